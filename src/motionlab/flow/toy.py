"""Rectified flow on 2-D toy data: where the ODE view can be *seen* (Chapter 03).

Everything here is small on purpose: the toy distributions, a tiny MLP velocity field ``v(x, t[, class])``,
its training through the shared :class:`~motionlab.train.Trainer` with the library's
:func:`~motionlab.flow.flow_matching_loss`, and two measurements used to judge a sampler:

- :func:`straightness`: chord length over path length of a sampled trajectory (1 = a straight line);
- :func:`energy_distance`: a distance between two point clouds that is zero iff their distributions agree.

The samplers themselves are the library's (:func:`~motionlab.flow.sample`); :func:`flow_trajectory` runs the
very same steppers but keeps every intermediate state, so a trajectory can be drawn, and :func:`sample_at_budget`
calls ``sample`` with a given number of network evaluations. :func:`energy_by_budget` measures a grid of fields ×
solvers × budgets, which :func:`energy_table` renders.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import torch
from torch import Tensor, nn

from motionlab.flow.rectified_flow import (
    SOLVERS,
    VelocityFn,
    euler_step,
    flow_matching_loss,
    midpoint_step,
    n_evaluations,
    sample,
    time_grid,
)
from motionlab.sizes import TOY_FLOW, resized
from motionlab.train import TrainConfig, Trainer, seeded, train_or_load

# ----------------------------------------------------------------------------- toy distributions

TOY_DISTRIBUTIONS = {"ring": 8, "moons": 2}  # name -> number of clusters (the class labels of a conditional toy)


def sample_toy(name: str, n: int, generator: torch.Generator) -> tuple[Tensor, Tensor]:
    """``n`` points of a 2-D toy distribution and their cluster ids: ``(n, 2)`` float, ``(n,)`` long.

    - ``"ring"``: 8 Gaussians (std 0.15) evenly spaced on a circle of radius 2; the id is the Gaussian.
    - ``"moons"``: two interleaved half circles (radius 1, noise 0.08), centred; the id is the moon.
    """
    if name not in TOY_DISTRIBUTIONS:
        raise ValueError(f"name must be one of {sorted(TOY_DISTRIBUTIONS)}, got {name!r}")
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be a positive int, got {n!r}")
    k = TOY_DISTRIBUTIONS[name]
    labels = torch.randint(0, k, (n,), generator=generator)  # (n,)
    if name == "ring":
        angle = 2 * math.pi * labels.float() / k
        centres = 2.0 * torch.stack([torch.cos(angle), torch.sin(angle)], dim=1)  # (n, 2)
        return centres + 0.15 * torch.randn(n, 2, generator=generator), labels
    # moons: the upper arc for id 0, the lower arc (shifted right and down) for id 1
    angle = math.pi * torch.rand(n, generator=generator)
    upper = torch.stack([torch.cos(angle), torch.sin(angle)], dim=1)  # (n, 2)
    lower = torch.stack([1.0 - torch.cos(angle), 0.5 - torch.sin(angle)], dim=1)
    points = torch.where(labels[:, None] == 0, upper, lower) - torch.tensor([0.5, 0.25])
    return 1.5 * points + 0.08 * torch.randn(n, 2, generator=generator), labels


# ----------------------------------------------------------------------------- the velocity field


@dataclass(frozen=True)
class ToyFlowConfig:
    """A tiny MLP velocity field and its training budget."""

    distribution: str = "ring"
    conditional: bool = False  # True: v(x, t, class id), the toy version of "decode tokens into motion"
    hidden: int = 128
    depth: int = 3  # hidden layers
    time_freqs: int = 8  # sin/cos features of t at frequencies 1, 2, 4, ... (times π)
    steps: int = 20_000  # the full profile's; smaller ones in motionlab.sizes.TOY_FLOW
    batch_size: int = 512
    lr: float = 2e-3
    warmup_steps: int = 100
    seed: int = 0  # weight initialisation and the trainer's data/noise streams

    def __post_init__(self) -> None:
        if self.distribution not in TOY_DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {sorted(TOY_DISTRIBUTIONS)}, got {self.distribution!r}")
        for name in ("hidden", "depth", "time_freqs", "steps", "batch_size"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive int, got {value!r}")

    @property
    def n_classes(self) -> int:
        return TOY_DISTRIBUTIONS[self.distribution]

    def train_config(self) -> TrainConfig:
        return TrainConfig(
            steps=self.steps,
            lr=self.lr,
            schedule="cosine",
            warmup_steps=self.warmup_steps,
            min_lr_ratio=0.05,
            seed=self.seed,
            log_every=max(1, self.steps // 50),
        )


def toy_flow_config(profile: str | None = None, **overrides: Any) -> ToyFlowConfig:
    """The toy config of a profile: only the number of training steps changes (300 / 5000 / 20000)."""
    config = resized(ToyFlowConfig(), TOY_FLOW, profile)
    unknown = set(overrides) - set(ToyFlowConfig.__dataclass_fields__)
    if unknown:
        raise ValueError(f"unknown ToyFlowConfig fields: {sorted(unknown)}")
    return replace(config, **overrides)


class ToyVelocityMLP(nn.Module):
    """``v(x, t[, y])``: an MLP on ``[x, sin/cos(π 2^k t), embedding(y)]``; ``(B, 2), (B,), (B,) -> (B, 2)``."""

    def __init__(self, config: ToyFlowConfig) -> None:
        super().__init__()
        self.config = config
        self.register_buffer("freqs", math.pi * 2.0 ** torch.arange(config.time_freqs), persistent=False)
        self.label = nn.Embedding(config.n_classes, config.hidden) if config.conditional else None
        width_in = 2 + 2 * config.time_freqs + (config.hidden if config.conditional else 0)
        layers: list[nn.Module] = []
        for i in range(config.depth):
            layers += [nn.Linear(width_in if i == 0 else config.hidden, config.hidden), nn.SiLU()]
        self.net = nn.Sequential(*layers, nn.Linear(config.hidden, 2))

    def forward(self, x: Tensor, t: Tensor, cond: Tensor | None = None) -> Tensor:
        angles = t.to(x.dtype)[:, None] * self.freqs.to(x.dtype)  # (B, F)
        parts = [x, torch.sin(angles), torch.cos(angles)]
        if self.label is not None:
            if cond is None:
                raise ValueError("this velocity field is conditional: pass cond = class ids of shape (B,)")
            parts.append(self.label(cond))  # (B, hidden)
        return self.net(torch.cat(parts, dim=-1))  # (B, 2)


def build_toy_flow(config: ToyFlowConfig) -> ToyVelocityMLP:
    """The velocity field of ``config``, with weights that depend on ``config.seed`` alone."""
    with seeded(config.seed):
        return ToyVelocityMLP(config)


# ----------------------------------------------------------------------------- training


def toy_flow_loss_fn(model: ToyVelocityMLP, batch: tuple[Tensor, Tensor], generator: torch.Generator) -> dict:
    """The trainer's ``loss_fn``: the rectified-flow loss, conditioned on cluster ids if the model is."""
    points, labels = batch
    cond = labels if model.config.conditional else None
    return {"loss": flow_matching_loss(model, points, cond, generator)}


def train_toy_flow(
    model: ToyVelocityMLP, workdir: str | Path | None = None, progress: bool = True
) -> list[dict[str, float]]:
    """Train ``model`` on fresh toy samples every step (the data is infinite); returns the logged history.

    Always on the CPU, whatever devices the machine has: the network is a 2 × 64 MLP whose step a GPU would only
    slow down with launches and copies, and the trained field stays where the chapter's samples are drawn.
    """
    cfg = model.config

    def batch_fn(step: int, generator: torch.Generator) -> tuple[Tensor, Tensor]:
        return sample_toy(cfg.distribution, cfg.batch_size, generator)

    trainer = Trainer(
        model,
        toy_flow_loss_fn,
        batch_fn,
        cfg.train_config(),
        workdir=workdir,
        device="cpu",
        desc=f"toy flow ({cfg.distribution})",
        progress=progress,
    )
    with _one_torch_thread():
        history = trainer.fit()
    model.eval()
    return history


@contextmanager
def _one_torch_thread() -> Iterator[None]:
    """A 2 × 64 MLP step is microseconds of arithmetic: extra intra-op threads only add hand-offs, and on a
    busy machine their spinning makes training ~10× slower. Run on one thread, then restore the setting."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def train_or_load_toy_flow(config: ToyFlowConfig, profile: str | None = None, progress: bool = True) -> nn.Module:
    """The cached toy velocity field for ``config`` (trained on first use, in seconds)."""

    def train_fn(model: ToyVelocityMLP, workdir: Path) -> list[dict[str, float]]:
        return train_toy_flow(model, workdir, progress=progress)

    return train_or_load("toy_flow", config, build_toy_flow, train_fn, profile, device="cpu")


# ----------------------------------------------------------------------------- trajectories and measurements

_STEPPERS = {"euler": euler_step, "midpoint": midpoint_step}


@torch.no_grad()
def flow_trajectory(velocity_fn: VelocityFn, x0: Tensor, steps: int, solver: str = "euler", cond: Any = None) -> Tensor:
    """The states of :func:`~motionlab.flow.sample` at every grid point: ``(steps + 1, B, ...)``.

    Same grid and steppers as ``sample``, so ``flow_trajectory(...)[-1]`` equals ``sample(...)``.
    """
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    if not isinstance(x0, Tensor) or x0.dim() < 1:
        raise ValueError(f"x0 must be a tensor of shape (B, ...), got {type(x0).__name__}")
    grid = time_grid(steps).tolist()  # validates steps
    states = [x0]
    for t0, t1 in zip(grid[:-1], grid[1:]):
        states.append(_STEPPERS[solver](velocity_fn, states[-1], t0, t1 - t0, cond))
    return torch.stack(states)  # (K + 1, B, ...)


def straightness(path: Tensor) -> Tensor:
    """Per-sample chord / arc length ``|x_K − x_0| / Σ_k |x_{k+1} − x_k|`` of paths ``(K + 1, B, ...)``: ``(B,)``.

    1 for a straight path traversed in one direction, 2/π for a half circle, → 0 for a loop. A path
    that does not move counts as straight (1).
    """
    if not isinstance(path, Tensor) or path.dim() < 2 or path.shape[0] < 2:
        raise ValueError(f"path must have shape (K + 1, B, ...) with K >= 1, got {tuple(getattr(path, 'shape', ()))}")
    flat = path.reshape(path.shape[0], path.shape[1], -1)  # (K + 1, B, D)
    arc = (flat[1:] - flat[:-1]).norm(dim=-1).sum(dim=0)  # (B,)
    chord = (flat[-1] - flat[0]).norm(dim=-1)  # (B,)
    return torch.where(arc > 0, chord / arc.clamp_min(torch.finfo(flat.dtype).tiny), torch.ones_like(arc))


def _check_energy_distance_inputs(a: Tensor, b: Tensor) -> None:
    """Reject point clouds that are not ``(N, D)`` tensors of one dimension ``D``."""
    for name, x in (("a", a), ("b", b)):
        if not isinstance(x, Tensor) or x.dim() != 2 or x.shape[0] < 1:
            raise ValueError(f"{name} must be a tensor of shape (N, D), got {tuple(getattr(x, 'shape', ()))}")
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"a and b must have the same dimension D, got {a.shape[1]} and {b.shape[1]}")


def energy_distance(a: Tensor, b: Tensor) -> Tensor:
    """Energy distance between point clouds ``a (N, D)`` and ``b (M, D)`` (V-statistic, ≥ 0)::

        E(a, b) = 2 · mean ‖a_i − b_j‖ − mean ‖a_i − a_k‖ − mean ‖b_j − b_l‖

    Zero in the population limit iff the two distributions are equal (Székely & Rizzo); two finite
    samples of one distribution give a small positive value of order 1/N (compare against that floor).
    """
    _check_energy_distance_inputs(a, b)
    a, b = a.double(), b.double()  # many small differences of large means: keep precision
    return 2 * torch.cdist(a, b).mean() - torch.cdist(a, a).mean() - torch.cdist(b, b).mean()


@torch.no_grad()
def sample_at_budget(
    velocity_fn: VelocityFn, x0: Tensor, nfe: int, solver: str = "euler", cond: Any = None
) -> Tensor | None:
    """:func:`~motionlab.flow.sample` from ``x0`` with exactly ``nfe`` network evaluations, or ``None`` where
    ``solver`` cannot spend that many (midpoint takes two per step: no odd budget)."""
    if isinstance(nfe, bool) or not isinstance(nfe, int) or nfe < 1:
        raise ValueError(f"nfe must be a positive int, got {nfe!r}")
    per_step = n_evaluations(1, solver)  # validates the solver
    if nfe % per_step:
        return None
    return sample(velocity_fn, x0, nfe // per_step, solver, cond)


def energy_by_budget(
    fields: Mapping[str, tuple[VelocityFn, Any]],
    x0: Tensor,
    reference: Tensor,
    nfes: Sequence[int],
    solvers: Sequence[str] = SOLVERS,
) -> dict[tuple[str, str, int], float]:
    """``{(field, solver, nfe): energy distance}`` of the samples each field (``name -> (velocity_fn, cond)``) draws
    from the same start ``x0`` with each solver at each budget, to the sample ``reference`` of the data. Budgets a
    solver cannot spend (:func:`sample_at_budget`) are left out."""
    if not fields or not nfes:
        raise ValueError("need at least one field and one budget")
    quality = {}
    for name, (velocity_fn, cond) in fields.items():
        for solver in solvers:
            for nfe in nfes:
                x = sample_at_budget(velocity_fn, x0, nfe, solver, cond)
                if x is not None:
                    quality[name, solver, nfe] = energy_distance(x, reference).item()
    return quality


__all__ = [
    "TOY_DISTRIBUTIONS",
    "ToyFlowConfig",
    "ToyVelocityMLP",
    "build_toy_flow",
    "energy_by_budget",
    "energy_distance",
    "flow_trajectory",
    "sample_at_budget",
    "sample_toy",
    "straightness",
    "toy_flow_config",
    "toy_flow_loss_fn",
    "train_or_load_toy_flow",
    "train_toy_flow",
]
