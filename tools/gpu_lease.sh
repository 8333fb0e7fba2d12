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
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-_build/gpu}
mkdir -p "$OUT"
export PYTHONPATH=src${PYTHONPATH:+:$PYTHONPATH}

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
