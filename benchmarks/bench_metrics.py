"""The joint-based metrics of a reconstruction evaluation: a per-clip loop against motionlab's vectorised path.

Not a test: prints a table and writes JSON. Usage::

    python benchmarks/bench_metrics.py [--clips 512 4384] [--repeats 5] [--threads 1] [--out PATH]

Data: ``--pool`` clips of the embedded generator (196 feature rows each, HumanML3D's 263-d t2m features)
are cut into ``--clips`` windows of 40–196 frames (uniform lengths, random starts), the test split's range;
the "reconstruction" adds Gaussian noise of 5 % of each feature column's spread. Both sides get the same
lists of raw float32 ``(T_i, 263)`` clips, as the reconstruction evaluation has them, and compute:

- joint positions of every clip (``recover_from_ric``), in float64;
- sJPE per clip in both variants (element: sJPE, Noise, Static; ratio: Noise, Static) and the mean jerk
  magnitude of the sJPE joints, prediction and ground truth;
- MPJPE over all poses;
- Eq. 10 (M2D2M's Jerk, time in frames) on the 40-frame window centred on each clip, and its LDLJ,
  prediction and ground truth.

"reference loop" is written here, one clip at a time, the way the public evaluation code does it;
"motionlab" is :class:`motionlab.metrics.ClipJoints` (joints recovered once, real frames only) with
``sjpe_variants``, ``mpjpe`` and ``clip_log_jerk`` on it. Every value must agree to 1e-9. Timing follows
``benchmarks/_timing.py``: one thread, the two variants interleaved, ``--repeats`` rounds, median and
min–max of CPU and wall time, and the per-round ratio.
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

import numpy as np
import torch
from _timing import add_timing_arguments, apply_threads, interleaved, ratio, ratio_text, spread

from motionlab.data.embedded import FAMILIES, generate_clip
from motionlab.metrics import ClipJoints, clip_log_jerk, ldlj_from_log_jerk, log_jerk, mpjpe, sjpe_variants
from motionlab.representation import joints_to_features, recover_from_ric

REPO = Path(__file__).resolve().parents[1]
SJPE_JOINTS, FPS, EPS, WINDOW = [10, 11, 20, 21], 20.0, 1e-6, 40
TOLERANCE = 1e-9
TARGET_SPEEDUP = 5.0


def make_clips(n: int, pool: int, seed: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``n`` ground-truth clips of 40–196 frames cut from ``pool`` generated clips, and noisy copies."""
    names = sorted(FAMILIES)
    sources = [
        joints_to_features(
            generate_clip(names[i % len(names)], np.random.default_rng([seed, i]), n_frames=197).joints,
            retarget_to_target=False,
        )
        for i in range(pool)
    ]
    scale = 0.05 * np.concatenate(sources).std(axis=0)  # (263,)
    rng = np.random.default_rng([seed, n])
    gt, pred = [], []
    for _ in range(n):
        src = sources[rng.integers(pool)]
        length = int(rng.integers(40, len(src) + 1))
        start = int(rng.integers(0, len(src) - length + 1))
        clip = src[start : start + length]
        gt.append(clip.astype(np.float32))
        pred.append((clip + scale * rng.standard_normal(clip.shape)).astype(np.float32))
    return pred, gt


def reference_loop(pred: list[np.ndarray], gt: list[np.ndarray]) -> dict[str, np.ndarray]:
    """Every quantity, one clip at a time: recover both clips' joints, then score them."""
    keys = (
        "sjpe",
        "noise",
        "static",
        "noise_ratio",
        "static_ratio",
        "jerk_pred",
        "jerk_gt",
        "eq10_pred",
        "eq10_gt",
        "ldlj_pred",
        "ldlj_gt",
    )
    out = {k: np.empty(len(gt)) for k in keys}
    error_sum, poses = 0.0, 0
    for i, (p_feats, g_feats) in enumerate(zip(pred, gt)):
        p = recover_from_ric(p_feats.astype(np.float64), 22)  # (T, 22, 3)
        g = recover_from_ric(g_feats.astype(np.float64), 22)
        jp = np.linalg.norm(np.diff(p[:, SJPE_JOINTS], n=3, axis=0) * FPS**3, axis=-1)  # (T-3, 4)
        jg = np.linalg.norm(np.diff(g[:, SJPE_JOINTS], n=3, axis=0) * FPS**3, axis=-1)
        over, under = np.maximum(jp - jg, 0.0), np.maximum(jg - jp, 0.0)
        out["noise"][i] = np.sum(over / (jp + jg + EPS)) / len(jp)
        out["static"][i] = np.sum(under / (jp + jg + EPS)) / len(jp)
        out["sjpe"][i] = out["noise"][i] + out["static"][i]
        out["noise_ratio"][i] = over.sum() / (jp + jg).sum()
        out["static_ratio"][i] = under.sum() / (jp + jg).sum()
        out["jerk_pred"][i], out["jerk_gt"][i] = jp.mean(), jg.mean()
        error_sum += np.linalg.norm((p - p[:, :1]) - (g - g[:, :1]), axis=-1).sum()
        poses += p.shape[0] * p.shape[1]
        start = min(max(len(p) // 2 - WINDOW // 2, 0), len(p) - WINDOW)
        for name, joints in (("pred", p), ("gt", g)):
            out[f"eq10_{name}"][i] = log_jerk(joints[start : start + WINDOW])
            out[f"ldlj_{name}"][i] = ldlj_from_log_jerk(out[f"eq10_{name}"][i], WINDOW)
    out["mpjpe"] = np.array([error_sum / poses])
    return out


def motionlab_path(pred: list[np.ndarray], gt: list[np.ndarray]) -> dict[str, np.ndarray]:
    """The same quantities from joints recovered once per clip set (real frames only) and shared."""
    p, g = ClipJoints.from_features(pred), ClipJoints.from_features(gt)
    scores = sjpe_variants(p, g)
    element, ratio_ = scores["element"], scores["ratio"]
    out = {
        "sjpe": element.sjpe_per_clip,
        "noise": element.noise_per_clip,
        "static": element.static_per_clip,
        "noise_ratio": ratio_.noise_per_clip,
        "static_ratio": ratio_.static_per_clip,
        "jerk_pred": element.jerk_pred_per_clip,
        "jerk_gt": element.jerk_gt_per_clip,
        "mpjpe": np.array([mpjpe(p, g)]),
    }
    for name, joints in (("pred", p), ("gt", g)):
        out[f"eq10_{name}"] = clip_log_jerk(joints, window=WINDOW)
        out[f"ldlj_{name}"] = ldlj_from_log_jerk(out[f"eq10_{name}"], np.minimum(joints.lengths, WINDOW))
    return out


def max_difference(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    """The largest ``|a - b| / max(1, |b|)`` over every quantity and clip."""
    return max(float(np.max(np.abs(a[k] - b[k]) / np.maximum(1.0, np.abs(b[k])))) for k in b)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, nargs="+", default=[512, 4384], help="clip-set sizes")
    parser.add_argument("--pool", type=int, default=32, help="generated source clips the windows are cut from")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=REPO / "_build" / "benchmarks" / "metrics.json")
    add_timing_arguments(parser, repeats=5)
    args = parser.parse_args(argv)
    threads = apply_threads(args.threads)

    rows = []
    for n in args.clips:
        pred, gt = make_clips(n, args.pool, args.seed)
        reference, ours = reference_loop(pred, gt), motionlab_path(pred, gt)
        difference = max_difference(ours, reference)
        variants = {
            "reference loop": lambda p=pred, g=gt: reference_loop(p, g),
            "motionlab": lambda p=pred, g=gt: motionlab_path(p, g),
        }
        timing = interleaved(variants, args.repeats)
        speedup = ratio(timing["reference loop"], timing["motionlab"])
        rows.append(
            {
                "clips": n,
                "frames": int(sum(len(c) for c in gt)),
                "max_difference": difference,
                "equal": difference <= TOLERANCE,
                "speedup": speedup,
                "timing": {name: t.summary() for name, t in timing.items()},
                "values": {k: float(np.mean(v)) for k, v in ours.items()},
                "_timing": timing,
            }
        )

    print(
        f"joint metrics (sJPE both variants, MPJPE, Eq. 10 + LDLJ): per-clip loop vs motionlab; "
        f"{threads} thread(s), {args.repeats} interleaved rounds, median (min–max)"
    )
    print(
        f"{'clips':>6} {'frames':>8} {'variant':<15} {'cpu s':>22} {'wall s':>22} {'max |diff|':>11} "
        f"{'speed-up (cpu)':>20} {'speed-up (wall)':>20}"
    )
    for r in rows:
        for name, t in r["_timing"].items():
            last = name == "motionlab"
            extra = (
                (
                    f" {r['max_difference']:>11.1e} {ratio_text(r['speedup'], 'cpu'):>20} "
                    f"{ratio_text(r['speedup'], 'wall'):>20}"
                )
                if last
                else ""
            )
            print(f"{r['clips']:>6} {r['frames']:>8} {name:<15} {spread(t.cpu):>22} {spread(t.wall):>22}{extra}")
    for r in rows:
        fast = r["speedup"]["cpu_median"] >= TARGET_SPEEDUP
        print(
            f"{r['clips']} clips: values {'equal' if r['equal'] else 'DIFFER'} (max {r['max_difference']:.1e} "
            f"<= {TOLERANCE:g}: {r['equal']}); motionlab {r['speedup']['cpu_median']:.1f}× faster in CPU time "
            f"({'meets' if fast else 'MISSES'} the {TARGET_SPEEDUP:g}× target)"
        )
        r.pop("_timing")
    report = {
        "rows": rows,
        "repeats": args.repeats,
        "threads": threads,
        "pool": args.pool,
        "seed": args.seed,
        "tolerance": TOLERANCE,
        "machine": f"{platform.machine()} {platform.processor() or platform.system()}",
        "torch": torch.__version__,
        "numpy": np.__version__,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2))
    print(f"wrote {args.out}")
    return report


if __name__ == "__main__":
    main()
