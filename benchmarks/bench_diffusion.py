"""Discrete-diffusion sampling time and the memory of the dense transition matrices.

Not a test: prints a table and writes JSON. Setting (random weights; timing does not depend on them):

- transitions: K = 512 codes, T = 100, the book's schedule ("vqdiffusion_paper"), M2D2M's dynamic β with
  η = 0.5 on a random (512, 64) codebook; build time and bytes of the stored float32 Q_t and Q̄_t, and of
  the extra jump matrices fast sampling caches;
- sampler: ``transformer_config("laptop")`` denoiser, a batch of 32 texts (16 text tokens of width 256),
  49 tokens each (196 frames / 4), guidance s = 4 (so every step runs a batch of 64), top-p 0.85;
  ancestral T = 100 steps and fast sampling with fewer jumps. Timing follows ``benchmarks/_timing.py``: one
  thread unless ``--threads``, a first (untimed, reported) call per step count that also builds its jump
  matrices, then ``--repeats`` rounds timing every step count once, interleaved; median and min–max of wall
  and process CPU time, and each step count's per-round speed-up over the first.

    .venv/bin/python benchmarks/bench_diffusion.py                       # _build/benchmarks/diffusion.json
    .venv/bin/python benchmarks/bench_diffusion.py --steps 100 10 --threads 1 --repeats 1
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np
import torch
from _timing import add_timing_arguments, apply_threads, interleaved, ratio, ratio_text, spread

from motionlab.diffusion import DenoisingTransformer, build_transitions, get_schedule, sample, transformer_config

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "_build" / "benchmarks" / "diffusion.json")
    parser.add_argument("--codes", type=int, default=512)
    parser.add_argument("--timesteps", type=int, default=100)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--tokens", type=int, default=49)
    parser.add_argument("--steps", type=int, nargs="+", default=[100, 25, 10])
    parser.add_argument("--guidance", type=float, default=4.0)
    parser.add_argument("--device", default="cpu")
    add_timing_arguments(parser, repeats=3)
    args = parser.parse_args()
    apply_threads(args.threads)
    K, T, dev = args.codes, args.timesteps, torch.device(args.device)

    codebook = torch.randn(K, 64, generator=torch.Generator().manual_seed(0))
    start = time.perf_counter()
    transitions = build_transitions(get_schedule("vqdiffusion_paper", T), codebook=codebook, eta=0.5)
    build_s = time.perf_counter() - start
    dense_bytes = transitions.nbytes
    transitions.to(dev)

    cfg = transformer_config("laptop", num_codes=K, text_dim=256, timesteps=T)
    model = DenoisingTransformer(cfg, seed=0).to(dev).eval()
    g = torch.Generator().manual_seed(1)
    text = torch.randn(args.batch, 16, 256, generator=g).to(dev)
    lengths = [args.tokens] * args.batch

    def run(steps: int):
        out = sample(
            model,
            transitions,
            text,
            lengths=lengths,
            generator=torch.Generator().manual_seed(2),
            num_steps=steps,
            guidance_scale=args.guidance,
            top_p=0.85,
        )
        if dev.type == "cuda":
            torch.cuda.synchronize()
        return out

    first = {}
    for steps in args.steps:  # the first call also builds and caches the jump matrices of this grid
        start = time.perf_counter()
        run(steps)
        first[steps] = time.perf_counter() - start
    calls = {steps: (lambda s=steps: run(s)) for steps in args.steps}
    timing = interleaved(calls, args.repeats, warmup=0)  # the first calls above were the warm-up
    base = timing[args.steps[0]]
    rows = [
        dict(
            steps=steps,
            first_call_s=first[steps],
            ms_per_step=1e3 * float(np.median(t.wall)) / steps,
            speedup_vs_first=ratio(base, t),
            **t.summary(),
        )
        for steps, t in timing.items()
    ]

    cache_bytes = sum(m.numel() * m.element_size() for m in transitions._intervals.values())
    result = dict(
        device=str(dev) if dev.type != "cuda" else torch.cuda.get_device_name(dev),
        machine=platform.processor() or platform.machine(),
        threads=torch.get_num_threads(),
        torch=torch.__version__,
        codes=K,
        timesteps=T,
        batch=args.batch,
        tokens=args.tokens,
        guidance=args.guidance,
        model_params=model.num_params,
        model=dict(n_layers=cfg.n_layers, d_model=cfg.d_model, n_heads=cfg.n_heads),
        transitions=dict(
            build_s=build_s,
            dense_bytes=dense_bytes,
            dense_mb=dense_bytes / 2**20,
            jump_cache_bytes=cache_bytes,
            jump_cache_mb=cache_bytes / 2**20,
        ),
        sampling=rows,
    )

    print(
        f"dense Q_t + Q̄_t (K={K}, T={T}, float32): {dense_bytes / 2**20:.1f} MiB, built in {build_s:.2f} s; "
        f"jump cache {cache_bytes / 2**20:.1f} MiB"
    )
    print(
        f"laptop denoiser: {model.num_params / 1e6:.2f} M params; batch {args.batch} x {args.tokens} tokens, "
        f"guidance s={args.guidance} on {result['device']} ({result['threads']} threads)"
    )
    print(f"{args.repeats} interleaved rounds, median (min–max)")
    print(f"{'steps':>6} {'wall s':>22} {'cpu s':>22} {'ms/step':>9} {'1st call s':>11} {'× faster (cpu)':>22}")
    for r in rows:
        t = timing[r["steps"]]
        print(
            f"{r['steps']:>6} {spread(t.wall, digits=2):>22} {spread(t.cpu, digits=2):>22} {r['ms_per_step']:>9.1f}"
            f" {r['first_call_s']:>11.2f} {ratio_text(r['speedup_vs_first']):>22}"
        )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
