"""How far does retraining move DisCoRD's claim numbers? Train the chain behind them again with other seeds.

Chapter 05 judges DisCoRD's Table 1 claims on one trained RVQ tokenizer and one DisCoRD decoder, decoded at
temperature 0: the numbers carry no interval, so a verdict says nothing about the training run's own variance, and a
different CPU or precision (a different training run) can flip it. This study trains the whole chain again with
seeds 1, 2, ... (``tokenizer/rvq-seed<k>``, then ``discord/rvq-seed<k>`` on its tokens; seed 0 is the book's pair)
and scores every seed with chapter 05's evaluation (:func:`motionlab.evaluation.evaluate_reconstruction` at the
profile's sizes, without the timing, which measures the machine rather than the models)::

    python experiments/training_seeds.py --seeds 0 1 2          # laptop: about 12 CPU-minutes per new seed (bf16)

Each seed's numbers go to ``<out>/discord-<profile>-seed<k>.json`` (written atomically; an existing one is skipped)
with the machine, the precision, the commit and the training time: ``{"values": {key: value}}`` for every
``discord/<key>`` the claims table judges (:func:`motionlab.evaluation.claim_cells`). The claims table reads the
folder (:mod:`motionlab.report.spread`) and widens each DisCoRD comparison by the spread it finds there.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import torch

from motionlab import models
from motionlab.data.embedded.generator import VERSION
from motionlab.evaluation import ReconstructionConfig, claim_cells, evaluate_reconstruction
from motionlab.io.common import write_text_atomic
from motionlab.precision import read_cpu_info, resolve_precision
from motionlab.sizes import chapter_sizes

OUT = Path(__file__).resolve().parents[1] / "book" / "data" / "training_seeds" / f"embedded-v{VERSION}"


def _commit() -> str | None:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        return None
    return out.stdout.strip() or None


def score(training_seed: int, profile: str) -> dict:
    """Train (or load) the chain of ``training_seed`` and score it with chapter 05's evaluation (no timing)."""
    dataset = models.load("data", None, profile)
    config = ReconstructionConfig.from_sizes(chapter_sizes(profile).discord, training_seed=training_seed)
    config = replace(config, timing_repeats=0)
    start, cpu = time.perf_counter(), time.process_time()
    for name in config.book_models():  # trained here on first use, so that the training time is their own
        models.load(name, dataset, profile)
    training = {"seconds": round(time.perf_counter() - start, 1), "cpu_seconds": round(time.process_time() - cpu, 1)}
    table = evaluate_reconstruction(dataset, config, profile)
    values = {key: table.estimate(row, metric).mean for key, (row, metric) in claim_cells(table, config).items()}
    return {
        "data": dataset.key,
        "training": training,
        "models": config.book_models(),
        "command": config.command_line(profile),
        "values": values,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="training seeds (0: the book's)")
    parser.add_argument("--profile", default="laptop", help="the sizes of the models and evaluations (default: laptop)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    if any(s < 0 for s in args.seeds):
        parser.error("--seeds must be >= 0")
    torch.set_num_threads(1)  # one process per experiment on a shared machine
    args.out.mkdir(parents=True, exist_ok=True)
    for seed in args.seeds:
        path = args.out / f"discord-{args.profile}-seed{seed}.json"
        if path.exists():
            print(f"seed {seed}: recorded already ({path})", file=sys.stderr)
            continue
        print(f"seed {seed}: training (or loading) the chain and scoring it", file=sys.stderr)
        record = {
            "study": "discord",
            "training_seed": seed,
            "profile": args.profile,
            "cpu": read_cpu_info().summary,
            "machine": platform.machine(),
            "precision": resolve_precision(),
            "torch_threads": torch.get_num_threads(),
            "commit": _commit(),
            **score(seed, args.profile),
        }
        write_text_atomic(path, json.dumps(record, indent=1) + "\n")
        print(f"seed {seed}: wrote {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
