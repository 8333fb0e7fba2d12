"""Throughput of the metrics at HumanML3D test-set scale (4,384 clips x 196 frames; 512-d embeddings).

Not a test: prints a table and writes JSON. Usage::

    python benchmarks/bench_metrics.py [OUT_JSON] [--clips N] [--frames T] [--repeats R] [--seed S]

Timed (best of ``--repeats``): sJPE over all clips (both variants share the jerk, "element" is timed),
Eq. 10 Jerk on one 40-frame window per clip, their sum (target < 2 s on 2 cores), MPJPE, FID on
``N x 512`` embeddings, and R-precision + MM-Dist in batches of 32.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy
import torch

from motionlab.metrics import fid, log_jerk_batch, mpjpe, retrieval_metrics, sjpe_dataset

TARGET_SJPE_PLUS_JERK_S = 2.0


def smooth_clips(rng: np.random.Generator, n: int, frames: int, joints: int = 22) -> np.ndarray:
    """Random smooth motion ``(n, frames, joints, 3)`` float32: twice-integrated white noise, in metres."""
    acc = rng.normal(scale=2e-4, size=(n, frames, joints, 3)).astype(np.float32)
    return np.cumsum(np.cumsum(acc, axis=1), axis=1)


def best_of(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", default="_build/benchmarks/metrics.json", help="JSON output path")
    parser.add_argument("--clips", type=int, default=4384)
    parser.add_argument("--frames", type=int, default=196)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    gt = smooth_clips(rng, args.clips, args.frames)
    pred = gt + rng.normal(scale=1e-3, size=gt.shape).astype(np.float32)  # frame-wise noise
    gt_list, pred_list = list(gt), list(pred)
    start = args.frames // 2 - 20
    windows = pred[:, start : start + 40]  # (N, 40, 22, 3): one transition-sized window per clip
    emb_a = rng.normal(size=(args.clips, 512))
    emb_b = rng.normal(size=(args.clips, 512)) + 0.1

    timings = {
        "sjpe": best_of(lambda: sjpe_dataset(pred_list, gt_list), args.repeats),
        "jerk_eq10": best_of(lambda: log_jerk_batch(windows), args.repeats),
        "mpjpe": best_of(lambda: mpjpe(pred, gt), args.repeats),
        "fid_512": best_of(lambda: fid(emb_a, emb_b), args.repeats),
        "r_precision_mm_dist": best_of(lambda: retrieval_metrics(emb_a, emb_b), args.repeats),
    }
    timings["sjpe_plus_jerk"] = timings["sjpe"] + timings["jerk_eq10"]
    res = sjpe_dataset(pred_list, gt_list)
    report = {
        "clips": args.clips,
        "frames": args.frames,
        "repeats": args.repeats,
        "seconds": timings,
        "target_sjpe_plus_jerk_s": TARGET_SJPE_PLUS_JERK_S,
        "meets_target": timings["sjpe_plus_jerk"] < TARGET_SJPE_PLUS_JERK_S,
        "values": {
            "sjpe": res.sjpe,
            "noise": res.noise,
            "static": res.static,
            "jerk_eq10_mean": float(np.nanmean(log_jerk_batch(windows))),
        },
        "machine": {
            "cpu_count": os.cpu_count(),
            "torch_threads": torch.get_num_threads(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
        },
    }

    print(f"metrics on {args.clips} clips x {args.frames} frames (best of {args.repeats})")
    print(f"{'metric':<24}{'seconds':>10}{'clips/s':>14}")
    for name, sec in timings.items():
        print(f"{name:<24}{sec:>10.3f}{args.clips / sec:>14,.0f}")
    verdict = "meets" if report["meets_target"] else "MISSES"
    print(f"sJPE + Jerk {verdict} the {TARGET_SJPE_PLUS_JERK_S:.0f} s target; sJPE = {res.sjpe:.3f}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=2))
    print(f"wrote {out}")
    return report


if __name__ == "__main__":
    main()
