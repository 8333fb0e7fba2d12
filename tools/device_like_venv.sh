#!/usr/bin/env bash
# A virtual environment with the GPU machine's Python, torch and packages (not the project's pins), for dry runs of
# tools/gpu_lease.sh on a CPU before a lease: the lease runs under that image's python3, where an API the pinned torch
# has, or a package the book's tooling brings (nbformat, ipywidgets), may be missing. What it holds follows the
# device's page of packages (Python 3.12, torch 2.11, numpy 2.5.2, einops, torchdiffeq, scipy, matplotlib, tqdm,
# safetensors, pyyaml, pytest, hypothesis); nothing of the book's tooling. About 5 GB (torch's CUDA build from PyPI:
# it runs on the CPU here), a few minutes to install.
#
#     tools/device_like_venv.sh /tmp/device-venv
#     PATH=/tmp/device-venv/bin:$PATH BENCH_ARGS=--smoke BENCH_ONLY=1 OUT=/tmp/lease tools/gpu_lease.sh
#     PATH=/tmp/device-venv/bin:$PATH TEST_DEVICE=cpu TESTS_ONLY=1 OUT=/tmp/lease tools/gpu_lease.sh
#     PATH=/tmp/device-venv/bin:$PATH SCALE_ONLY=1 SCALE_DEVICE=cpu SCALE_ARGS=--smoke OUT=/tmp/lease tools/gpu_lease.sh
set -euo pipefail
dest=${1:?usage: tools/device_like_venv.sh DEST}
python=${DEVICE_PYTHON:-}
if [ -z "$python" ]; then
  # A pyenv shim answers `command -v` and then refuses to run, so each candidate has to start.
  for candidate in "$(pyenv root 2>/dev/null)/versions/3.12"*/bin/python3.12 python3.12; do
    if "$candidate" -c "" >/dev/null 2>&1; then python=$(command -v "$candidate"); break; fi
  done
fi
[ -n "$python" ] || { echo "no Python 3.12 found: set DEVICE_PYTHON to one" >&2; exit 2; }
"$python" -m venv "$dest"
"$dest/bin/pip" install -q torch==2.11.0 numpy==2.5.2 torchdiffeq==0.2.5 safetensors==0.8.0 einops scipy matplotlib \
  tqdm pyyaml pytest hypothesis
"$dest/bin/python" -c "import sys, torch, numpy; print(sys.version.split()[0], torch.__version__, numpy.__version__)"
