"""Do clips begin and end mid-motion, and how jerky is a concatenation of two? The embedded data against real clips.

M2D2M's "ground truth (concat)" row plays real clips back to back and measures the transition Jerk (Eq. 10)
around each seam; its "ground truth (single)" row measures the same Jerk on windows inside real clips. This
script measures both exactly as chapter 09 does (the same library functions), together with what drives the
difference: how fast the clips move at their first and last frames against their middle
(:func:`~motionlab.data.embedded.realism.edge_speeds`) and how far the pose jumps at a seam
(:func:`~motionlab.data.embedded.realism.seam_pose_jump`).

* ``embedded``: generates the laptop profile's dataset (3,000 clips, seed 0) into a temporary folder with one
  worker process, timing it, then measures chapter 09's multi-action test set (every instance of 4 single
  actions from the test split). Writes ``<out>/embedded-v<VERSION>.json``.
* ``real``: the real clips of ``../shared/data`` (HumanML3D 012314 and 000612, the CMU takes 131_01-03
  converted by the BVH import that ``data from-bvh`` uses), read only: as whole takes, and cut into
  HumanML3D-like windows (2-5 s at random places) to give more examples of a clip cut out of a take.
  Writes ``<out>/real.json``.

One torch thread; run it while nothing else is benchmarking::

    MOTIONLAB_THREADS=1 OMP_NUM_THREADS=1 python experiments/clip_boundaries.py embedded --out book/data/clip_boundaries
    MOTIONLAB_THREADS=1 OMP_NUM_THREADS=1 python experiments/clip_boundaries.py real --out book/data/clip_boundaries
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import tempfile
import time
from itertools import permutations
from pathlib import Path

import numpy as np
import torch

from motionlab.data import MotionDataset
from motionlab.data.embedded import VERSION, write_embedded_dataset
from motionlab.data.embedded.realism import MOVING_SPEED, edge_speeds, seam_pose_jump
from motionlab.io.bvh_import import bvh_to_features
from motionlab.io.common import write_text_atomic
from motionlab.metrics import log_jerk_batch, mean_ci
from motionlab.multimotion import (
    build_multi_action_testset,
    concatenate_segments,
    ground_truth_concat_jerk,
    real_windows,
    single_action_pool,
    transition_jerk,
)
from motionlab.representation import recover_from_ric

WINDOW = 40  # chapter 09's transition window (frames)
LAPTOP_INSTANCES = 32  # chapter 09 scores the first 32 instances in the laptop profile
SINGLE_REPEATS = 10  # seeds for the "ground truth (single)" windows (random places in the clips)
CUT_LENGTHS = (40, 100)  # frames of a real window cut out of a take: 2-5 s, within HumanML3D's 40-196
CUTS_PER_TAKE = 6


def _round(values, digits: int = 4) -> list[float]:
    return [round(float(v), digits) for v in values]


def single_jerk(clips: list[np.ndarray], n_windows: int) -> dict:
    """The "ground truth (single)" Jerk as chapter 09 computes it (``evaluate_ground_truth_single``): Eq. 10 on
    ``n_windows`` random ``WINDOW``-frame windows of the clips, joints recovered per window; one mean per seed."""
    per_seed = []
    for seed in range(SINGLE_REPEATS):
        windows = real_windows(clips, WINDOW, seed, n=max(n_windows, 2))
        per_seed.append(float(np.nanmean(log_jerk_batch(recover_from_ric(np.stack(windows).astype(np.float32))))))
    mean, half = mean_ci(per_seed)
    return {"mean": mean, "ci95": half, "per_seed": _round(per_seed), "n_windows": max(n_windows, 2)}


def concat_measures(sequences: list[list[np.ndarray]], kinds: list[str] | None = None) -> dict:
    """Eq. 10 around every seam of clips played back to back (``transition_jerk`` on ``concatenate_segments``,
    as ``ground_truth_concat_jerk`` does) and the pose jump at each seam; ``kinds`` (one per seam, optional)
    says what the two clips show there (``"rest|move"``: the first ends at rest, the second starts mid-move)."""
    jerks, jumps = [], []
    for segments in sequences:
        jerks.extend(transition_jerk(*concatenate_segments(segments), WINDOW))
        jumps.extend(seam_pose_jump(a, b) for a, b in zip(segments, segments[1:], strict=False))
    jerks = np.asarray(jerks)
    out = {
        "mean": float(np.nanmean(jerks)),
        "n_seams": len(jerks),
        "values": _round(jerks, 3),
        "pose_jump_cm": _round(100 * np.asarray(jumps), 2),
    }
    if kinds is not None:
        out["kinds"] = kinds
    return out


def edge_measures(clips: list[np.ndarray]) -> dict:
    """Per clip: the speeds of :func:`edge_speeds`, lists keyed like its dict; the share of moving starts and ends."""
    rows = [edge_speeds(c) for c in clips]
    out = {key: _round([r[key] for r in rows], 3) for key in rows[0] if not key.startswith("moving")}
    out["share_moving_start"] = float(np.mean([r["moving_start"] for r in rows]))
    out["share_moving_end"] = float(np.mean([r["moving_end"] for r in rows]))
    step = [
        np.median(np.linalg.norm(np.diff(recover_from_ric(c.astype(np.float32)), axis=0), axis=-1).mean(-1))
        for c in clips
    ]
    out["median_frame_step_cm"] = float(100 * np.median(step))
    return out


def measure_embedded(out: Path, n_clips: int, seed: int) -> Path:
    with tempfile.TemporaryDirectory(prefix="clip-boundaries-") as tmp:
        wall, cpu = time.perf_counter(), time.process_time()
        root = write_embedded_dataset(Path(tmp) / "data", n_clips, seed=seed, progress=False, workers=1)
        generation = {
            "n_clips": n_clips,
            "workers": 1,
            "wall_s": round(time.perf_counter() - wall, 1),
            "cpu_s": round(time.process_time() - cpu, 1),
            "load_after": _round(os.getloadavg(), 2),
        }
        print(f"generated {n_clips} clips in {generation['wall_s']} s ({generation['cpu_s']} CPU-s)", flush=True)
        dataset = MotionDataset(root)
        meta = json.loads((root / "meta.json").read_text())["clips"]
        pool = single_action_pool(dataset, "test")
        instances = build_multi_action_testset(dataset, 4, seed=seed)
        sequences = [inst.real_segments for inst in instances]
        segments = [s for seq in sequences for s in seq]
        # what each clip shows at its ends (version 3 on; every earlier clip starts and ends at rest)
        ends = {cid: (c["params"].get("starts", "rest"), c["params"].get("ends", "rest")) for cid, c in meta.items()}
        kinds = [
            f"{ends[a.name][1]}|{ends[b.name][0]}"
            for inst in instances
            for a, b in zip(inst.clips, inst.clips[1:], strict=False)
        ]
        concat = concat_measures(sequences, kinds)
        # the same number chapter 09 reports, from its own function
        assert np.isclose(concat["mean"], ground_truth_concat_jerk(instances)), concat["mean"]
        lengths = np.array([c["n_frames"] for c in meta.values()])
        result = {
            "source": "embedded",
            "version": VERSION,
            "seed": seed,
            "generation": generation,
            "lengths": {f"p{p}": float(np.percentile(lengths, p)) for p in (0, 10, 50, 90, 100)},
            "n_pool": len(pool),
            "n_instances": len(instances),
            "edges": edge_measures([p.clip.features for p in pool]),
            "concat": concat,
            "concat_laptop_subset": ground_truth_concat_jerk(instances[:LAPTOP_INSTANCES]),
            "single": single_jerk(segments, concat["n_seams"]),
        }
    return _write(out / f"embedded-v{VERSION}.json", result)


def _takes(shared: Path) -> dict[str, tuple[np.ndarray, Path | None]]:
    """Whole real takes as features: HumanML3D clips as stored, CMU takes through the BVH import."""
    takes = {}
    for path in sorted((shared / "humanml3d-sample" / "new_joint_vecs").glob("*.npy")):
        takes[f"HumanML3D {path.stem}"] = (np.load(path).astype(np.float32), None)
    for path in sorted((shared / "momask-example").glob("*.npy")):
        takes[f"HumanML3D {path.stem}"] = (np.load(path).astype(np.float32), None)
    for path in sorted((shared / "cmu-bvh").glob("*.bvh")):
        takes[f"CMU {path.stem}"] = (bvh_to_features(path).astype(np.float32), path)
    if not takes:
        raise SystemExit(f"no real clips under {shared}")
    return takes


def _cut(features: np.ndarray, bvh: Path | None, start: int, stop: int) -> np.ndarray:
    """Rows ``[start, stop)`` of a take: a CMU take is cropped in the BVH import (as ``data from-bvh`` crops it,
    features recomputed from the cropped joints), a HumanML3D clip by its feature rows."""
    if bvh is None:
        return features[start:stop]
    return bvh_to_features(bvh, start=start, end=stop + 1).astype(np.float32)  # stop + 1 poses -> stop rows


def measure_real(out: Path, shared: Path, seed: int) -> Path:
    takes = _takes(shared)
    rng = np.random.default_rng(seed)
    cuts: dict[str, list[np.ndarray]] = {}
    for name, (features, bvh) in takes.items():
        cuts[name] = []
        for _ in range(CUTS_PER_TAKE):
            length = int(rng.integers(CUT_LENGTHS[0], CUT_LENGTHS[1] + 1))
            start = int(rng.integers(len(features) - length + 1))
            cuts[name].append(_cut(features, bvh, start, start + length))
    whole = {name: f[: len(f) // 4 * 4] for name, (f, _) in takes.items()}  # floored to 4 frames, as chapter 09
    cut_clips = [(name, c[: len(c) // 4 * 4]) for name, cs in cuts.items() for c in cs]
    result = {
        "source": "real",
        "seed": seed,
        "takes": {name: len(f) for name, (f, _) in takes.items()},
        "acknowledgement": "CMU: the data used in this project was obtained from mocap.cs.cmu.edu. The database was "
        "created with funding from NSF EIA-0196217.",
        "whole": {
            "edges": edge_measures(list(whole.values())),
            "concat": concat_measures([[whole[a], whole[b]] for a, b in permutations(whole, 2)]),
            "single": single_jerk(list(whole.values()), 200),
        },
        # pairs of windows from different takes: a window joined to its own take's continuation would be seamless
        "cut": {
            "cuts_per_take": CUTS_PER_TAKE,
            "lengths": list(CUT_LENGTHS),
            "edges": edge_measures([c for _, c in cut_clips]),
            "concat": concat_measures([[a, b] for (ta, a), (tb, b) in permutations(cut_clips, 2) if ta != tb]),
        },
    }
    return _write(out / "real.json", result)


def _write(path: Path, result: dict) -> Path:
    result["machine"] = {
        "python": platform.python_version(),
        "torch": torch.__version__,
        "cpus": os.cpu_count(),
        "date": time.strftime("%Y-%m-%d"),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    flat_list = re.compile(r"\[\s+([^\[\]{}]*?)\s+\]")  # a list of numbers or words: one line, not one per item
    text = flat_list.sub(lambda m: "[" + " ".join(m.group(1).split()) + "]", json.dumps(result, indent=1))
    write_text_atomic(path, text + "\n")
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("what", choices=("embedded", "real"))
    parser.add_argument("--out", type=Path, default=Path("book/data/clip_boundaries"))
    parser.add_argument("--shared", type=Path, default=Path("../shared/data"), help="the real clips (read only)")
    parser.add_argument("--n-clips", type=int, default=3000, help="embedded clips (the laptop profile's 3,000)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    torch.set_num_threads(int(os.environ.get("MOTIONLAB_THREADS", "1")))
    if args.what == "embedded":
        path = measure_embedded(args.out, args.n_clips, args.seed)
    else:
        path = measure_real(args.out, args.shared, args.seed)
    result = json.loads(path.read_text())
    parts = [result] if args.what == "embedded" else [result["whole"], result["cut"]]
    for part in parts:
        single = part.get("single", {}).get("mean", float("nan"))
        edges = part["edges"]
        print(
            f"{path.name}: concat Jerk {part['concat']['mean']:.3f} ({part['concat']['n_seams']} seams), single "
            f"{single:.3f}; moving starts {edges['share_moving_start']:.0%}, ends {edges['share_moving_end']:.0%} "
            f"(joint speed >= {MOVING_SPEED} m/s); seam pose jump median "
            f"{np.median(part['concat']['pose_jump_cm']):.1f} cm"
        )


if __name__ == "__main__":
    main()
