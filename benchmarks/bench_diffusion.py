"""Discrete-diffusion sampling time and the memory of the dense transition matrices.

Not a test: prints a table and writes JSON. Setting (random weights; timing does not depend on them):

- transitions: K = 512 codes, T = 100, the book's schedule ("vqdiffusion_paper"), M2D2M's dynamic β with
  η = 0.5 on a random (512, 64) codebook; build time and bytes of the stored float32 Q_t and Q̄_t, and of
  the extra jump matrices fast sampling caches;
- sampler: ``transformer_config("laptop")`` denoiser, a batch of 32 texts (16 text tokens of width 256),
  49 tokens each (196 frames / 4), guidance s = 4 (so every step runs a batch of 64), top-p 0.85;
  ancestral T = 100 steps and fast sampling with fewer jumps. Best of ``--repeats`` runs, wall and
  process CPU time.

    .venv/bin/python benchmarks/bench_diffusion.py                       # _build/benchmarks/diffusion.json
    .venv/bin/python benchmarks/bench_diffusion.py --steps 100 10 --threads 1 --repeats 1
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import torch

from motionlab.diffusion import DenoisingTransformer, build_transitions, get_schedule, sample, transformer_config

REPO = Path(__file__).resolve().parents[1]


def timed(fn, repeats: int) -> tuple[float, float]:
    """Fastest wall and process-CPU seconds of ``repeats`` calls."""
    walls, cpus = [], []
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "_build" / "benchmarks" / "diffusion.json")
    parser.add_argument("--codes", type=int, default=512)
    parser.add_argument("--timesteps", type=int, default=100)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--tokens", type=int, default=49)
    parser.add_argument("--steps", type=int, nargs="+", default=[100, 25, 10])
    parser.add_argument("--guidance", type=float, default=4.0)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
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

    rows = []
    for steps in args.steps:
        def run(steps=steps):
            out = sample(model, transitions, text, lengths=lengths, generator=torch.Generator().manual_seed(2),
                         num_steps=steps, guidance_scale=args.guidance, top_p=0.85)  # fmt: skip
            if dev.type == "cuda":
                torch.cuda.synchronize()
            return out

        start = time.perf_counter()
        run()  # warm-up; also builds and caches the jump matrices of this grid
        first = time.perf_counter() - start
        wall, cpu = timed(run, args.repeats)
        rows.append(dict(steps=steps, wall_s=wall, cpu_s=cpu, first_call_s=first, ms_per_step=1e3 * wall / steps))

    cache_bytes = sum(m.numel() * m.element_size() for m in transitions._intervals.values())
    result = dict(
        device=str(dev) if dev.type != "cuda" else torch.cuda.get_device_name(dev),
        machine=platform.processor() or platform.machine(), threads=torch.get_num_threads(), torch=torch.__version__,
        codes=K, timesteps=T, batch=args.batch, tokens=args.tokens, guidance=args.guidance,
        model_params=model.num_params, model=dict(n_layers=cfg.n_layers, d_model=cfg.d_model, n_heads=cfg.n_heads),
        transitions=dict(build_s=build_s, dense_bytes=dense_bytes, dense_mb=dense_bytes / 2**20,
                         jump_cache_bytes=cache_bytes, jump_cache_mb=cache_bytes / 2**20),
        sampling=rows,
    )  # fmt: skip

    print(f"dense Q_t + Q̄_t (K={K}, T={T}, float32): {dense_bytes / 2**20:.1f} MiB, built in {build_s:.2f} s; "
          f"jump cache {cache_bytes / 2**20:.1f} MiB")  # fmt: skip
    print(f"laptop denoiser: {model.num_params / 1e6:.2f} M params; batch {args.batch} x {args.tokens} tokens, "
          f"guidance s={args.guidance} on {result['device']} ({result['threads']} threads)")  # fmt: skip
    print(f"{'steps':>6} {'wall s':>9} {'cpu s':>9} {'ms/step':>9} {'1st call s':>11}")
    for r in rows:
        print(f"{r['steps']:>6} {r['wall_s']:>9.2f} {r['cpu_s']:>9.2f} {r['ms_per_step']:>9.1f}"
              f" {r['first_call_s']:>11.2f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
