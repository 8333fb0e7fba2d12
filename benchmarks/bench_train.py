"""Training steps and sampling throughput of every laptop model, fp32 against bf16 (the matrix units).

Not a test: prints a table and writes JSON. Each laptop model is built at its laptop size (random initial weights:
the cost of a step does not depend on them) on the same dataset, once per precision, and trained through its own
:class:`~motionlab.train.Trainer` (the one the library fits: ``tokenizer_trainer``, ``discord_trainer``,
``text_to_motion_trainer``, ``evaluator_trainer``) — same loss, batches, optimizer and precision handling:

- ``vq``, ``rvq``: the tokenizers (batch 32 windows of 64 frames);
- ``discord``: the flow decoder on RVQ codes (batch 32, 64 frames);
- ``diffusion``: the text encoder + denoising transformer (batch 64 captioned token sequences);
- ``evaluator``: the text and motion encoders (contrastive batches);

and the samplers, items per second, precision switched through ``$MOTIONLAB_PRECISION`` as a run would:

- ``discord-decode``: DisCoRD decoding of 32 clips of 49 tokens (196 frames), the laptop ODE (8 midpoint steps);
- ``diffusion-sample``: text-to-motion tokens for 32 captions at dataset lengths, all T steps, guidance 4;
- ``tps``: Two-Phase Sampling of 8 four-action instances.

Timing follows ``benchmarks/_timing.py``: one thread, the two precisions interleaved round by round in one process,
``--repeats`` rounds after a warm-up, median and min–max of wall and CPU time, and the per-round fp32/bf16 ratio.
A training round is ``--steps`` optimizer steps. ``--json OUT`` writes one record per model and precision:
``{"model", "precision", "steps_per_s", "median_s", "min_s", "max_s", ...}`` (samplers add ``items_per_s``).

    .venv/bin/python benchmarks/bench_train.py --json _build/benchmarks/train.json
    .venv/bin/python benchmarks/bench_train.py --models discord diffusion --repeats 3
"""

from __future__ import annotations

import argparse
import os
import platform
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from _timing import add_timing_arguments, apply_threads, interleaved, ratio, ratio_text, spread, write_records
from _trainers import book_trainer, diffusion_parts

from motionlab.data import load_dataset
from motionlab.precision import explain_precision, read_cpu_info

PRECISIONS = ("fp32", "bf16")
TRAINED = ("vq", "rvq", "discord", "diffusion", "evaluator")
SAMPLERS = ("discord-decode", "diffusion-sample", "tps")
REPO = Path(__file__).resolve().parents[1]


# -- training: one Trainer per model and precision ------------------------------------------------------------------
def training_rounds(
    name: str, dataset, parts, steps: int, precisions: tuple[str, ...] = PRECISIONS
) -> dict[str, Callable[[], None]]:
    """``{precision: one round of `steps` training steps}`` for model ``name``."""

    def build(precision: str):
        model = "t2m" if name == "diffusion" else name  # this benchmark's name for the text-to-motion networks
        return book_trainer(model, "laptop", dataset, precision, parts=parts)[0]

    def round_of(trainer) -> Callable[[], None]:
        def run() -> None:
            for _ in range(steps):
                trainer.train_step()

        return run

    return {p: round_of(build(p)) for p in precisions}


# -- sampling: the same networks, the precision chosen per call through the run's setting ------------------------
def with_precision(precision: str, fn: Callable[[], object]) -> Callable[[], None]:
    def run() -> None:
        os.environ["MOTIONLAB_PRECISION"] = precision
        fn()

    return run


def sampler_rounds(
    name: str, dataset, parts, precisions: tuple[str, ...] = PRECISIONS
) -> tuple[dict[str, Callable[[], None]], int]:
    """``({precision: one sampling call}, items per call)`` for sampler ``name``."""
    if name == "discord-decode":
        from motionlab.flow import DisCoRDDecoder, discord_config
        from motionlab.tokenizers import build_tokenizer, rvq_config

        tokenizer = build_tokenizer(rvq_config("laptop")).eval()
        decoder = DisCoRDDecoder(discord_config("laptop", tokenizer=tokenizer)).attach(tokenizer).eval()
        ids = torch.randint(
            0, tokenizer.codebook_size, (32, 49, tokenizer.num_layers), generator=torch.Generator().manual_seed(0)
        )
        call, items = (lambda: decoder.decode(ids, seed=0)), 32
    else:
        from motionlab.diffusion.pipeline import TextToMotion
        from motionlab.diffusion.training import TextToMotionNetworks

        config = parts.config
        networks = TextToMotionNetworks(config, parts.vocabulary).eval()
        pipe = TextToMotion(
            parts.tokenizer,
            networks.text_encoder,
            networks.denoiser,
            parts.transitions,
            dataset.normalizer,
            config.transformer,
        )
        clips = dataset.split("test")
        if name == "diffusion-sample":
            texts = [clip.captions[0].text for clip in clips[:32]]
            lengths = [clip.length // 4 * 4 for clip in clips[:32]]
            call, items = (lambda: pipe.sample_tokens(texts, lengths, generator=torch.Generator().manual_seed(0))), 32
        else:
            from motionlab.multimotion import MultiMotionGenerator

            multi = MultiMotionGenerator.from_pipeline(pipe)
            instances = [[clips[(4 * i + k) % len(clips)] for k in range(4)] for i in range(8)]
            texts = [[clip.captions[0].text for clip in group] for group in instances]
            lengths = [[max(40, clip.length // 4 * 4) for clip in group] for group in instances]
            call, items = (lambda: [multi.generate(t, n, method="tps", seed=0) for t, n in zip(texts, lengths)]), 8
    return {p: with_precision(p, call) for p in precisions}, items


def where_time_goes(run: Callable[[], None], top: int) -> list[dict[str, float]]:
    """The ``top`` operators of one round by self CPU time, as shares of the round (torch's profiler)."""
    from torch.profiler import profile

    with profile() as prof:
        run()
    events = sorted(prof.key_averages(), key=lambda e: e.self_cpu_time_total, reverse=True)
    total = sum(e.self_cpu_time_total for e in events) or 1.0
    return [{"op": e.key, "share": round(e.self_cpu_time_total / total, 3), "calls": e.count} for e in events[:top]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=[*TRAINED, *SAMPLERS], choices=[*TRAINED, *SAMPLERS])
    parser.add_argument("--steps", type=int, default=5, help="training steps per timed round (default 5)")
    parser.add_argument("--data", default=None, help="dataset folder (default: the embedded dataset, smoke size)")
    parser.add_argument("--json", type=Path, default=None, help="write the records here")
    parser.add_argument(
        "--precisions",
        nargs="+",
        default=list(PRECISIONS),
        choices=PRECISIONS,
        help="the precisions to time (default: both; fp32 alone where bf16 has no instructions, e.g. an AVX2-only CPU)",
    )
    parser.add_argument(
        "--profile-top",
        type=int,
        default=0,
        help="also profile one round per precision and list its N most expensive operators (default: off)",
    )
    add_timing_arguments(parser, repeats=5)
    args = parser.parse_args()
    threads = apply_threads(args.threads)
    precisions = tuple(dict.fromkeys(args.precisions))
    saved = os.environ.get("MOTIONLAB_PRECISION")
    dataset = load_dataset(args.data, profile="smoke")
    cpu = read_cpu_info().summary
    auto, why = explain_precision("auto")
    print(f"{cpu}; {threads} thread(s); auto here = {auto} ({why}); dataset {dataset.key}")
    parts = None
    if {"diffusion", *SAMPLERS} & set(args.models) - {"discord-decode"}:
        parts = diffusion_parts(dataset, "laptop")
    records, lines = [], []
    for name in args.models:
        if name in TRAINED:
            rounds, per_round, unit = training_rounds(name, dataset, parts, args.steps, precisions), args.steps, "steps"
        else:
            (rounds, per_round), unit = sampler_rounds(name, dataset, parts, precisions), "items"
        torch.manual_seed(0)
        timings = interleaved(rounds, repeats=args.repeats)
        for precision, t in timings.items():
            per_item = t.wall / per_round
            record = {
                "model": name,
                "precision": precision,
                "median_s": float(np.median(per_item)),
                "min_s": float(per_item.min()),
                "max_s": float(per_item.max()),
                "cpu_median_s": float(np.median(t.cpu / per_round)),
                "repeats": args.repeats,
                "cpu": cpu,
                "threads": threads,
            }
            if unit == "steps":
                record["steps_per_s"] = 1.0 / record["median_s"]
            else:
                record["items_per_s"] = 1.0 / record["median_s"]
                record["steps_per_s"] = record["items_per_s"] / per_round  # sampling calls per second
            records.append(record)
        both = len(timings) == 2
        if both:
            speedup = ratio(timings["fp32"], timings["bf16"])
            for r in records[-2:]:
                r["bf16_speedup_wall"], r["bf16_speedup_cpu"] = speedup["wall_median"], speedup["cpu_median"]
        if args.profile_top:
            for record, precision in zip(records[-len(timings) :], timings, strict=True):
                record["profile"] = where_time_goes(rounds[precision], args.profile_top)
                shares = ", ".join(f"{e['op']} {e['share']:.0%}" for e in record["profile"])
                print(f"  {name} {precision}, where the time goes: {shares}", flush=True)
        cells = [spread(timings[p].wall / per_round, 1000, 1) if p in timings else "–" for p in PRECISIONS]
        ratios = [ratio_text(speedup, "wall"), ratio_text(speedup, "cpu")] if both else ["–", "–"]
        cpu_ms = [spread(timings[p].cpu / per_round, 1000, 1) if p in timings else "–" for p in PRECISIONS]
        lines.append(f"| {name} | {unit} | {' | '.join(cells)} | {' | '.join(cpu_ms)} | {' | '.join(ratios)} |")
        print(lines[-1], flush=True)
    if saved is None:
        os.environ.pop("MOTIONLAB_PRECISION", None)
    else:
        os.environ["MOTIONLAB_PRECISION"] = saved
    print(
        f"\n{cpu}, {platform.machine()}, {threads} thread(s), {args.repeats} rounds; ms per step or item, "
        "median (min–max) of wall and of CPU time; speed-up = fp32 / bf16 per round"
    )
    print(
        "| model | per | fp32 ms | bf16 ms | fp32 CPU ms | bf16 CPU ms | bf16 speed-up (wall) | (CPU) |\n"
        "|---|---|---|---|---|---|---|---|"
    )
    print("\n".join(lines))
    write_records(args.json, records)


if __name__ == "__main__":
    main()
