#!/usr/bin/env bash
# One-time set-up of a fresh Debian/Ubuntu machine with Python 3.10+ (idempotent: re-running
# it on a set-up machine takes seconds). Installs the system libraries open3d and pymeshlab
# need, a CPU-only torch, then the toolkit itself with its test extras.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}

# System libraries: open3d needs libusb-1.0 and libgomp; pymeshlab needs libGL/libOpenGL.
if command -v apt-get >/dev/null 2>&1; then
  SUDO=""
  [ "$(id -u)" = 0 ] || SUDO="sudo"
  need=""
  for pkg in libusb-1.0-0 libgl1 libopengl0 libgomp1 libegl1; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need="$need $pkg"
  done
  if [ -n "$need" ]; then
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $need
  fi
fi

# torch: a CPU build first, so that the project's 'torch>=2.2' does not pull a CUDA build.
# TORCH_SPEC / TORCH_INDEX let other machines choose, e.g.
#   TORCH_SPEC=torch TORCH_INDEX=https://download.pytorch.org/whl/cpu bash .ci/setup.sh
if ! $PY -c "import torch" >/dev/null 2>&1; then
  if [ -n "${TORCH_INDEX:-}" ]; then
    $PY -m pip install -q "${TORCH_SPEC:-torch}" --index-url "$TORCH_INDEX"
  else
    $PY -m pip install -q "${TORCH_SPEC:-torch==2.13.0}"
  fi
fi

$PY -m pip install -q -e ".[test]"
