#!/usr/bin/env bash
# Builds the libFuzzer harnesses of the input readers (fuzz/: scene JSON, OBJ, glTF) with clang in
# ./build-fuzz and runs each for SECONDS (default 60), one after the other, from the seed corpora in
# fuzz/corpus/<name>/ (what a run adds goes to build-fuzz/corpus/<name>/, not into the repository).
# A crash, a hang (-timeout), a sanitizer report, a memory blow-up (-rss_limit_mb) or an error
# message that is not "FILE: FIELD: REASON" stops it with a non-zero status; the input is left in
# build-fuzz/artifacts/<name>/. Keep each such input in tests/data/fuzz/ with a test
# (tests/test_fuzz_regressions.cpp).
#   ./scripts/fuzz.sh [SECONDS]   e.g. ./scripts/fuzz.sh 1800 for the 30-minute runs
# Needs clang and the libraries scripts/setup.sh installs.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
if ! command -v clang++ >/dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends clang
fi
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ -DRAYCLOTH_FUZZ=ON
cmake --build build-fuzz -j "$(nproc)"
export ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
status=0
for name in scene obj gltf; do
  corpus="build-fuzz/corpus/$name" artifacts="build-fuzz/artifacts/$name"
  mkdir -p "$corpus" "$artifacts"
  echo "fuzz_$name: $seconds s"
  if ! build-fuzz/fuzz/fuzz_$name -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
      -artifact_prefix="$artifacts/" "$corpus" "fuzz/corpus/$name" > "build-fuzz/fuzz_$name.log" 2>&1; then
    status=1
    echo "fuzz_$name FAILED: see build-fuzz/fuzz_$name.log and $artifacts/"
    tail -n 40 "build-fuzz/fuzz_$name.log"
  fi
  grep -E "^stat::number_of_executed_units|^Done " "build-fuzz/fuzz_$name.log" || true
done
exit "$status"
