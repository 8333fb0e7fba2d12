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
# The scale study continues from the records committed under book/data/scale/embedded-v<N>/. After the lease, copy
# $OUT/scale/*.json (the points this run added) there and commit them, and replace _build/gpu-carry/ with the run's
# $OUT/scale-cache.tgz.* parts (the models the remaining points need, and a training cut off, saved at the step it
# reached): name _build/gpu-carry in the next lease's carry, and that lease resumes where this one stopped.
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${OUT:-_build/gpu}
mkdir -p "$OUT"
# absolute: the tests start Python in other folders (a worker, torchrun's ranks), where a relative src/ finds nothing
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH}

if [ -n "${SCALE_ONLY:-}" ]; then
  version=$(python -c "from motionlab.data.embedded.generator import VERSION; print(VERSION)")
  committed=book/data/scale/embedded-v"$version"
  records=${SCALE_RECORDS:-/tmp/scale-records}
  export MOTIONLAB_HOME=${MOTIONLAB_HOME:-/tmp/motionlab-home}
  rm -rf "$records" && mkdir -p "$records" "$OUT/scale"
  cp "$committed"/*.json "$records/" 2>/dev/null  # the points recorded so far: the run goes on after them
  carry_in=()
  [ -d _build/gpu-carry ] && carry_in=(--carry-in _build/gpu-carry)  # the last lease's scale-cache.tgz.* parts
  # stopped from outside at SCALE_SECONDS (SIGINT): a training cut off saves the step it reached, packed into $OUT
  # on the way out
  timeout -s INT -k 60 "${SCALE_SECONDS:-510}" python experiments/scale.py --device "${SCALE_DEVICE:-cuda}" \
    --minutes "${SCALE_MINUTES:-8}" --out "$records" "${carry_in[@]}" --carry-out "$OUT" --carry-parts 4 \
    ${SCALE_ARGS:-} > "$OUT/scale.txt" 2>&1
  echo "scale exit $?" >> "$OUT/scale.txt"
  for f in "$records"/*.json; do  # only what this run added or measured again: a lease returns at most 8 files
    [ -e "$f" ] && ! cmp -s "$f" "$committed/$(basename "$f")" && cp "$f" "$OUT/scale/"
  done
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
  MOTIONLAB_DEVICE=${TEST_DEVICE:-cuda} MOTIONLAB_PROFILE=smoke timeout "${TEST_TIMEOUT:-420}" \
    python -m pytest -q tests --ignore=tests/book -p no:cacheprovider -o addopts="-m 'not slow'" -rfEs \
    --continue-on-collection-errors \
    > "$OUT/pytest-cuda.txt" 2>&1
  echo "pytest exit $?" >> "$OUT/pytest-cuda.txt"
fi
