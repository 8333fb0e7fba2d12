#!/usr/bin/env bash
# One lease of a GPU machine, prepared: the GPU benchmark at the papers' sizes, then the unit tests on CUDA.
#
# Runs from the repository root under the machine's own Python (torch with CUDA; einops and torchdiffeq for the
# official modules), with the library taken from src/. Results go to $OUT (default _build/gpu): gpu.json (the
# benchmark's records: copy it to book/data/gpu/<date>-<gpu>.json to show it in chapter 98), bench.txt and
# pytest-cuda.txt. The official repositories are used when a checkout of each sits in the git-ignored folder
# _official/ (whwjdqls/DisCoRD as _official/DisCoRD, EricGuo5513/momask-codes as _official/momask-codes): never
# committed, carried to the machine with the working tree.
#
#     BENCH_ONLY=1 tools/gpu_lease.sh     # the benchmark alone (about 5 minutes)
#     TESTS_ONLY=1 tools/gpu_lease.sh     # the tests alone (a device command may run 10 minutes: call twice)
#     tools/gpu_lease.sh                  # both, where one command may run longer
#     BENCH_ARGS="--smoke" BENCH_ONLY=1 tools/gpu_lease.sh   # a dry run on a CPU, in seconds
#     SCALE_ONLY=1 tools/gpu_lease.sh     # the scale study alone: its next points, for SCALE_MINUTES (8) of training
#     SCALE_ONLY=1 SCALE_DEVICE=cpu SCALE_ARGS="--smoke" tools/gpu_lease.sh   # its dry run on a CPU (about 2 minutes)
#
# The scale study continues from the records committed under book/data/scale/embedded-v<N>/ (copied to $OUT/scale
# first); copy $OUT/scale/*.json back there and commit them after the lease.
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-_build/gpu}
mkdir -p "$OUT"
export PYTHONPATH=src${PYTHONPATH:+:$PYTHONPATH}

if [ -n "${SCALE_ONLY:-}" ]; then
  version=$(python -c "from motionlab.data.embedded.generator import VERSION; print(VERSION)")
  mkdir -p "$OUT/scale"
  cp book/data/scale/embedded-v"$version"/*.json "$OUT/scale/" 2>/dev/null  # none yet: the run starts at 10x
  python experiments/scale.py --device "${SCALE_DEVICE:-cuda}" --minutes "${SCALE_MINUTES:-8}" --out "$OUT/scale" \
    ${SCALE_ARGS:-} > "$OUT/scale.txt" 2>&1
  echo "scale exit $?" >> "$OUT/scale.txt"
  exit 0
fi

official=()
[ -d _official/DisCoRD ] && official+=(--official-discord _official/DisCoRD)
[ -d _official/momask-codes ] && official+=(--official-momask _official/momask-codes)

if [ -z "${TESTS_ONLY:-}" ]; then
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv > "$OUT/bench.txt" 2>&1
  timeout "${BENCH_TIMEOUT:-420}" python benchmarks/bench_gpu.py --json "$OUT/gpu.json" "${official[@]}" ${BENCH_ARGS:-} >> "$OUT/bench.txt" 2>&1
  echo "bench_gpu exit $?" >> "$OUT/bench.txt"
fi

if [ -z "${BENCH_ONLY:-}" ]; then
  MOTIONLAB_DEVICE=cuda MOTIONLAB_PROFILE=smoke timeout "${TEST_TIMEOUT:-420}" \
    python -m pytest -q tests --ignore=tests/book -p no:cacheprovider -o addopts="-m 'not slow'" \
    > "$OUT/pytest-cuda.txt" 2>&1
  echo "pytest exit $?" >> "$OUT/pytest-cuda.txt"
fi
