"""Draw the README's picture: frames of a generated motion, side by side, with the library's own stick figure.

    motionlab generate "a person waves" --out wave.npy        # laptop models: trained once, then cached
    python tools/front_picture.py wave.npy --out book/images/front.png

The motion's sidecar (``wave.npy.json``, written by ``generate``) names its text, profile and seed; the picture's
caption repeats them, so the image says which model drew it. A smoke motion is refused: it only shows that the
code runs, and the README's picture stands for what the book's models do.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from motionlab.io import load_joints  # noqa: E402
from motionlab.io.provenance import sidecar_path  # noqa: E402
from motionlab.viz.skeleton import plot_pose  # noqa: E402


def frame_indices(n_frames: int, count: int) -> list[int]:
    """``count`` frames spread evenly from the first to the last of ``n_frames``."""
    if n_frames < 1 or count < 1:
        raise ValueError(f"need at least one frame and one panel, got {n_frames} frames, {count} panels")
    return sorted({int(round(k)) for k in np.linspace(0, n_frames - 1, min(count, n_frames))})


def draw(joints: np.ndarray, caption: str, panels: int = 6, fps: float = 20.0):
    """A figure of ``panels`` poses of ``joints`` ``(T, 22, 3)``, each titled with its time, and ``caption`` below."""
    frames = frame_indices(len(joints), panels)
    fig = plt.figure(figsize=(1.6 * len(frames), 2.3))
    for k, t in enumerate(frames):
        ax = fig.add_subplot(1, len(frames), k + 1, projection="3d")
        plot_pose(joints[t], "t2m", ax=ax, title=f"{t / fps:.1f} s")
    fig.text(0.5, 0.02, caption, ha="center", fontsize=8)
    fig.subplots_adjust(left=0, right=1, top=0.9, bottom=0.08, wspace=0)
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("motion", type=Path, help="a .npy motion written by `motionlab generate`")
    parser.add_argument("--out", type=Path, default=Path("book/images/front.png"), help="the PNG to write")
    parser.add_argument("--panels", type=int, default=6, help="poses drawn (default: 6)")
    args = parser.parse_args(argv)
    made = json.loads(sidecar_path(args.motion).read_text()) if sidecar_path(args.motion).is_file() else {}
    if made.get("profile") == "smoke":
        print(
            "error: a smoke motion only shows that the code runs; generate one with the laptop models", file=sys.stderr
        )
        return 2
    caption = f'"{made.get("text", args.motion.stem)}"'
    if made:
        caption += f" ({made['profile']} profile, seed {made['seed']}, {made['code']})"
    fig = draw(load_joints(args.motion), caption, args.panels)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110, bbox_inches="tight")
    print(f"{args.out}: {args.out.stat().st_size // 1024} KB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
