"""Decode time per clip: the feed-forward conv decoder vs DisCoRD's rectified-flow decoder (CPU).

Both networks have their published sizes and random weights (timing does not depend on the weights):

- feed-forward: ``motionlab.tokenizers.encdec.Decoder`` with the T2M-GPT / MoMask setting
  (width 512, 3 residual blocks per stage, code 512 → 263 features);
- DisCoRD: ``DisCoRDDecoder(discord_config("full"))`` (66.9 M parameters), Euler and midpoint over
  1/2/4/8/16 intervals, plus the public code's default (16-point grid = 15 midpoint intervals).

Each clip is 196 frames (49 tokens). The condition projection runs once per clip and the U-Net once per
network evaluation, exactly as in ``DisCoRDDecoder.sample``. A row's time is the fastest of up to
``--repeats`` timed calls (fewer once a row has used ``--budget`` seconds), divided by the batch size,
both as wall time and as process CPU time (the fair measure on a shared machine, best with --threads 1);
each batch size starts with one untimed warm-up call of each network.

    .venv/bin/python benchmarks/bench_decode.py                  # table + _build/benchmarks/decode.json
    .venv/bin/python benchmarks/bench_decode.py --batch-sizes 1 --repeats 5 --threads 2
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from collections.abc import Callable
from pathlib import Path

import torch
from torch import nn

from motionlab.flow import DisCoRDDecoder, discord_config, discord_default_solver, n_evaluations
from motionlab.tokenizers.encdec import Decoder

REPO = Path(__file__).resolve().parents[1]
FRAMES = 196
STEPS = (1, 2, 4, 8, 16)
SOLVERS = ("euler", "midpoint")


def best_seconds(fn: Callable[[], object], repeats: int, budget_s: float) -> tuple[float, float]:
    """Fastest wall time and fastest process CPU time of up to ``repeats`` calls of ``fn()``.

    Stops early once ``budget_s`` of wall time is spent. The minimum (as ``timeit`` advises) and the CPU
    time both resist other processes on a shared machine; with one thread, CPU time ≈ compute cost.
    """
    walls: list[float] = []
    cpus: list[float] = []
    while len(walls) < repeats and (not walls or sum(walls) < budget_s):
        wall, cpu = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


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
def run(batch_sizes: list[int], repeats: int, budget_s: float, seed: int) -> dict:
    feed_forward, discord = build_networks(seed)
    cfg = discord.config
    n_tokens = FRAMES // cfg.q
    default = discord_default_solver()
    settings = [(s, solver) for solver in SOLVERS for s in STEPS] + [(default.steps, default.solver)]
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
        feed_forward(z), discord.sample(z, 1, "euler", seed=seed)  # warm-up: allocator, first-call costs
        ff_wall, ff_cpu = (t / batch for t in best_seconds(lambda z=z: feed_forward(z), repeats, budget_s))
        rows.append(dict(decoder="feed-forward", solver="-", steps=0, evaluations=1, batch=batch,
                         wall_s_per_clip=ff_wall, cpu_s_per_clip=ff_cpu, ratio_wall=1.0, ratio_cpu=1.0,
                         gmac_per_clip=macs["feed_forward"] / 1e9, ratio_macs=1.0))  # fmt: skip
        for steps, solver in settings:
            call = lambda z=z, s=steps, m=solver: discord.sample(z, s, m, seed=seed)  # noqa: E731
            wall, cpu = (t / batch for t in best_seconds(call, repeats, budget_s))
            nfe = n_evaluations(steps, solver)
            clip_macs = macs["projection"] + nfe * macs["unet_evaluation"]
            rows.append(dict(decoder="discord", solver=solver, steps=steps, evaluations=nfe,
                             batch=batch, wall_s_per_clip=wall, cpu_s_per_clip=cpu,
                             ratio_wall=wall / ff_wall, ratio_cpu=cpu / ff_cpu,
                             gmac_per_clip=clip_macs / 1e9, ratio_macs=clip_macs / macs["feed_forward"]))  # fmt: skip
    return {
        "frames": FRAMES,
        "repeats": repeats,
        "budget_s": budget_s,
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
            str(r["batch"]): {"wall": r["ratio_wall"], "cpu": r["ratio_cpu"], "macs": r["ratio_macs"]}
            for r in rows
            if r["solver"] == "euler" and r["steps"] == 2
        },
    }


def table(result: dict) -> str:
    lines = [
        f"decode time per clip, {result['frames']} frames, CPU, {result['threads']} threads, torch {result['torch']}",
        f"params: feed-forward {result['params']['feed_forward'] / 1e6:.1f} M, "
        f"DisCoRD {result['params']['discord'] / 1e6:.1f} M",
        f"{'decoder':<13}{'solver':<10}{'steps':>6}{'NFE':>5}{'batch':>6}"
        f"{'GMAC':>7}{'× FF':>7}{'wall ms/clip':>14}{'× FF':>8}{'cpu ms/clip':>13}{'× FF':>8}",
    ]
    for r in result["rows"]:
        lines.append(
            f"{r['decoder']:<13}{r['solver']:<10}{r['steps']:>6}{r['evaluations']:>5}{r['batch']:>6}"
            f"{r['gmac_per_clip']:>7.2f}{r['ratio_macs']:>7.2f}"
            f"{1e3 * r['wall_s_per_clip']:>14.1f}{r['ratio_wall']:>8.2f}"
            f"{1e3 * r['cpu_s_per_clip']:>13.1f}{r['ratio_cpu']:>8.2f}"
        )
    for batch, ratio in result["ratio_2_euler"].items():
        verdict = "within" if ratio["cpu"] <= 3.0 else "NOT within"
        lines.append(
            f"2 Euler steps, batch {batch}: {ratio['wall']:.2f}× (wall) / {ratio['cpu']:.2f}× (cpu) / "
            f"{ratio['macs']:.2f}× (MACs) the "
            f"feed-forward decoder ({verdict} the 3× target)"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[1, 32])
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per row (at most)")
    parser.add_argument("--budget", type=float, default=2.0, help="seconds per row after which timing stops")
    parser.add_argument("--threads", type=int, default=None, help="torch CPU threads (default: torch's choice)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=REPO / "_build" / "benchmarks" / "decode.json")
    args = parser.parse_args()
    if args.threads is not None:
        torch.set_num_threads(args.threads)
    result = run(args.batch_sizes, args.repeats, args.budget, args.seed)
    print(table(result))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
