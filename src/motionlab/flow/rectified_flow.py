"""Rectified flow: the training objective and fixed-grid ODE samplers, with no network inside.

Like a diffusers scheduler, this module only knows about tensors and a *velocity function*
``velocity_fn(x_t, t, cond) -> v`` with ``x_t`` of any shape ``(B, ...)``, ``t`` of shape ``(B,)`` and
``cond`` whatever the network needs (or ``None``). The network lives elsewhere (``unet1d.py``).

Convention (DisCoRD and gnobitab/RectifiedFlow agree): noise at ``t = 0``, data at ``t = 1``::

    x_t = t · x1 + (1 − t) · x0,      x0 ~ N(0, I),  x1 ~ data,  t ~ U(0, 1)
    target velocity  v* = d x_t / dt = x1 − x0
    loss = E ‖v*  − v(x_t, t, cond)‖²              (mean over every element)

Sampling integrates ``dx/dt = v(x, t, cond)`` from ``t = 0`` (noise) to ``t = 1`` (data) on a fixed grid
(uniform ``t_k = k / steps``, or denser near the data end). ``steps`` is the number of *intervals*; the network
is called :func:`n_evaluations` ``(steps, solver)`` times: once per interval for Euler, twice for midpoint (RK2).

**What the network predicts.** The paper's network outputs the velocity (``prediction="v"``). With
``prediction="x"`` it outputs the clean data ``x̂1`` instead, and the velocity it implies along the straight
path is ``v = (x̂1 − x_t) / (1 − t)`` (``1 − t`` clamped at :data:`X_PREDICTION_MIN_GAP`, as Li & He, 2025, do).
Both are trained with the same loss, on the velocity: for ``x`` it equals ``‖x̂1 − x1‖² / (1 − t)²``, which
weighs late times more. A network narrow relative to its data cannot carry every noise dimension through to
its output; predicting ``x̂1`` asks it to *drop* the noise rather than reproduce it, so what it cannot
represent is lost from the noise, not left in the motion. The samplers only ever see velocities
(:func:`as_velocity_fn`), so they are the same code for both.

The public DisCoRD code calls ``torchdiffeq.odeint(..., torch.linspace(0, 1, 16), method="midpoint")``:
a 16-point grid, i.e. **15 midpoint intervals = 30 network evaluations**, not "16 Euler steps".
:func:`discord_default_solver` returns exactly that setting.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch
from torch import Tensor

VelocityFn = Callable[[Tensor, Tensor, Any], Tensor]
SOLVERS = ("euler", "midpoint")
_EVALS_PER_STEP = {"euler": 1, "midpoint": 2}
PREDICTIONS = ("v", "x")  # what the network outputs: the velocity x1 − x0, or the clean data x1
TIME_DISTRIBUTIONS = ("uniform", "logit_normal")  # training times: U(0, 1), or sigmoid(N(loc, scale²))
GRIDS = ("uniform", "data_dense")  # sampling grids: t_k = k/n, or t_k = 1 − (1 − k/n)², denser near t = 1
X_PREDICTION_MIN_GAP = 0.05  # 1 − t is clamped here when x-prediction is turned into a velocity

# The public DisCoRD sampler: odeint over linspace(0, 1, 16) with the midpoint method.
DISCORD_GRID_POINTS = 16
DISCORD_SOLVER = "midpoint"


# ----------------------------------------------------------------------------- training objective


def interpolate(x0: Tensor, x1: Tensor, t: Tensor) -> Tensor:
    """The straight path ``x_t = t · x1 + (1 − t) · x0``; ``t`` has shape ``(B,)`` and broadcasts."""
    t = t.reshape(-1, *([1] * (x1.dim() - 1))).to(x1.dtype)  # (B, 1, ..., 1)
    return t * x1 + (1.0 - t) * x0


def target_velocity(x0: Tensor, x1: Tensor) -> Tensor:
    """The constant velocity of the straight path: ``d x_t / dt = x1 − x0``."""
    return x1 - x0


def sample_noise(shape: tuple[int, ...], generator: torch.Generator, like: Tensor | None = None) -> Tensor:
    """``x0 ~ N(0, I)`` drawn on the generator's device, then moved to ``like``'s device and dtype.

    Drawing on the generator's device (CPU by default) makes a seed give the same noise whatever device
    the network runs on.
    """
    noise = torch.randn(shape, generator=generator, device=generator.device)
    if like is not None:
        noise = noise.to(device=like.device, dtype=like.dtype)
    return noise


def sample_time(
    batch: int,
    generator: torch.Generator,
    like: Tensor | None = None,
    distribution: str = "uniform",
    loc: float = 0.0,
    scale: float = 1.0,
) -> Tensor:
    """Training times of shape ``(B,)``: ``U(0, 1)`` (DisCoRD, no ε-offset at t = 0) or logit-normal.

    ``"logit_normal"`` draws ``t = sigmoid(n)``, ``n ~ N(loc, scale²)`` (as rectified-flow transformers do);
    ``loc > 0`` puts more of the training near the data end ``t = 1``.
    """
    _check_choice("distribution", distribution, TIME_DISTRIBUTIONS)
    if distribution == "uniform":
        t = torch.rand(batch, generator=generator, device=generator.device)
    else:
        if not scale > 0:
            raise ValueError(f"the logit-normal scale must be > 0, got {scale}")
        t = torch.sigmoid(loc + scale * torch.randn(batch, generator=generator, device=generator.device))
    if like is not None:
        t = t.to(device=like.device, dtype=like.dtype)
    return t


def velocity_from_data(x1_hat: Tensor, x_t: Tensor, t: Tensor, min_gap: float = X_PREDICTION_MIN_GAP) -> Tensor:
    """The velocity an x-prediction implies on the straight path: ``(x̂1 − x_t) / max(1 − t, min_gap)``.

    Exact (equal to ``x1 − x0``) whenever ``x̂1 = x1`` and ``1 − t ≥ min_gap``.
    """
    gap = (1.0 - t).clamp_min(min_gap).reshape(-1, *([1] * (x_t.dim() - 1))).to(x_t.dtype)  # (B, 1, ..., 1)
    return (x1_hat - x_t) / gap


def as_velocity_fn(network: VelocityFn, prediction: str = "v") -> VelocityFn:
    """Wrap a network so it returns velocities whatever it predicts (``"v"``: itself; ``"x"``: converted)."""
    _check_choice("prediction", prediction, PREDICTIONS)
    if prediction == "v":
        return network

    def velocity(x_t: Tensor, t: Tensor, cond: Any) -> Tensor:
        return velocity_from_data(network(x_t, t, cond), x_t, t)

    return velocity


def _check_flow_matching_loss_inputs(x1: Tensor, generator: torch.Generator | None) -> None:
    """Reject an ``x1`` that is not a ``(B, ...)`` tensor and a missing generator."""
    if not isinstance(x1, Tensor) or x1.dim() < 2:
        raise ValueError(f"x1 must be a tensor of shape (B, ...) with at least 2 dims, got {_shape(x1)}")
    if generator is None:
        raise ValueError("generator is required: pass a seeded torch.Generator")


def flow_matching_loss(
    network: VelocityFn,
    x1: Tensor,
    cond: Any = None,
    generator: torch.Generator | None = None,
    *,
    prediction: str = "v",
    time_distribution: str = "uniform",
    time_loc: float = 0.0,
    time_scale: float = 1.0,
) -> Tensor:
    """Rectified-flow loss ``mean((x1 − x0) − v(t·x1 + (1 − t)·x0, t, cond))²``.

    ``x1``: a batch of data ``(B, ...)``. ``generator`` draws both the noise ``x0`` and the times ``t``
    (from ``time_distribution``, see :func:`sample_time`); it is required (pass one created with
    ``torch.Generator().manual_seed(seed)``). ``network`` outputs what ``prediction`` says; the loss is always
    on the velocity it implies (:func:`as_velocity_fn`).
    """
    _check_flow_matching_loss_inputs(x1, generator)
    velocity_fn = as_velocity_fn(network, prediction)
    x0 = sample_noise(tuple(x1.shape), generator, like=x1)  # (B, ...)
    t = sample_time(x1.shape[0], generator, like=x1, distribution=time_distribution, loc=time_loc, scale=time_scale)
    x_t = interpolate(x0, x1, t)
    v = velocity_fn(x_t, t, cond)
    return torch.mean((target_velocity(x0, x1) - v) ** 2)


# ----------------------------------------------------------------------------- ODE samplers


@dataclass(frozen=True)
class ODESolver:
    """A fixed-grid solver setting: ``steps`` intervals of ``spacing`` on [0, 1], ``solver`` method."""

    steps: int
    solver: str = "euler"
    spacing: str = "uniform"

    def __post_init__(self) -> None:
        _check_solver(self.steps, self.solver)
        _check_choice("spacing", self.spacing, GRIDS)

    @property
    def n_evaluations(self) -> int:
        return n_evaluations(self.steps, self.solver)

    @property
    def grid(self) -> Tensor:
        return time_grid(self.steps, self.spacing)


def n_evaluations(steps: int, solver: str = "euler") -> int:
    """Network calls needed for ``steps`` intervals: ``steps`` (Euler) or ``2 · steps`` (midpoint)."""
    _check_solver(steps, solver)
    return _EVALS_PER_STEP[solver] * steps


def time_grid(steps: int, spacing: str = "uniform") -> Tensor:
    """``steps + 1`` time points from 0 to 1: ``t_k = k / steps`` (``"uniform"``) or ``1 − (1 − k/steps)²``
    (``"data_dense"``: intervals shrink linearly towards the data end, where the fine detail is decided)."""
    _check_steps(steps)
    _check_choice("spacing", spacing, GRIDS)
    s = torch.linspace(0.0, 1.0, steps + 1, dtype=torch.float64)
    return s if spacing == "uniform" else 1.0 - (1.0 - s) ** 2


def discord_default_solver() -> ODESolver:
    """The public DisCoRD setting: a 16-point grid with midpoint = 15 intervals = 30 evaluations."""
    return ODESolver(steps=DISCORD_GRID_POINTS - 1, solver=DISCORD_SOLVER)


def discord_default_grid() -> Tensor:
    """The 16 time points ``linspace(0, 1, 16)`` of the public DisCoRD sampler."""
    return discord_default_solver().grid


def euler_step(velocity_fn: VelocityFn, x: Tensor, t: float, dt: float, cond: Any = None) -> Tensor:
    """``x ← x + dt · v(x, t)``: exact when ``v`` is constant along the path."""
    return x + dt * velocity_fn(x, _full_time(x, t), cond)


def midpoint_step(velocity_fn: VelocityFn, x: Tensor, t: float, dt: float, cond: Any = None) -> Tensor:
    """Explicit midpoint (RK2): ``x_mid = x + dt/2 · v(x, t)``; ``x ← x + dt · v(x_mid, t + dt/2)``.

    Exact when ``v`` depends on ``t`` linearly (and not on ``x``): the midpoint rule integrates lines exactly.
    """
    x_mid = x + 0.5 * dt * velocity_fn(x, _full_time(x, t), cond)
    return x + dt * velocity_fn(x_mid, _full_time(x, t + 0.5 * dt), cond)


_STEPPERS = {"euler": euler_step, "midpoint": midpoint_step}


def _check_sample_inputs(x0: Tensor, steps: int, solver: str) -> None:
    """Reject a bad ``steps`` / ``solver`` and an ``x0`` that is not a ``(B, ...)`` tensor."""
    _check_solver(steps, solver)
    if not isinstance(x0, Tensor) or x0.dim() < 1:
        raise ValueError(f"x0 must be a tensor of shape (B, ...), got {_shape(x0)}")


def sample(
    velocity_fn: VelocityFn,
    x0: Tensor,
    steps: int,
    solver: str = "euler",
    cond: Any = None,
    *,
    spacing: str = "uniform",
    final_fn: Callable[[Tensor, Tensor, Any], Tensor] | None = None,
) -> Tensor:
    """Integrate ``dx/dt = v(x, t, cond)`` from ``x(0) = x0`` to ``t = 1`` over ``steps`` intervals of ``spacing``.

    Calls ``velocity_fn`` exactly :func:`n_evaluations` ``(steps, solver)`` times. ``x0`` is the starting noise
    (draw it with :func:`sample_noise` and a seeded generator); the function itself is deterministic.
    ``final_fn(x, t, cond)``, if given, replaces the last interval: it returns the data estimate from the last
    grid point before 1 in one call (an x-predicting network's own ``x̂1``).
    """
    _check_sample_inputs(x0, steps, solver)
    step = _STEPPERS[solver]
    grid = time_grid(steps, spacing).tolist()
    x = x0
    for k, (t0, t1) in enumerate(zip(grid[:-1], grid[1:])):
        if final_fn is not None and k == steps - 1:
            return final_fn(x, _full_time(x, t0), cond)
        x = step(velocity_fn, x, t0, t1 - t0, cond)
    return x


# ----------------------------------------------------------------------------- helpers


def _full_time(x: Tensor, t: float) -> Tensor:
    return torch.full((x.shape[0],), t, device=x.device, dtype=x.dtype)  # (B,)


def _check_steps(steps: int) -> None:
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"steps (number of integration intervals) must be a positive int, got {steps!r}")


def _check_choice(name: str, value: Any, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")


def _check_solver(steps: int, solver: str) -> None:
    _check_steps(steps)
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")


def _shape(x: Any) -> str:
    return str(tuple(x.shape)) if isinstance(x, Tensor) else type(x).__name__
