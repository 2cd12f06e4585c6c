#!/usr/bin/env bash
# Installs raycloth's dependencies (Debian 12 packages) and builds it in ./build.
# The CUDA backend is built too when nvcc is found (e.g. /usr/local/cuda/bin/nvcc).
# ffmpeg is only run by `raycloth run --video` / `raycloth render --video`; it is installed so that
# the tests take the real video path. The Python module (build/python) is built with the system's
# /usr/bin/python3, which has python3-numpy and python3-pytest.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(cmake ninja-build g++ pkg-config libembree-dev libtbb-dev nlohmann-json3-dev libcli11-dev
          libtinyobjloader-dev libspdlog-dev libfmt-dev libstb-dev libtinygltf-dev libgtest-dev
          libbenchmark-dev libcgal-dev ffmpeg chromium
          python3-dev python3-pybind11 pybind11-dev python3-numpy python3-pytest)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

cuda_args=()
if ! command -v nvcc >/dev/null && [ -x /usr/local/cuda/bin/nvcc ]; then
  cuda_args+=("-DCMAKE_CUDA_COMPILER=/usr/local/cuda/bin/nvcc")
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DRAYCLOTH_VALIDATE="${RAYCLOTH_VALIDATE:-OFF}" "${cuda_args[@]}"
cmake --build build -j "$(nproc)"
