"""Diagrams of the book's foundations: motion as a vector per frame (chapter 01) and residual vector quantization
(chapter 02).

Every size the diagrams print is read from the library: the feature groups and their widths from
:func:`motionlab.representation.feature_slices`, the skeleton from :mod:`motionlab.representation`, the codebook
sizes from a tokenizer configuration (:class:`motionlab.tokenizers.RVQConfig`) and the frames per token from the
tokenizer class.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Rectangle

from ...io.palette import CHAIN_COLORS
from ...representation import Skeleton, feature_slices, forward_kinematics, get_skeleton
from ...tokenizers import RVQVAE, RVQConfig
from ..plots import GROUP_COLORS
from ._draw import PALETTE, Canvas

# What each group of the HumanML3D vector holds, in the words of chapter 01 (the keys are the library's names).
GROUP_LABELS = {
    "root_rot_vel": "root angular velocity",
    "root_lin_vel": "root linear velocity (x, z)",
    "root_height": "root height",
    "ric": "ric: joints relative to the root",
    "rot": "rot: local rotations, 6D",
    "local_vel": "local joint velocities",
    "foot_contact": "foot contacts",
}


def _group_width_text(name: str, width: int, sk: Skeleton) -> str:
    """``63 = 21 × 3`` for the per-joint groups (the root is left out of ric and rot), the width alone otherwise."""
    per_joint = {"ric": sk.n_joints - 1, "rot": sk.n_joints - 1, "local_vel": sk.n_joints}
    if name in per_joint:
        return f"{width} = {per_joint[name]} × {width // per_joint[name]}"
    return str(width)


def _draw_poses(canvas: Canvas, joints: np.ndarray, sk: Skeleton, box: tuple[float, float, float, float], n: int):
    """``n`` poses of ``joints (T, J, 3)``, evenly spaced in time, drawn side by side in ``box = (x, y, w, h)`` with
    the floor on its bottom edge. Each pose is seen across the root's direction of travel (from the side when the
    clip moves, from the front when it stays in place) and centred in its own slot; returns the frames drawn."""
    x0, y0, w, h = box
    frames = np.linspace(0, len(joints) - 1, n).round().astype(int)
    poses = joints[frames] - np.array([0.0, joints[..., 1].min(), 0.0])  # (n, J, 3), floor at 0
    travel = joints[-1, 0, [0, 2]] - joints[0, 0, [0, 2]]
    # horizontal axis of the drawing: the direction of travel, or x (a front view) for a clip that stays in place
    across = travel / np.linalg.norm(travel) if np.linalg.norm(travel) > 0.3 else np.array([1.0, 0.0])
    horizontal = poses[..., [0, 2]] @ across  # (n, J)
    horizontal = horizontal - poses[:, :1, [0, 2]] @ across  # each pose about its own root
    scale = min(h / max(float(poses[..., 1].max()), 1e-6), w / n / max(float(np.ptp(horizontal, axis=1).max()), 0.3))
    for i, (pose, along) in enumerate(zip(poses, horizontal)):
        centre = x0 + (i + 0.5) * w / n
        for k, chain in enumerate(sk.chains):
            idx = list(chain)
            canvas.ax.plot(
                centre + scale * along[idx],
                y0 + scale * pose[idx, 1],
                color=CHAIN_COLORS[k % len(CHAIN_COLORS)],
                lw=1.4,
                solid_capstyle="round",
            )
    canvas.ax.plot([x0, x0 + w], [y0, y0], color=PALETTE["edge"], lw=0.6)
    return frames


def motion_as_data(joints: np.ndarray | None = None, skeleton: str | Skeleton = "t2m", *, n_poses: int = 3) -> Figure:
    """Motion as data: joint positions ``(T, J, 3)`` become one feature vector per frame, and come back.

    Left, ``n_poses`` poses of ``joints`` evenly spaced in time, seen from the side of the root's path (by default
    the rest pose of ``skeleton``: :func:`~motionlab.representation.forward_kinematics` with identity rotations).
    Right, the HumanML3D feature vector of one frame as a column whose segments have the true widths of its groups
    (:func:`~motionlab.representation.feature_slices`), each labelled with its name, its index range and its width.
    Arrows: ``process_joints`` turns joints into features; ``recover_from_ric`` (root velocities integrated, ric
    un-rotated) and ``recover_from_rot`` (forward kinematics of the 6D rotations) turn features back into joints.
    """
    sk = get_skeleton(skeleton)
    if n_poses < 1:
        raise ValueError(f"n_poses must be at least 1, got {n_poses}")
    if joints is None:
        identity = np.tile([1.0, 0.0, 0.0, 0.0], (1, sk.n_joints, 1))
        joints = forward_kinematics(identity, np.zeros((1, 3)), sk)
        joints = joints - np.array([0.0, joints[..., 1].min(), 0.0])  # feet on the floor
        n_poses = 1
    joints = np.asarray(joints, dtype=np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (sk.n_joints, 3):
        raise ValueError(f"joints must have shape (T, {sk.n_joints}, 3) for skeleton {sk.name!r}, got {joints.shape}")
    if not np.isfinite(joints).all():
        raise ValueError("joints contain NaN or inf values")
    n_poses = min(n_poses, len(joints))

    canvas = Canvas(9.8, 5.2)
    ax = canvas.ax

    # left: the poses
    canvas.text(1.75, 5.0, "joint positions $\\mathbf{p}_j(t)$", fontsize=9)
    canvas.text(1.75, 4.65, f"T frames × {sk.n_joints} joints × 3, in metres", fontsize=8)
    frames = _draw_poses(canvas, joints * sk.meters_per_unit, sk, (0.2, 1.35, 3.1, 2.9), n_poses)
    if len(frames) > 1:
        seconds = ", ".join(f"{f / sk.fps:.1f}" for f in frames)
        canvas.text(1.75, 1.05, f"t = {seconds} s ({sk.fps:g} frames per second)", fontsize=7.5)

    # right: the feature vector of one frame, segments to scale
    slices = feature_slices(sk)
    top, bottom, col_x, col_w = 4.65, 0.35, 5.7, 0.45
    per_dim = (top - bottom) / sk.feature_dim
    canvas.text(col_x + col_w / 2, 5.0, f"feature vector $\\mathbf{{x}}_i \\in \\mathbb{{R}}^{{{sk.feature_dim}}}$")
    label_ys = np.linspace(top - 0.1, bottom + 0.1, len(slices))
    centres = {}
    for (name, sl), label_y in zip(slices.items(), label_ys):
        width = sl.stop - sl.start
        y_hi = top - sl.start * per_dim
        y_lo = top - sl.stop * per_dim
        ax.add_patch(Rectangle((col_x, y_lo), col_w, y_hi - y_lo, facecolor=GROUP_COLORS[name], edgecolor="white"))
        centres[name] = (y_hi + y_lo) / 2
        ax.plot([col_x + col_w, col_x + col_w + 0.25, 6.45], [centres[name], label_y, label_y], color="#777", lw=0.6)
        canvas.text(
            6.5,
            label_y,
            f"{GROUP_LABELS.get(name, name)}\n[{sl.start}:{sl.stop}]  {_group_width_text(name, width, sk)}",
            fontsize=7.5,
            ha="left",
            linespacing=1.1,
        )

    # arrows: joints -> features, and the two ways back
    canvas.arrow((3.45, 4.25), (col_x - 0.05, 4.25))
    canvas.text(4.55, 4.47, "process_joints", fontsize=8, family="monospace")
    canvas.text(4.55, 3.98, "canonical frame,\nvelocities, contacts", fontsize=7)
    ric, rot = centres["ric"], centres["rot"]
    canvas.arrow((col_x - 0.05, ric), (3.45, 3.45), color=PALETTE["accent"])
    canvas.text(4.5, 3.35, "recover_from_ric", fontsize=8, family="monospace", color=PALETTE["accent"])
    canvas.text(4.5, 3.03, "integrate the root,\nun-rotate ric: exact", fontsize=7)
    canvas.arrow((col_x - 0.05, rot), (3.45, 2.55), dashed=True)
    canvas.text(4.5, 2.32, "recover_from_rot", fontsize=8, family="monospace")
    canvas.text(4.5, 2.0, "forward kinematics\nof the 6D rotations", fontsize=7)

    canvas.text(
        1.75,
        0.45,
        f"T poses give T − 1 rows (the velocities need\nthe next pose): a clip is a (T − 1) × {sk.feature_dim} matrix",
        fontsize=7.5,
    )
    return canvas.finish()


def residual_vq(config: RVQConfig | None = None, *, shown_layers: int = 3, positions: int = 4) -> Figure:
    """Residual vector quantization of one encoder output, layer by layer, and the token ids it leaves behind.

    The motion ``T × D`` goes through the encoder to one vector ``z_i`` per ``downsample`` frames. Layer ``k``
    replaces its residual ``r^k`` by the nearest of its ``K`` codes (token ``s^k_i``, code vector ``q^k``) and passes
    on ``r^{k+1} = r^k − q^k``; the sum of the code vectors goes to the decoder. Each layer's strip is its row of
    token ids over the clip's ``T / downsample`` positions. Sizes come from ``config`` (a
    :class:`~motionlab.tokenizers.RVQConfig`, by default the papers' ``RVQConfig()``): ``num_layers`` ``R``,
    ``codebook_size`` ``K``, ``code_dim`` and ``feature_dim`` ``D``; the frames per token from
    :attr:`~motionlab.tokenizers.RVQVAE.downsample`. ``shown_layers`` layers are drawn (when ``R`` is larger, the
    first ``shown_layers − 1``, a gap, and layer ``R − 1``), with ``positions`` token positions per strip.
    """
    config = RVQConfig() if config is None else config
    if not isinstance(config, RVQConfig):
        raise ValueError(f"config must be an RVQConfig (a residual tokenizer), got {type(config).__name__}")
    if shown_layers < 2:
        raise ValueError(f"shown_layers must be at least 2 (a residual needs two layers), got {shown_layers}")
    if not 2 <= positions <= 6:
        raise ValueError(f"positions must be between 2 and 6, got {positions}")
    n_layers, k_codes, dim, feat = config.num_layers, config.codebook_size, config.code_dim, config.feature_dim
    q = RVQVAE.downsample
    rows = list(range(n_layers)) if n_layers <= shown_layers else [*range(shown_layers - 1), n_layers - 1]

    row_h, gap, skip = 0.5, 0.6, 0.35
    span = len(rows) * row_h + (len(rows) - 1) * gap + (skip if len(rows) < n_layers else 0)
    height = span + 2.75
    canvas = Canvas(9.8, height)
    row_y = [height - 2.75 - i * (row_h + gap) for i in range(len(rows))]
    if len(rows) < n_layers:  # room for the dots before the last layer
        row_y[-1] -= skip
    top = height - 0.55

    canvas.text(
        4.9,
        height - 0.2,
        f"{n_layers} layers, each a codebook of {k_codes} codes in $\\mathbb{{R}}^{{{dim}}}$",
        fontsize=9,
    )
    # left column: motion -> encoder -> z_i = r^0
    motion = canvas.box(0.1, top - 0.5, 1.7, 0.5, f"motion $\\mathbf{{X}}$\n$T \\times {feat}$", "data", fontsize=8)
    encoder = canvas.box(0.1, top - 1.25, 1.7, 0.5, "encoder $\\mathcal{E}$", "network")
    canvas.arrow(motion, encoder, start_side="bottom", end_side="top")
    canvas.text(
        1.95,
        encoder.center[1],
        f"one $\\mathbf{{z}}_i \\in \\mathbb{{R}}^{{{dim}}}$\nper {q} frames",
        fontsize=7.5,
        ha="left",
    )

    residuals, layers, cells, codes = [], [], [], []
    for k, y in zip(rows, row_y):
        label = "$\\mathbf{r}^0 = \\mathbf{z}_i$" if k == 0 else f"$\\mathbf{{r}}^{{{k}}}$"
        residuals.append(canvas.box(0.1, y, 1.7, row_h, label, "data"))
        layers.append(canvas.box(2.3, y, 1.9, row_h, f"layer {k}: nearest\nof {k_codes} codes", fontsize=8))
        canvas.arrow(residuals[-1], layers[-1])
        labels = [f"$s^{{{k}}}_i$" if j == 0 else "" for j in range(positions)]
        kinds = ["token" if j == 0 else "operation" for j in range(positions)]
        cells.append(canvas.strip(4.65, y + 0.03, labels, cell=0.44, kinds=kinds, fontsize=8))
        canvas.arrow(layers[-1], cells[-1][0])
        code = f"$\\mathbf{{q}}^{{{k}}} = \\mathbf{{c}}^{{{k}}}_{{s^{{{k}}}_i}}$"
        codes.append(canvas.box(6.85, y, 1.25, row_h, code, "token", fontsize=8))
        canvas.arrow(cells[-1][-1], codes[-1])
    canvas.arrow(encoder, residuals[0], start_side="bottom", end_side="top")

    # between drawn rows: r^{k+1} = r^k − q^k, or dots where layers are left out
    for i in range(len(rows) - 1):
        k, mid = rows[i], (row_y[i] + row_y[i + 1] + row_h) / 2
        if rows[i + 1] == k + 1:
            x_minus = residuals[i].center[0]
            canvas.arrow(residuals[i], (x_minus, mid + 0.12), start_side="bottom")
            canvas.ax.add_patch(Circle((x_minus, mid), 0.12, facecolor="white", edgecolor=PALETTE["edge"], lw=0.9))
            canvas.text(x_minus, mid, "−", fontsize=10)
            canvas.arrow((x_minus, mid - 0.12), residuals[i + 1], end_side="top")
            q_x = codes[i].center[0]
            canvas.ax.plot([q_x, q_x], [codes[i].y, mid], color=PALETTE["accent"], lw=1.0, ls="--")
            canvas.arrow((q_x, mid), (x_minus + 0.12, mid), color=PALETTE["accent"], dashed=True)
            canvas.text(
                3.25,
                mid,
                f"$\\mathbf{{r}}^{{{k + 1}}} = \\mathbf{{r}}^{{{k}}} - \\mathbf{{q}}^{{{k}}}$",
                fontsize=8,
                color=PALETTE["accent"],
                bbox={"facecolor": "white", "edgecolor": "none", "pad": 1.0},
            )
        else:
            for box in (residuals[i], layers[i], codes[i]):
                canvas.text(box.center[0], mid, "⋮", fontsize=11)
            canvas.text(cells[i][0].center[0], mid, "⋮", fontsize=11)

    # right column: the sum of the code vectors -> decoder -> reconstruction
    output = canvas.box(8.0, top - 0.5, 1.7, 0.5, f"$\\hat{{\\mathbf{{X}}}}$\n$T \\times {feat}$", "data", fontsize=8)
    decoder = canvas.box(8.0, top - 1.25, 1.7, 0.5, "decoder $\\mathcal{D}$", "network")
    lowest = row_y[-1]
    total = canvas.box(decoder.center[0] - 0.25, lowest, 0.5, row_y[0] + row_h - lowest, "Σ", fontsize=12)
    for code in codes:
        canvas.arrow(code, (total.x, code.center[1]))
    canvas.arrow(total, decoder, start_side="top", end_side="bottom")
    canvas.arrow(decoder, output, start_side="top", end_side="bottom")

    # the strips, stacked, are the clip's token ids
    left, right = cells[0][0].x, cells[0][-1].x + cells[0][-1].w
    canvas.bracket(left, right, row_y[0] + row_h + 0.2, f"one row of ids per layer, $T/{q}$ positions", below=False)
    canvas.text((left + right) / 2, lowest - 0.3, f"a clip: {n_layers} × $T/{q}$ ids in 0 … {k_codes - 1}", fontsize=8)
    return canvas.finish()
