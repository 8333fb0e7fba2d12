"""Does bf16 training lose quality? Train the laptop models in one precision and score them, for a side-by-side.

One run of this script is one precision: it trains (or loads) the laptop models that the parity table needs, in
order, through the same CLI a reader uses (``motionlab --precision P train ...``), timing each command (wall and
CPU of the child process), then scores them with the book's evaluations:

- ``evaluate reconstruction --decoder discord`` (RVQ tokens): the tokenizer's MPJPE, FID and sJPE (feed-forward
  row) and the DisCoRD decoder's (flow row);
- ``evaluate t2m``: the diffusion model's FID and R-precision, and the real motions' R-precision.

Both precisions score with the same evaluator: the library trains it in fp32 whatever the run's precision (it is a
metric, and bf16 does not speed it up). Its own parity is measured apart (``--evaluator``): the evaluator trained in
this precision, uncached, at the laptop budget, and its validation retrieval accuracy.

Run the two precisions side by side, one torch thread each, so that both see the same machine::

    python experiments/precision_parity.py --precision fp32 --out book/data/precision_parity &
    python experiments/precision_parity.py --precision bf16 --out book/data/precision_parity &
    python experiments/precision_parity.py --precision fp32 --out book/data/precision_parity --evaluator &   # after
    python experiments/precision_parity.py --precision bf16 --out book/data/precision_parity --evaluator &

Writes ``<out>/<precision>.json``: the machine, the per-model training times and both evaluation tables.
Chapter 98 reads the folder.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from motionlab.io.common import write_text_atomic
from motionlab.precision import read_cpu_info, resolve_precision

MODELS = ("rvq", "discord", "vq", "diffusion", "evaluator")  # `motionlab train` names, inputs first


def run(args: list[str], env: dict[str, str]) -> dict[str, float]:
    """Run ``motionlab ARGS`` to completion; its wall and CPU seconds (user + system of the child)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "motionlab", *args], env=env, check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"seconds": round(wall, 1), "cpu_seconds": round(cpu, 1)}


def add_evaluator_parity(args: argparse.Namespace) -> None:
    """Train the laptop evaluator in ``args.precision`` (no cache) and add its training time and final validation
    retrieval scores to ``<out>/<precision>.json``."""
    import torch

    from motionlab.data import load_dataset
    from motionlab.metrics.evaluator_training import (
        EvaluatorNetworks,
        build_vocabulary,
        evaluator_config,
        evaluator_trainer,
    )

    torch.set_num_threads(1)
    dataset = load_dataset(args.data, profile=args.profile)
    config = evaluator_config(args.profile)
    vocabulary = build_vocabulary(dataset, config)
    model = EvaluatorNetworks(config.evaluator, len(vocabulary), torch.Generator().manual_seed(config.seed))
    trainer = evaluator_trainer(model, dataset, vocabulary, config, precision=args.precision)
    wall, cpu = time.perf_counter(), time.process_time()
    trainer.fit()
    timing = {"seconds": round(time.perf_counter() - wall, 1), "cpu_seconds": round(time.process_time() - cpu, 1)}
    path = args.out / f"{args.precision}.json"
    record = json.loads(path.read_text())
    record["evaluator_parity"] = {"validation": trainer.validate(), "steps": trainer.step, **timing}
    write_text_atomic(path, json.dumps(record, indent=1) + "\n")
    print(f"{args.precision}: evaluator {record['evaluator_parity']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--precision", choices=["fp32", "bf16"], required=True)
    parser.add_argument("--profile", default="laptop")
    parser.add_argument("--repeats", type=int, default=5, help="evaluation repeats for the 95%% intervals")
    parser.add_argument("--data", default=None, help="a dataset folder (default: the embedded dataset of the profile)")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument(
        "--evaluator",
        action="store_true",
        help="only train the evaluator in this precision and add its validation scores to the record",
    )
    args = parser.parse_args()
    if args.evaluator:
        return add_evaluator_parity(args)
    data = ["--data", args.data] if args.data else []
    env = {
        **os.environ,
        "MOTIONLAB_PRECISION": args.precision,
        "MOTIONLAB_PROFILE": args.profile,
        "MOTIONLAB_THREADS": "1",
        "OMP_NUM_THREADS": "1",
    }
    args.out.mkdir(parents=True, exist_ok=True)
    record = {
        "precision": args.precision,
        "profile": args.profile,
        "cpu": read_cpu_info().summary,
        "machine": platform.machine(),
        "data": args.data or "embedded",
        "auto_here": resolve_precision("auto"),
        "training": {},
        "started": time.strftime("%Y-%m-%d %H:%M"),
    }
    for model in MODELS:
        record["training"][model] = run(["train", model, *data], env)
        print(f"{args.precision}: trained {model} {record['training'][model]}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for task, extra in (("reconstruction", ["--decoder", "discord"]), ("t2m", [])):
            path = Path(tmp) / f"{task}.json"
            seconds = run(["evaluate", task, *extra, *data, "--repeats", str(args.repeats), "--json", str(path)], env)
            record[task] = {"table": json.loads(path.read_text()), **seconds}
    write_text_atomic(args.out / f"{args.precision}.json", json.dumps(record, indent=1) + "\n")
    print(f"wrote {args.out / f'{args.precision}.json'}")


if __name__ == "__main__":
    main()
