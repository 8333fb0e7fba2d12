"""Decode time per clip: the feed-forward conv decoder vs DisCoRD's rectified-flow decoder (CPU).

Both networks have their published sizes and random weights (timing does not depend on the weights):

- feed-forward: ``motionlab.tokenizers.encdec.Decoder`` with the T2M-GPT / MoMask setting
  (width 512, 3 residual blocks per stage, code 512 → 263 features);
- DisCoRD: ``DisCoRDDecoder(discord_config("full"))`` (66.9 M parameters), Euler and midpoint over
  1/2/4/8/16 intervals, plus the public code's default (16-point grid = 15 midpoint intervals).

Each clip is 196 frames (49 tokens). The condition projection runs once per clip and the U-Net once per
network evaluation, exactly as in ``DisCoRDDecoder.sample``. Timing follows ``benchmarks/_timing.py``: one
thread unless ``--threads``, one untimed warm-up call of every row, then ``--repeats`` rounds in which every
row (the feed-forward decoder and each DisCoRD setting) is timed once, interleaved; a row reports the median
and min–max per clip of wall and process CPU time, and its ratio to the feed-forward decoder of the same
round (median and min–max).

    .venv/bin/python benchmarks/bench_decode.py                  # table + _build/benchmarks/decode.json
    .venv/bin/python benchmarks/bench_decode.py --batch-sizes 1 --repeats 5 --steps 1 2 --threads 2
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

import torch
from _timing import add_timing_arguments, apply_threads, interleaved, ratio
from torch import nn

from motionlab.flow import DisCoRDDecoder, discord_config, discord_default_solver, n_evaluations
from motionlab.tokenizers.encdec import Decoder

REPO = Path(__file__).resolve().parents[1]
FRAMES = 196
STEPS = (1, 2, 4, 8, 16)
SOLVERS = ("euler", "midpoint")


def count_macs(module: nn.Module, *inputs: object) -> int:
    """Multiply-accumulates of one call, summed over its Linear and (transposed) Conv1d layers."""
    total = 0

    def hook(layer: nn.Module, args: tuple, out: torch.Tensor) -> None:
        nonlocal total
        if isinstance(layer, nn.Linear):
            total += out.numel() * layer.in_features
        elif isinstance(layer, nn.Conv1d):
            total += out.numel() * layer.in_channels // layer.groups * layer.kernel_size[0]
        elif isinstance(layer, nn.ConvTranspose1d):  # each input element meets every kernel tap once
            total += args[0].numel() * layer.out_channels // layer.groups * layer.kernel_size[0]

    handles = [m.register_forward_hook(hook) for m in module.modules()]
    try:
        module(*inputs)
    finally:
        for h in handles:
            h.remove()
    return total


def build_networks(seed: int) -> tuple[Decoder, DisCoRDDecoder]:
    cfg = discord_config("full")
    torch.manual_seed(seed)  # random weights: only the shapes matter for timing
    feed_forward = Decoder(feature_dim=cfg.feature_dim, code_dim=cfg.code_dim, width=512, depth=3).eval()
    discord = DisCoRDDecoder(cfg).eval()
    return feed_forward, discord


@torch.inference_mode()
def run(batch_sizes: list[int], repeats: int, steps: list[int], seed: int) -> dict:
    feed_forward, discord = build_networks(seed)
    cfg = discord.config
    n_tokens = FRAMES // cfg.q
    default = discord_default_solver()
    settings = [(s, solver) for solver in SOLVERS for s in steps] + [(default.steps, default.solver)]
    # Compute per clip: the projection once, the U-Net once per evaluation (batch 1, MACs scale with B).
    z1 = torch.randn(1, n_tokens, cfg.code_dim, generator=torch.Generator().manual_seed(seed))
    cond = discord.condition(z1)
    x1 = torch.zeros(1, FRAMES, cfg.feature_dim)
    macs = {
        "feed_forward": count_macs(feed_forward, z1),
        "projection": count_macs(discord.projection, z1),
        "unet_evaluation": count_macs(discord.unet, x1, torch.zeros(1), cond),
    }
    rows = []
    for batch in batch_sizes:
        z = torch.randn(batch, n_tokens, cfg.code_dim, generator=torch.Generator().manual_seed(seed))
        calls = {("feed-forward", "-", 0): lambda z=z: feed_forward(z)}
        for steps_, solver in settings:
            calls[("discord", solver, steps_)] = lambda z=z, s=steps_, m=solver: discord.sample(z, s, m, seed=seed)
        timing = interleaved(calls, repeats)  # one warm-up of every row, then rounds of every row
        base = timing[("feed-forward", "-", 0)]
        for (decoder, solver, steps_), t in timing.items():
            nfe = 1 if decoder == "feed-forward" else n_evaluations(steps_, solver)
            clip_macs = (
                macs["feed_forward"]
                if decoder == "feed-forward"
                else (macs["projection"] + nfe * macs["unet_evaluation"])
            )
            per_clip = {k: v / batch for k, v in t.summary().items()}
            rows.append(
                dict(
                    decoder=decoder,
                    solver=solver,
                    steps=steps_,
                    evaluations=nfe,
                    batch=batch,
                    seconds_per_clip=per_clip,
                    ratio=ratio(t, base),
                    gmac_per_clip=clip_macs / 1e9,
                    ratio_macs=clip_macs / macs["feed_forward"],
                )
            )
    return {
        "frames": FRAMES,
        "repeats": repeats,
        "threads": torch.get_num_threads(),
        "torch": torch.__version__,
        "machine": f"{platform.machine()} {platform.processor() or platform.system()}",
        "params": {
            "feed_forward": sum(p.numel() for p in feed_forward.parameters()),
            "discord": sum(p.numel() for p in discord.parameters()),
        },
        "macs_per_clip": macs,
        "feed_forward_network": "motionlab.tokenizers.encdec.Decoder(width=512, depth=3, code_dim=512)",
        "rows": rows,
        "ratio_2_euler": {
            str(r["batch"]): {
                "wall": r["ratio"]["wall_median"],
                "cpu": r["ratio"]["cpu_median"],
                "macs": r["ratio_macs"],
            }
            for r in rows
            if r["solver"] == "euler" and r["steps"] == 2
        },
    }


def table(result: dict) -> str:
    def cell(r: dict, kind: str) -> str:  # "median (min–max)" ms per clip
        t = r["seconds_per_clip"]
        return f"{1e3 * t[f'{kind}_median']:.1f} ({1e3 * t[f'{kind}_min']:.1f}–{1e3 * t[f'{kind}_max']:.1f})"

    def times(r: dict, kind: str) -> str:
        q = r["ratio"]
        return f"{q[f'{kind}_median']:.2f} ({q[f'{kind}_min']:.2f}–{q[f'{kind}_max']:.2f})"

    lines = [
        f"decode time per clip, {result['frames']} frames, CPU, {result['threads']} thread(s), torch "
        f"{result['torch']}; {result['repeats']} interleaved rounds, median (min–max)",
        f"params: feed-forward {result['params']['feed_forward'] / 1e6:.1f} M, "
        f"DisCoRD {result['params']['discord'] / 1e6:.1f} M",
        f"{'decoder':<13}{'solver':<10}{'steps':>6}{'NFE':>5}{'batch':>6}{'GMAC':>7}{'× FF':>7}"
        f"{'cpu ms/clip':>26}{'× FF (cpu)':>24}{'wall ms/clip':>26}{'× FF (wall)':>24}",
    ]
    for r in result["rows"]:
        lines.append(
            f"{r['decoder']:<13}{r['solver']:<10}{r['steps']:>6}{r['evaluations']:>5}{r['batch']:>6}"
            f"{r['gmac_per_clip']:>7.2f}{r['ratio_macs']:>7.2f}"
            f"{cell(r, 'cpu'):>26}{times(r, 'cpu'):>24}{cell(r, 'wall'):>26}{times(r, 'wall'):>24}"
        )
    for batch, ratio_ in result["ratio_2_euler"].items():
        verdict = "within" if ratio_["cpu"] <= 3.0 else "NOT within"
        lines.append(
            f"2 Euler steps, batch {batch}: {ratio_['wall']:.2f}× (wall) / {ratio_['cpu']:.2f}× (cpu) / "
            f"{ratio_['macs']:.2f}× (MACs) the feed-forward decoder ({verdict} the 3× target)"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[1, 32])
    parser.add_argument("--steps", type=int, nargs="+", default=list(STEPS), help="DisCoRD ODE intervals to time")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=REPO / "_build" / "benchmarks" / "decode.json")
    add_timing_arguments(parser, repeats=3)
    args = parser.parse_args()
    apply_threads(args.threads)
    result = run(args.batch_sizes, args.repeats, args.steps, args.seed)
    print(table(result))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
