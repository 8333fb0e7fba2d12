"""The DisCoRD decoder as one picture: token ids → summed code vectors → condition projection → frame-wise condition
``C`` → concatenated to the noisy motion ``x_t`` → 1-D U-Net ``v_θ(x_t, t, C)`` → ODE steps from ``x_0`` to the
motion ``x_1`` (chapter 05).

Every size on the picture comes from a :class:`~motionlab.flow.DisCoRDConfig`: the condition's shape is what the
library's own projection returns (run on the ``meta`` device, so nothing is computed), the concatenation's width is
the U-Net's input width, the number of U-Net calls is :func:`~motionlab.flow.n_evaluations`. Where the config departs
from the paper (what the network predicts, the start-noise temperature), the labels say so.
"""

from __future__ import annotations

import torch
from matplotlib.figure import Figure

from motionlab.flow.condition import make_condition_projection
from motionlab.flow.config import DisCoRDConfig
from motionlab.flow.rectified_flow import n_evaluations
from motionlab.viz.diagrams._draw import Canvas

__all__ = ["pipeline"]


def _condition_shape(config: DisCoRDConfig, tokens: int) -> tuple[int, int]:
    """``(T, d_feat)`` of the frame-wise condition, from the library's projection on ``tokens`` code vectors."""
    with torch.device("meta"):  # shapes only: no weights are initialised, nothing is computed
        projection = make_condition_projection(config.projection, config.code_dim, config.cond_dim, q=config.q)
        condition = projection(torch.zeros(1, tokens, config.code_dim))
    _, frames, width = condition.shape
    return int(frames), int(width)


def _projection_steps(config: DisCoRDConfig, tokens: int, frames: int, width: int) -> str:
    """The projection's steps with their shapes, one per line (DisCoRD's "stacked" or an ablation of Table 6)."""
    q, d = config.q, config.code_dim
    if config.projection == "stacked":
        return (
            f"repeat ×{q}, stack: {tokens} × {q * d}\n"
            f"linear, unstack: {frames} × {d}\n"
            f"linear per frame: {frames} × {width}"
        )
    if config.projection == "repeat":
        return f"repeat ×{q}: {frames} × {d}\nlinear per frame: {frames} × {width}"
    return f"transposed conv, stride {q}\n{frames} × {width}"


def _start_noise(temperature: float) -> str:
    if temperature == 1:
        return r"$\mathbf{x}_0 \sim \mathcal{N}(0, I)$"
    if temperature == 0:
        return r"$\mathbf{x}_0 = 0$ (temperature 0)"
    return rf"$\mathbf{{x}}_0 \sim \mathcal{{N}}(0, {temperature:g}^2 I)$"


def _check(config: object, residual_layers: object, frames: object) -> None:
    if not isinstance(config, DisCoRDConfig):
        raise ValueError(f"config must be a DisCoRDConfig (flow.discord_config(...)), got {type(config).__name__}")
    if isinstance(residual_layers, bool) or not isinstance(residual_layers, int) or residual_layers < 1:
        raise ValueError(f"residual_layers must be a positive int, got {residual_layers!r}")
    if frames is not None and (
        isinstance(frames, bool) or not isinstance(frames, int) or frames < 1 or frames % config.unet.length_multiple
    ):
        raise ValueError(
            f"frames must be a positive multiple of {config.unet.length_multiple} (whole tokens), got {frames!r}"
        )


def pipeline(config: DisCoRDConfig | None = None, *, residual_layers: int = 6, frames: int | None = None) -> Figure:
    """The DisCoRD decoder from token ids to motion, with the sizes of ``config`` (default: the paper's).

    ``residual_layers`` is the tokenizer's ``R`` (1 for a single codebook); ``frames`` the clip length ``T``
    (default: the training window). Returns a 7.4-inch-wide figure: the condition path down the left, the ODE loop
    (concatenation and U-Net, called at every step) along the bottom.
    """
    config = DisCoRDConfig() if config is None else config
    _check(config, residual_layers, frames)
    frames = config.window if frames is None else frames
    tokens = frames // config.q
    T, width = _condition_shape(config, tokens)
    D, calls = config.feature_dim, n_evaluations(config.sample_steps, config.solver)
    layers = f"{residual_layers} layer{'s' if residual_layers > 1 else ''}"

    canvas = Canvas(10.0, 4.9, inches_per_unit=0.74)
    # the condition path, top to bottom: computed once per clip
    ids = canvas.box(
        0.1, 4.05, 2.9, 0.75, f"token ids\n{tokens} tokens × {layers} ($T/q \\times R$)", "token", fontsize=8
    )
    codes = canvas.box(
        0.1,
        2.95,
        2.9,
        0.75,
        f"code vectors, summed over layers\n$\\mathbf{{Z}}$: {tokens} × {config.code_dim} ($T/q \\times d$)",
        "token",
        fontsize=8,
    )
    steps = _projection_steps(config, tokens, T, width)
    projection = canvas.box(0.1, 1.3, 2.9, 1.3, f"condition projection $P$, once\n{steps}", "operation", fontsize=8)
    condition = canvas.box(
        0.1,
        0.15,
        2.9,
        0.8,
        f"frame-wise condition $\\mathbf{{C}}$\n{T} × {width} ($T \\times d_{{feat}}$)",
        "condition",
        fontsize=8,
    )
    for upper, lower in ((ids, codes), (codes, projection), (projection, condition)):
        canvas.arrow(upper, lower, start_side="bottom", end_side="top")

    # the ODE loop: concatenate, call the U-Net, take a step; repeated from t = 0 to t = 1
    canvas.box(3.35, 0.02, 5.05, 2.45, kind="operation", dashed=True)
    ode = f"ODE, $t$: 0 → 1\n{config.sample_steps} {config.solver} steps = {calls} U-Net calls"
    canvas.text(5.95, 2.12, ode, fontsize=8)
    concat = canvas.box(
        3.55, 0.15, 1.9, 1.05, f"concatenate\n$[\\mathbf{{x}}_t, \\mathbf{{C}}]$\n{T} × {D + width}", "data", fontsize=8
    )
    if config.prediction == "v":
        field = "1-D U-Net\n$v_\\theta(\\mathbf{x}_t, t, \\mathbf{C})$"
    else:
        field = "1-D U-Net outputs $\\hat{\\mathbf{x}}_1$\n$v = (\\hat{\\mathbf{x}}_1 - \\mathbf{x}_t) / (1 - t)$"
    channels = "channels " + ", ".join(map(str, config.unet.dims))
    unet = canvas.box(5.85, 0.15, 2.4, 1.05, f"{field}\n{channels}", "network", fontsize=8)
    motion = canvas.box(
        8.65, 0.15, 1.25, 1.05, f"$\\mathbf{{x}}_1$ at $t = 1$:\nthe motion\n{T} × {D}", "data", fontsize=8
    )
    canvas.box(3.55, 3.05, 2.3, 0.95, f"{_start_noise(config.temperature)}\nat $t = 0$: {T} × {D}", "noise", fontsize=8)

    canvas.arrow(condition, concat)
    canvas.arrow((3.95, 3.05), (3.95, 1.2))  # x_0 is the first x_t
    canvas.arrow(concat, unet)
    step = "step: $\\mathbf{x}_t \\to \\mathbf{x}_{t + \\Delta t}$"
    canvas.arrow(unet, concat, step, start_side="top", end_side="top", curve=0.45, text_offset=(0.0, 0.22))
    canvas.arrow(unet, motion)
    canvas.text(7.85, 3.45, "$t$ enters every\nResNet block\n(scale and shift)", fontsize=8)
    canvas.arrow((7.85, 2.95), (7.85, 1.22), dashed=True)
    return canvas.finish()
