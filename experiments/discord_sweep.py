"""Which DisCoRD decoder fits a laptop? Train variants under one wall-clock budget and score them on val.

Each variant is a set of :class:`~motionlab.flow.DisCoRDConfig` overrides on top of the laptop profile
(prediction target, normalisation, time distribution, width, learning rate). Its training run is sized to
the budget: a calibration of ``--calibrate`` steps measures the seconds per step on this machine, and the
run gets ``budget / (seconds per step)`` steps (the cosine schedule needs the total up front). At the given
fractions of the run the EMA weights are scored on the validation split under several *sampling* settings
(temperature, grid, final x̂1); the last checkpoint is scored with ``--seeds`` sampling seeds for intervals.

One process per variant, one torch thread each, so two variants share a 2-core machine fairly::

    python experiments/discord_sweep.py --list
    python experiments/discord_sweep.py x-w128 x-w128-lr3e-3 --budget 600 &
    python experiments/discord_sweep.py x-w128 --budget 2400 --fractions 0.125 0.25 0.5 0.75 1.0 --suffix=-40min &
    python experiments/discord_sweep.py v --budget 2400 --samplings T1 T0 --suffix=-40min &

Scoring every sampling setting at every fraction takes about as long as the training itself (the 40-minute run of
``v`` took 79 min of wall time); ``--samplings`` scores only the named ones. The first line of a run's log comes
after the calibration and the first fraction's scores, so a quiet log for the first 25 minutes or so is not a hang.

Every result goes to ``<out>/<variant>.json`` (written atomically), with the machine, the precision and the dataset
it was measured on; one folder per version of the embedded data (``book/data/discord_sweep/embedded-v<N>/``),
which chapter 05 reads.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from motionlab.data import load_dataset
from motionlab.flow import DisCoRDDecoder, discord_config
from motionlab.flow.discord import discord_loss_fn
from motionlab.flow.reconstruction import decode_clips, reconstruction_scores
from motionlab.flow.training import flow_validation, token_window_batches
from motionlab.io.common import write_text_atomic
from motionlab.metrics.evaluator_training import load_or_train_evaluator
from motionlab.precision import read_cpu_info
from motionlab.tokenizers import tokenizer_for_dataset
from motionlab.train import Trainer, WindowDataset

# Every variant starts from the laptop profile's sizes with the paper's parameterisation at width 272 (>= the 263
# features), so a result does not change when the profile's own choice does; then its overrides apply.
BASE = dict(width=272, prediction="v", normalization="std", time_distribution="uniform", temperature=1.0)

# Training-time choices: each variant is one trained model.
VARIANTS: dict[str, dict] = {
    # the paper's parameterisation at the laptop profile's former width (272 >= 263 features)
    "v": dict(prediction="v", normalization="std"),
    "v-feat": dict(prediction="v", normalization="feat_bias"),
    "x": dict(prediction="x", normalization="std"),
    # narrower U-Nets: several times cheaper per step, so several times more steps in the same budget
    "v-w128": dict(prediction="v", normalization="std", width=128),
    "x-w128": dict(prediction="x", normalization="std", width=128),
    "x-w64": dict(prediction="x", normalization="std", width=64),
    "x-w64-feat": dict(prediction="x", normalization="feat_bias", width=64),
    "x-w64-logit": dict(prediction="x", normalization="std", width=64, time_distribution="logit_normal", time_loc=0.5),
    "v-w64": dict(prediction="v", normalization="std", width=64),
    "x-w64-b16": dict(prediction="x", normalization="std", width=64, batch_size=16),
    "x-w64-lr3e-3": dict(prediction="x", normalization="std", width=64, lr=3e-3),
    # levers on the laptop decoder itself (x, width 128): smaller batches (more steps), a higher learning rate, a
    # slower EMA (averages away more of the late steps' weight noise)
    "x-w128-b16": dict(prediction="x", normalization="std", width=128, batch_size=16),
    "x-w128-lr3e-3": dict(prediction="x", normalization="std", width=128, lr=3e-3),
    "x-w128-ema999": dict(prediction="x", normalization="std", width=128, ema_decay=0.999),
}

# Sampling-time choices, scored on the same weights.
SAMPLINGS: dict[str, dict] = {
    "T1": dict(temperature=1.0),
    "T0.5": dict(temperature=0.5),
    "T0": dict(temperature=0.0),
    "T1-dense": dict(temperature=1.0, spacing="data_dense"),
    "T1-final": dict(temperature=1.0, final_prediction=True),  # x only
    "T0.5-final": dict(temperature=0.5, final_prediction=True),  # x only
    # between zero noise and 0.5, and the cheapest deterministic decode: Euler, 2 steps, from zero noise
    "T0.25": dict(temperature=0.25),
    "T0.1": dict(temperature=0.1),
    "T0-euler2": dict(temperature=0.0, solver="euler", sample_steps=2),
}


def samplings_for(prediction: str, names: list[str] | None = None) -> dict[str, dict]:
    """The sampling settings scored for a decoder that predicts ``prediction`` ("x" or "v"): ``names`` (default:
    every one of :data:`SAMPLINGS`), less the final-x̂1 ones, which only an x-predicting decoder has."""
    chosen = SAMPLINGS if names is None else {k: SAMPLINGS[k] for k in names}
    return {k: v for k, v in chosen.items() if prediction == "x" or not v.get("final_prediction")}


def score_decoder(
    decoder, tokenizer, normalized, gt, dataset, evaluator, gt_embeddings, seed: int
) -> tuple[dict, list[np.ndarray]]:
    """Reconstruction scores of one decode of the validation clips, and the decoded (normalised) clips."""
    recon = decode_clips(normalized, tokenizer, decoder, seed=seed)
    raw = [dataset.normalizer.denormalize(r) for r in recon]
    scores = reconstruction_scores(raw, gt, evaluator.embed_motions, gt_embeddings).as_dict()
    return scores, recon


def evaluate(
    decoder, tokenizer, normalized, gt, dataset, evaluator, gt_embeddings, seeds: int, samplings: list[str] | None
) -> dict:
    out = {}
    for name, options in samplings_for(decoder.config.prediction, samplings).items():
        runs, recons = [], []
        for s in range(seeds):
            scores, recon = score_decoder(
                decoder.with_sampling(**options),
                tokenizer,
                normalized,
                gt,
                dataset,
                evaluator,
                gt_embeddings,
                seed=1000 + s,
            )
            runs.append(scores)
            recons.append(recon)
        row = {"runs": runs}
        if len(recons) > 1:  # how far two sampling seeds land apart: the diversity a temperature keeps
            a, b = np.concatenate(recons[0]), np.concatenate(recons[1])
            row["seed_rms"] = float(np.sqrt(np.mean((a - b) ** 2)))
        out[name] = row
    return out


def run_variant(name: str, args) -> dict:
    torch.set_num_threads(1)
    dataset = load_dataset(profile=args.profile)
    tokenizer = tokenizer_for_dataset("rvq", dataset, args.profile, progress=False)
    evaluator = load_or_train_evaluator(dataset, args.profile, progress=False)
    config = discord_config(args.profile, tokenizer=tokenizer, **{**BASE, **VARIANTS[name]})

    clips = list(dataset.split("val"))[: args.limit]
    q = int(tokenizer.downsample)
    normalized = [dataset.normalizer.normalize(c.features) for c in clips]
    gt = [c.features[: len(c.features) // q * q] for c in clips]
    gt_embeddings = evaluator.embed_motions(gt)
    ff = reconstruction_scores(
        [dataset.normalizer.denormalize(r) for r in decode_clips(normalized, tokenizer)],
        gt,
        evaluator.embed_motions,
        gt_embeddings,
    ).as_dict()

    truth = reconstruction_scores(gt, gt).as_dict()  # the ground truth's own jerk, for scale

    windows = WindowDataset(dataset.normalized("train"), config.window)
    batches = token_window_batches(windows, tokenizer, config.batch_size)

    # calibrate: seconds per step on this machine, now
    probe = DisCoRDDecoder(config)
    trainer = Trainer(probe, discord_loss_fn, batches, config.train_config(steps=args.calibrate + 5), progress=False)
    trainer.fit(until=5)
    start = time.perf_counter()
    trainer.fit(until=args.calibrate + 5)
    per_step = (time.perf_counter() - start) / args.calibrate
    steps = max(50, int(args.budget / per_step))
    config = replace(config, train_steps=steps, warmup_steps=max(10, steps // 20))

    model = DisCoRDDecoder(config).attach(tokenizer)
    val_fn = flow_validation(tokenizer, dataset.normalized("val"), config.window, seed=config.seed)
    train = config.train_config(seed=config.seed, log_every=max(1, steps // 50))
    trainer = Trainer(model, discord_loss_fn, batches, train, progress=False)
    result = {
        "variant": name,
        "overrides": VARIANTS[name],
        "config": config.to_dict(),
        "budget_s": args.budget,
        "calibrated_s_per_step": per_step,
        "feed_forward": ff,
        "ground_truth": truth,
        "checkpoints": [],
        "clips": len(clips),
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "torch": torch.__version__,
            "cpu": read_cpu_info().model or platform.processor() or "unknown",
        },
        "precision": trainer.precision,
        "dataset": dataset.key,
    }
    train_seconds = 0.0
    for fraction in args.fractions:
        until = max(1, round(fraction * steps))
        t0 = time.perf_counter()
        trainer.fit(until=until)
        train_seconds += time.perf_counter() - t0
        last = fraction == args.fractions[-1]
        with trainer.ema.apply_to(model):
            model.eval()
            seeds = args.seeds if last else 1
            scores = evaluate(
                model, tokenizer, normalized, gt, dataset, evaluator, gt_embeddings, seeds, args.samplings
            )
            val_loss = val_fn(model)["loss"]
            model.train()
        result["checkpoints"].append(
            {
                "step": until,
                "fraction": fraction,
                "train_seconds": train_seconds,
                "val_loss": val_loss,
                "samplings": scores,
            }
        )
        best = min(scores.items(), key=lambda kv: np.mean([r["sjpe"] for r in kv[1]["runs"]]))
        print(
            f"[{name}] step {until}/{steps} ({train_seconds:.0f} s): val loss {val_loss:.4f}; "
            f"best sampling {best[0]} sJPE {np.mean([r['sjpe'] for r in best[1]['runs']]):.3f} "
            f"(feed-forward {ff['sjpe']:.3f})",
            flush=True,
        )
    result["history"] = trainer.history
    return result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("variants", nargs="*", help=f"which of: {', '.join(VARIANTS)}")
    parser.add_argument("--list", action="store_true", help="list the variants and sampling settings")
    parser.add_argument("--profile", default="laptop")
    parser.add_argument("--budget", type=float, default=600.0, help="training wall-clock seconds per variant")
    parser.add_argument("--calibrate", type=int, default=20, help="steps timed to size the run")
    parser.add_argument("--fractions", type=float, nargs="+", default=[0.25, 0.5, 1.0])
    parser.add_argument("--seeds", type=int, default=3, help="sampling seeds at the last checkpoint")
    parser.add_argument("--limit", type=int, default=None, help="first N validation clips (default: all)")
    parser.add_argument("--out", type=Path, default=Path("book/data/discord_sweep/embedded-v3"))
    parser.add_argument("--suffix", default="", help="appended to the result's name, e.g. '-40min' for a longer budget")
    parser.add_argument(
        "--samplings",
        nargs="+",
        default=None,
        help="score only these sampling settings (default: every one the variant has); scoring all of them takes "
        "about half of a long run's wall time",
    )
    args = parser.parse_args(argv)
    if args.list or not args.variants:
        for name, overrides in VARIANTS.items():
            print(f"{name:16s} {overrides}")
        print("samplings:", ", ".join(f"{k} {v}" for k, v in SAMPLINGS.items()))
        return 0
    unknown = [v for v in args.variants if v not in VARIANTS]
    if unknown:
        parser.error(f"unknown variant(s) {unknown}; see --list")
    unknown = [s for s in args.samplings or [] if s not in SAMPLINGS]
    if unknown:
        parser.error(f"unknown sampling(s) {unknown}; see --list")
    for name in args.variants:
        if args.samplings and not samplings_for({**BASE, **VARIANTS[name]}["prediction"], args.samplings):
            parser.error(f"none of --samplings {args.samplings} applies to {name} (final x̂1 needs x-prediction)")
    if sorted(args.fractions) != args.fractions or not 0 < args.fractions[0] or args.fractions[-1] != 1.0:
        parser.error("--fractions must increase and end at 1.0")
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.variants:
        result = run_variant(name, args)
        result["variant"] = name + args.suffix
        write_text_atomic(args.out / f"{name}{args.suffix}.json", json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
