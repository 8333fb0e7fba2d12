"""How far does retraining move the claims' numbers? Train the models behind them again with other seeds.

A chapter judges a claim on one trained model: its interval (sampling seeds, test clips) says how well that model was
measured, not where another training run would land, and a different CPU or precision is a different training run. A
study trains the models again with seeds 1, 2, ... (seed 0 is the book's) and scores every seed with its chapter's
own evaluation at the profile's sizes:

- ``discord``: the whole chain behind DisCoRD's Table 1 claims, ``tokenizer/rvq-seed<k>`` and ``discord/rvq-seed<k>``
  on its tokens, scored by chapter 05's :func:`~motionlab.evaluation.evaluate_reconstruction` (without the timing,
  which measures the machine rather than the models);
- ``m2d2m``: the text-to-motion models behind M2D2M's claims on the book's VQ tokens, ``t2m/multi-eta0.25-seed<k>``
  (chapter 09's multi-motion table), ``t2m/uniform-seed<k>`` (its TPS row, Table 5) and ``t2m/dynamic-seed<k>``
  (chapter 07's guidance claim, s = 0 against s = 4);
- ``transitions``: chapter 08's two arms, ``t2m/dynamic-seed<k>`` against ``t2m/uniform-seed<k>`` (M2D2M's Table 3
  claim, single motions at s = 4), scored with chapter 08's evaluation. The book trains seed 0 of each arm only.

::

    python experiments/training_seeds.py --study discord --seeds 0 1 2   # laptop: ~18 CPU-min per new seed (bf16)
    python experiments/training_seeds.py --study m2d2m --seeds 0 1 2     # laptop: 7 to 10 CPU-min per seed (bf16)
    python experiments/training_seeds.py --study transitions --seeds 0 1 2   # laptop: ~2.5 CPU-min per new seed (fp32)

(The bf16 times are Zen 5's; in fp32 on an AVX2-only Zen 3 a new discord seed took ~38 CPU-min, an m2d2m seed ~12;
the records' ``seconds`` hold each run's own.)

Each seed's numbers go to ``<out>/<study>-<profile>-<precision>-seed<k>.json`` (written atomically; an existing one is
skipped; a run in another precision, on another machine, is another file) with the data, the machine, the precision,
the commit, the time spent, the resolved configs of the models and evaluations (``"configs"``,
:func:`motionlab.evaluation.studies.study_configs`: a run whose configs are no longer the code's is set aside when the
claims table reads the folder) and ``{"values": {"discord/sjpe_rf": ...}}``, every claim number the study's tables give
(:func:`motionlab.evaluation.reconstruction_claim_cells`, :func:`~motionlab.evaluation.multi_claim_cells`). The
claims table reads the folder (:mod:`motionlab.report.spread`) and adds to each comparison it judges the spread it
finds there, pooling the runs of every precision.
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
from motionlab.evaluation import evaluate_multi, evaluate_reconstruction, evaluate_t2m
from motionlab.evaluation.studies import (
    StudyPlan,
    m2d2m_values,
    reconstruction_values,
    study_configs,
    study_plan,
    transitions_values,
)

OUT = Path(__file__).resolve().parents[1] / "book" / "data" / "training_seeds" / f"embedded-v{VERSION}"


def _discord(plan: StudyPlan, dataset, profile: str) -> tuple[dict[str, float], list[str]]:
    """DisCoRD's chain of the plan's seed scored with chapter 05's evaluation (no timing)."""
    config = plan.evaluations["reconstruction"]
    table = evaluate_reconstruction(dataset, config, profile)
    values = {key: e.mean for key, e in reconstruction_values(table, config).items()}
    return values, [config.command_line(profile)]


def _m2d2m(plan: StudyPlan, dataset, profile: str) -> tuple[dict[str, float], list[str]]:
    """M2D2M's text-to-motion models of the plan's seed scored with chapter 09's and chapter 07's evaluations: the
    multi-motion table of the multi-motion model, TPS of the uniform model, and guidance s = 0 vs 4 of the dynamic
    one. Only the diffusion models are retrained; every seed reads the book's VQ tokens."""
    paper, arms, guidance = (plan.evaluations[role] for role in ("multi", "multi_uniform", "guidance"))
    table, uniform_table = evaluate_multi(dataset, paper, profile), evaluate_multi(dataset, arms, profile)
    t2m = evaluate_t2m(dataset, guidance, profile)
    values = {key: e.mean for key, e in m2d2m_values(table, uniform_table, t2m, guidance).items()}
    return values, [c.command_line(profile) for c in (paper, arms, guidance)]


def _transitions(plan: StudyPlan, dataset, profile: str) -> tuple[dict[str, float], list[str]]:
    """Chapter 08's comparison at the plan's seed: the dynamic arm (the paper's η) against the uniform one (η = 0),
    single motions at s = 4, scored with chapter 08's evaluation (its sizes, the two arms alone). The book trains seed 0
    of each arm; this study's seeds give the spread its verdict adds."""
    config = plan.evaluations["t2m"]
    table = evaluate_t2m(dataset, config, profile)
    values = {key: e.mean for key, e in transitions_values(table, config).items()}
    return values, [config.command_line(profile)]


STUDIES = {"discord": _discord, "m2d2m": _m2d2m, "transitions": _transitions}


def _train(names: list[str], dataset, profile: str) -> None:
    for name in names:  # trained here on first use, so that the training time is their own
        models.load(name, dataset, profile)


def score(study: str, training_seed: int, profile: str) -> dict:
    """Train (or load) ``study``'s models of ``training_seed`` and score them: the claim numbers by key, with the
    configs they were measured with (:func:`motionlab.evaluation.studies.study_configs`)."""
    dataset = models.load("data", None, profile)
    plan = study_plan(study, training_seed, profile)
    start, cpu = time.perf_counter(), time.process_time()
    _train(list(plan.models), dataset, profile)
    values, commands = STUDIES[study](plan, dataset, profile)
    spent = {"seconds": round(time.perf_counter() - start, 1), "cpu_seconds": round(time.process_time() - cpu, 1)}
    return {
        "data": dataset.key,
        "models": list(plan.models),
        "commands": commands,
        "configs": study_configs(study, profile),
        "seconds": spent,
        "values": values,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", choices=sorted(STUDIES), default="discord", help="whose models (default: discord)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="training seeds (0: the book's)")
    parser.add_argument("--profile", default="laptop", help="the sizes of the models and evaluations (default: laptop)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    if any(s < 0 for s in args.seeds):
        parser.error("--seeds must be >= 0")
    torch.set_num_threads(1)  # one process per experiment on a shared machine
    args.out.mkdir(parents=True, exist_ok=True)
    precision = machine_stamp()["precision"]  # a run in another precision is another run: its own file
    for seed in args.seeds:
        record = lambda seed=seed: {  # noqa: E731
            "study": args.study,
            "training_seed": seed,
            "profile": args.profile,
            **machine_stamp(),
            **score(args.study, seed, args.profile),
        }
        path = args.out / f"{args.study}-{args.profile}-{precision}-seed{seed}.json"
        record_once(path, f"{args.study} seed {seed}", record, "training (or loading) the models and scoring them")
    return 0


if __name__ == "__main__":
    sys.exit(main())
