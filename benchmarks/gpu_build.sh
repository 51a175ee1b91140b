#!/usr/bin/env bash
# Builds the engine and its Python module on the GPU machine, which reaches no package
# registry: plain CMake with the machine's own Python and pybind11 (run after
# `source .gpu/prelude.sh`). The module is copied next to the package so that
# `PYTHONPATH=python python3 -m cressim ...` works there.
set -euo pipefail
cd "$(dirname "$0")/.."
py=$(command -v "${PYTHON:-python3}")
cmake -S . -B build/gpu -G Ninja -DCMAKE_BUILD_TYPE=Release -DCRESSIM_TESTS=${CRESSIM_TESTS:-ON} \
  -DPython_EXECUTABLE="$py" -Dpybind11_DIR="$("$py" -m pybind11 --cmakedir)" > build-gpu-configure.log
cmake --build build/gpu -j "$(nproc)" > build-gpu.log || { tail -50 build-gpu.log; exit 1; }
cp build/gpu/engine/_core*.so python/cressim/
echo "built $(ls python/cressim/_core*.so)"
