#!/usr/bin/env bash
# Packs a CUDA-enabled build for a GPU machine that has none of the project's dependencies installed
# (a bare CUDA image): the command line, the test and benchmark programs and every shared library
# they load except the C library, into .gpu/rc.tar.xz (ignored by git). scripts/gpu_check.sh unpacks
# and runs it there.
#   scripts/gpu_pack.sh [BUILD_DIR]   (default build; it must have been configured with nvcc found)
# EXTRA="path ..." adds further programs (e.g. build-bullet/raycloth_vs_bullet, built with
# -DRAYCLOTH_BULLET=ON), with their libraries.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
grep -q 'RAYCLOTH_HAS_CUDA\|CMAKE_CUDA_COMPILER:' "$build/CMakeCache.txt" || { echo "gpu_pack: $build has no CUDA compiler" >&2; exit 1; }
stage=$(mktemp -d)
mkdir -p "$stage/bin" "$stage/lib"
bins=("$build/raycloth" "$build/tests/raycloth_tests" "$build/bench/raycloth_bench")
for extra in ${EXTRA:-}; do bins+=("$extra"); done
for b in "${bins[@]}"; do strip -o "$stage/bin/$(basename "$b")" "$b"; done
# Every library the programs load, by the name they ask for, less glibc's own (the target's is used).
for lib in $(ldd "${bins[@]}" | awk '/=>/ {print $3}' | sort -u); do
  case $(basename "$lib") in libc.so*|libm.so*|libdl.so*|libpthread.so*|librt.so*|ld-linux*) continue ;; esac
  cp -L "$lib" "$stage/lib/"
done
# The tests find the repository at the path baked in at configure time: the check links it there.
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt" > "$stage/source_dir"
mkdir -p .gpu
tar -C "$stage" -cf - bin lib source_dir | xz -T2 -6 > .gpu/rc.tar.xz
rm -rf "$stage"
ls -la .gpu/rc.tar.xz
