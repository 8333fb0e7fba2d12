"""Does a verdict of M2D2M depend on where classifier-free guidance acts? Score the book's models both ways.

M2D2M's Eq. 9 guides p_θ(x_{t-1} | x_t, y); VQ-Diffusion's public code, which the paper builds on, guides the
network's prediction p_θ(x_0 | x_t, y), and so does the book's sampler (``guidance_on="x0"``). This experiment scores
the book's seed-0 text-to-motion models with each (:func:`motionlab.evaluation.studies.guidance_evaluations`: chapter
09's multi-motion table and TPS of the uniform model at s = 2, chapter 07's guidance rows at s = 0 and 4, chapter 08's
two arms at s = 4, all at the chapters' sizes and seeds) and keeps every claim number M2D2M's rows read. Both spaces
are scored here, on the same models, machine and precision, so that the guidance space is the only difference;
study s7 (*Where the laptop departs from the papers*) judges each guided claim under both.

::

    python experiments/guidance_space.py --spaces x0 posterior   # laptop: ~8 CPU-min per space (bf16, Zen 4)
    python experiments/guidance_space.py --spaces posterior &     # or one process per space, side by side
    python experiments/guidance_space.py --spaces x0

Each space's numbers go to ``<out>/<profile>-<precision>-<space>.json`` (written atomically; an existing one is
skipped) with the machine, the precision, the commit, the data, the time spent, the resolved configs of the models
and evaluations (``"configs"``, :func:`~motionlab.evaluation.studies.guidance_configs`: a record whose configs are no
longer the code's is set aside when the book reads the folder), the claim numbers with their intervals
(``"values"``) and the evaluation tables. The models are the model cache's (trained here on first use, as a book
build trains them).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

from motionlab import models
from motionlab.build.stamp import machine_stamp, record_once
from motionlab.data.embedded.generator import VERSION
from motionlab.diffusion.sampling import GUIDANCE_SPACES
from motionlab.evaluation.studies import guidance_configs, guidance_evaluations
from motionlab.studies.scale import SCORERS, estimate_json

OUT = Path(__file__).resolve().parents[1] / "book" / "data" / "guidance_space" / f"embedded-v{VERSION}"


def score(guidance_on: str, profile: str) -> dict:
    """The claim numbers of the book's models sampled with guidance on ``guidance_on``, with what they depend on."""
    dataset = models.load("data", None, profile)
    evaluations = guidance_evaluations(guidance_on, profile)
    start, cpu = time.perf_counter(), time.process_time()
    values, tables = SCORERS["m2d2m"](evaluations, dataset, profile, None)  # the scale study's m2d2m scoring
    spent = {"seconds": round(time.perf_counter() - start, 1), "cpu_seconds": round(time.process_time() - cpu, 1)}
    return {
        "data": dataset.key,
        "commands": [config.command_line(profile) for config in evaluations.values()],
        "configs": guidance_configs(guidance_on, profile),
        "seconds": spent,
        "values": {key: estimate_json(e) for key, e in values.items()},
        "tables": tables,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spaces", nargs="+", choices=GUIDANCE_SPACES, default=list(GUIDANCE_SPACES))
    parser.add_argument("--profile", default="laptop", help="the sizes of the models and evaluations (default: laptop)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)  # one process per experiment on a shared machine
    args.out.mkdir(parents=True, exist_ok=True)
    precision = machine_stamp()["precision"]
    for space in args.spaces:
        record = lambda space=space: {  # noqa: E731
            "study": "guidance_space",
            "guidance_on": space,
            "profile": args.profile,
            **machine_stamp(),
            **score(space, args.profile),
        }
        path = args.out / f"{args.profile}-{precision}-{space}.json"
        record_once(path, space, record, f"scoring the book's models with guidance on {space}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
