"""Two-Phase Sampling time against the number of actions N (M2D2M appendix D.3, Fig. 4: near-linear).

Not a test: prints a table and writes JSON. Setting (random weights; timing does not depend on them):

- ``transformer_config("laptop")`` denoiser, K = 512 codes, T = 100 steps, the book's schedule with M2D2M's
  dynamic β (η = 0.25) on a random (512, 64) codebook;
- N actions of 40 frames (10 tokens) each, 16 text tokens of width 256 per action, guidance s = 2, top-p 0.85;
- three samplers on the same inputs: TPS with T_s = 90 (the paper's), independent (T_s = T) and fully
  joint (T_s = 0). Timing follows ``benchmarks/_timing.py``: one thread unless ``--threads``, one warm-up
  call of each sampler, then ``--repeats`` rounds timing the three interleaved; the medians of wall and
  process-CPU seconds (min–max in the JSON) feed a least-squares line through (N, seconds): the slope per
  action and R².

    .venv/bin/python benchmarks/bench_tps.py                           # _build/benchmarks/tps.json
    .venv/bin/python benchmarks/bench_tps.py --ns 1 2 4 --steps 10 --repeats 1
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

import numpy as np
import torch
from _timing import add_timing_arguments, apply_threads, interleaved

from motionlab.diffusion import DenoisingTransformer, build_transitions, get_schedule, transformer_config
from motionlab.multimotion import two_phase_sample

REPO = Path(__file__).resolve().parents[1]


def linear_fit(ns: list[int], seconds: list[float]) -> dict[str, float]:
    """seconds ≈ intercept + slope·N by least squares, and R² of that line."""
    x, y = np.asarray(ns, float), np.asarray(seconds, float)
    slope, intercept = np.polyfit(x, y, 1)
    residual = y - (intercept + slope * x)
    r2 = 1.0 - residual @ residual / max(((y - y.mean()) ** 2).sum(), 1e-30)
    return {"slope_s_per_action": float(slope), "intercept_s": float(intercept), "r2": float(r2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "_build" / "benchmarks" / "tps.json")
    parser.add_argument("--ns", type=int, nargs="+", default=[1, 2, 4, 8, 12, 16])
    parser.add_argument("--frames", type=int, default=40, help="frames per action (a multiple of 4)")
    parser.add_argument("--timesteps", type=int, default=100)
    parser.add_argument("--steps", type=int, default=None, help="sampling jumps (default: all T)")
    parser.add_argument("--T-s-fraction", type=float, default=0.9)
    parser.add_argument("--guidance", type=float, default=2.0)
    parser.add_argument("--device", default="cpu")
    add_timing_arguments(parser, repeats=3)
    args = parser.parse_args()
    apply_threads(args.threads)
    K, T, dev = 512, args.timesteps, torch.device(args.device)
    T_s = round(args.T_s_fraction * T)

    codebook = torch.randn(K, 64, generator=torch.Generator().manual_seed(0))
    transitions = build_transitions(get_schedule("vqdiffusion_paper", T), codebook=codebook, eta=0.25).to(dev)
    cfg = transformer_config("laptop", num_codes=K, text_dim=256, timesteps=T)
    model = DenoisingTransformer(cfg, seed=0).to(dev).eval()
    samplers = {"tps": T_s, "independent": T, "joint": 0}

    rows = []
    for n in args.ns:
        text = torch.randn(n, 16, 256, generator=torch.Generator().manual_seed(n)).to(dev)
        row = {"n_actions": n, "frames": n * args.frames, "tokens": n * args.frames // 4}

        def run(ts: int, text=text, n=n):
            out = two_phase_sample(
                model,
                transitions,
                (text, None),
                [args.frames] * n,
                T_s=ts,
                generator=torch.Generator().manual_seed(1),
                num_steps=args.steps,
                guidance_scale=args.guidance,
                top_p=0.85,
            )
            if dev.type == "cuda":
                torch.cuda.synchronize()
            return out

        timing = interleaved({name: (lambda ts=ts: run(ts)) for name, ts in samplers.items()}, args.repeats)
        for name, t in timing.items():
            row[f"{name}_s"], row[f"{name}_cpu_s"] = float(np.median(t.wall)), float(np.median(t.cpu))
            row[f"{name}_spread"] = t.summary()
        rows.append(row)
        print(
            f"N={n:3d}  " + "  ".join(f"{k}={row[f'{k}_s']:.3f}s (cpu {row[f'{k}_cpu_s']:.3f}s)" for k in samplers),
            flush=True,
        )

    fits = {
        f"{name}{kind}": linear_fit(args.ns, [r[f"{name}{kind}"] for r in rows])
        for name in samplers
        for kind in ("_s", "_cpu_s")
    }
    print(f"\nmedians of {args.repeats} interleaved rounds")
    print(f"{'N':>4} {'frames':>7} " + " ".join(f"{k + ' wall/cpu (s)':>24}" for k in samplers))
    for r in rows:
        cells = [f"{r[f'{k}_s']:.3f} / {r[f'{k}_cpu_s']:.3f}" for k in samplers]
        print(f"{r['n_actions']:>4} {r['frames']:>7} " + " ".join(f"{c:>24}" for c in cells))
    for name, fit in fits.items():
        print(
            f"{name:>18}: {fit['slope_s_per_action'] * 1e3:.1f} ms per action, intercept "
            f"{fit['intercept_s']:.3f} s, R² = {fit['r2']:.4f}"
        )

    device_name = torch.cuda.get_device_name(dev) if dev.type == "cuda" else platform.processor()
    setting = dict(
        model="laptop",
        params=model.num_params,
        codes=K,
        T=T,
        T_s=T_s,
        steps=args.steps or T,
        frames_per_action=args.frames,
        guidance=args.guidance,
        top_p=0.85,
        repeats=args.repeats,
        device=str(dev),
        device_name=device_name,
        threads=torch.get_num_threads(),
        torch=torch.__version__,
    )
    result = {"setting": setting, "rows": rows, "linear_fit": fits}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
