"""At what training budget do M2D2M's claims hold? Train the text-to-motion models far past the laptop budget and score
each budget with one fixed evaluator (issue 35's budget study; chapter 05's DisCoRD budget curve, for M2D2M).

A model is ``t2m/<arm>-seed<k>-steps<n>`` (:func:`motionlab.models.load`): the laptop profile's text-to-motion model
of ``arm`` (``dynamic``: M2D2M's β(t, d) at the paper's η = 0.5; ``uniform``: VQ-Diffusion's, η = 0) with training
seed ``k``, trained for ``n`` steps with its learning-rate drop stretched to them (the laptop profile trains 800;
``-steps800`` *is* the book's model). Each is trained once into the model cache (resumable: its checkpoints stay
there) and then scored with the book's evaluations at chapter 07's and chapter 09's laptop sizes:

- ``evaluate_t2m`` at guidance scales 0, 1, 2 and 4: FID, R-precision, MM-Dist, Diversity (the guidance claim and
  dynamic vs uniform on single motions);
- ``evaluate_multi`` of ``independent``, ``tps``, ``tps:T_s=50`` and ``handshake:transition=40``: transition Jerk,
  the Jerk inside the actions, per-action FID (TPS vs independent, TPS vs Handshake, the T_s trade-off, and dynamic
  vs uniform under TPS).

One process per arm, one torch thread each, so two arms share a 2-core machine fairly; budgets run in the order
given, so the short ones arrive first::

    python experiments/m2d2m_budget.py --arm dynamic --seeds 0 1 2 --steps 800 1600 3200 6400 8000 &
    python experiments/m2d2m_budget.py --arm uniform --seeds 0 1 2 --steps 800 1600 3200 6400 8000 &

The η axis (issue 35): ``--etas 1 2 4 8`` trains the dynamic model at each η for the profile's steps
(``t2m/eta<η>``) and scores it the same way, into ``book/data/m2d2m_eta/embedded-v<N>/eta<η>.json``.

Every model's result goes to ``<out>/<arm>-seed<k>-steps<n>.json`` (written atomically; an existing one is skipped)
with the machine, the precision, the commit, the training time and the model's training config (``"configs"``; the
tables carry their evaluations' configs): a file whose configs are no longer the code's is set aside when the book
reads the folder (:func:`motionlab.report.spread.read_current`). One folder per version of the embedded data
(``book/data/m2d2m_budget/embedded-v<N>/``), which the chapters read.
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
from motionlab.evaluation import evaluate_multi, evaluate_t2m
from motionlab.evaluation.studies import budget_evaluations, budget_model_config

ARMS = ("dynamic", "uniform")
OUT = Path(__file__).resolve().parents[1] / "book" / "data" / "m2d2m_budget" / f"embedded-v{VERSION}"
ETA_OUT = OUT.parents[1] / "m2d2m_eta" / f"embedded-v{VERSION}"


def model_name(arm: str, seed: int, steps: int) -> str:
    return f"t2m/{arm}-seed{seed}-steps{steps}"


def score(name: str, profile: str) -> dict:
    """Train (or load) ``name`` and score it at the chapters' sizes of ``profile``: both tables as JSON dicts (each
    carries its evaluation's config) and the training time."""
    dataset = models.load("data", None, profile)
    start, cpu = time.perf_counter(), time.process_time()
    models.load(name, dataset, profile)  # trained here on first use, so that its time is its own
    training = {"seconds": round(time.perf_counter() - start, 1), "cpu_seconds": round(time.process_time() - cpu, 1)}
    evaluations = budget_evaluations(name, profile)
    return {
        "training": training,
        "t2m": evaluate_t2m(dataset, evaluations["t2m"], profile).to_json_dict(),
        "multi": evaluate_multi(dataset, evaluations["multi"], profile).to_json_dict(),
    }


DOING = "training (or loading) and scoring"


def _measured(stamp: dict, profile: str) -> dict:
    """One model's record: ``stamp`` (what names it), the machine, its training config and its scores."""
    record = {**stamp, **machine_stamp()}
    return record | {"configs": {"model": budget_model_config(record, profile)}, **score(stamp["model"], profile)}


def eta_axis(etas: list[float], profile: str, out: Path) -> None:
    """The η axis at the profile's budget: the dynamic model at each η (``t2m/eta<η>``, training seed 0), scored like
    a budget; ``<out>/eta<η>.json`` each. The total variation from the uniform process is chapter 08's to compute."""
    from motionlab.evaluation.t2m import eta_model

    for eta in etas:
        name = eta_model(eta)
        stamp = {"model": name, "eta": eta, "training_seed": 0, "profile": profile}
        record_once(out / f"eta{eta:g}.json", name, lambda stamp=stamp: _measured(stamp, profile), DOING)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arm", choices=ARMS, help="the arm whose budgets to train (or --etas)")
    parser.add_argument(
        "--etas", type=float, nargs="+", help="instead: the dynamic model at each η, the profile's steps"
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--steps", type=int, nargs="+", default=[800, 1600, 3200, 6400, 8000])
    parser.add_argument("--profile", default="laptop", help="the sizes of the models and evaluations (default: laptop)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    if (args.arm is None) == (args.etas is None):
        parser.error("give --arm (the budget study) or --etas (the η axis)")
    if any(s < 1 for s in args.steps) or any(s < 0 for s in args.seeds):
        parser.error("--steps must be >= 1 and --seeds >= 0")
    torch.set_num_threads(1)  # one process per arm on a shared machine
    if args.etas is not None:
        out = ETA_OUT if args.out == OUT else args.out
        out.mkdir(parents=True, exist_ok=True)
        eta_axis(args.etas, args.profile, out)
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    for steps in args.steps:
        for seed in args.seeds:
            name = model_name(args.arm, seed, steps)
            stamp = {"model": name, "arm": args.arm, "training_seed": seed, "steps": steps, "profile": args.profile}
            path = args.out / f"{name.removeprefix('t2m/')}.json"
            record_once(path, name, lambda stamp=stamp: _measured(stamp, args.profile), DOING)
    return 0


if __name__ == "__main__":
    sys.exit(main())
