"""Noise schedules for mask-and-replace discrete diffusion (VQ-Diffusion, M2D2M §3).

The state space is K motion codes ``0..K-1`` plus one ``<MASK>`` state with index ``K``. One forward step
``x_{t-1} → x_t`` keeps a code with probability α_t (plus its share of β), replaces it by a code with total
probability K·β_t, and masks it with probability γ_t; the mask never leaves (absorbing)::

    α_t + K·β_t + γ_t = 1.

A schedule is given by its *cumulative* values ᾱ_t (the code survived all t steps) and γ̄_t (the code is
masked by step t), with ᾱ_0 = 1 and γ̄_0 = 0; the replaced mass is K·β̄_t = 1 − ᾱ_t − γ̄_t. The per-step
values follow from the Markov property (the non-mask mass 1 − γ̄ shrinks by (1 − γ_t) each step)::

    α_t = ᾱ_t / ᾱ_{t-1},    1 − γ_t = (1 − γ̄_t) / (1 − γ̄_{t-1}),    K·β_t = 1 − α_t − γ_t.

K·β_t ≥ 0 holds exactly when the ratio ᾱ_t / (1 − γ̄_t) never increases; :class:`Schedule` checks it.

Two named schedules (:func:`get_schedule`):

``"vqdiffusion_code"``
    The default of the public VQ-Diffusion code (``alpha_schedule``): ᾱ linear 0.99999 → 9e-6 and γ̄ linear
    9e-6 → 0.99999 over t = 1..T. Then ᾱ_t + γ̄_t = 0.999999 for every t, so K·β̄_t = 1e-6: the process is
    (almost) pure masking, and any shape given to β — such as M2D2M's distance-aware β(t, d) — does nothing.
``"vqdiffusion_paper"``
    The schedule the VQ-Diffusion *paper* describes: γ̄_t = 0.9·t/T and K·β̄_t = 0.1·t/T rise linearly
    from 0, so ᾱ_t = 1 − t/T falls linearly to 0. A tenth of the tokens are replaced by step T, so the
    replacement distribution matters. **The book uses this one** (:data:`DEFAULT_SCHEDULE`): M2D2M says it
    keeps VQ-Diffusion's linear ᾱ/γ̄ (appendix A.1), and its ablation shows β(t, d) changing results,
    which the code default could not do. Sampling starts from all-mask, the most likely x_T (probability
    0.9 per token here); the reverse steps are exact given that x_T.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

DEFAULT_T = 100
DEFAULT_SCHEDULE = "vqdiffusion_paper"


@dataclass(frozen=True)
class Schedule:
    """Cumulative mask-and-replace schedule over steps ``t = 0..T`` (float64 tensors of length T + 1).

    ``alpha_bar[0] = 1`` and ``gamma_bar[0] = 0`` (x_0 is the data). Everything else is derived.
    """

    name: str
    alpha_bar: torch.Tensor  # (T+1,) ᾱ_t
    gamma_bar: torch.Tensor  # (T+1,) γ̄_t

    def __post_init__(self) -> None:
        a, c = self.alpha_bar, self.gamma_bar
        if a.ndim != 1 or a.shape != c.shape or a.numel() < 2:
            raise ValueError(f"alpha_bar and gamma_bar must be 1-D of equal length T+1 >= 2, got {a.shape}, {c.shape}")
        if a[0] != 1.0 or c[0] != 0.0:
            raise ValueError("a schedule starts at alpha_bar[0] = 1 and gamma_bar[0] = 0")
        tol = 1e-12
        if (a < -tol).any() or (c < -tol).any() or (a + c > 1 + tol).any():
            raise ValueError("need alpha_bar, gamma_bar >= 0 and alpha_bar + gamma_bar <= 1")
        if (a[1:] > a[:-1] + tol).any() or (c[1:] < c[:-1] - tol).any():
            raise ValueError("alpha_bar must not increase and gamma_bar must not decrease")
        if (1.0 - self.alpha - self.gamma < -1e-9).any():
            raise ValueError("alpha_bar / (1 - gamma_bar) must not increase (otherwise K·beta_t < 0)")

    @property
    def T(self) -> int:
        return self.alpha_bar.numel() - 1

    @property
    def kbeta_bar(self) -> torch.Tensor:
        """(T+1,) K·β̄_t = 1 − ᾱ_t − γ̄_t: the probability that a code was replaced by step t."""
        return (1.0 - self.alpha_bar - self.gamma_bar).clamp_min(0.0)

    @property
    def alpha(self) -> torch.Tensor:
        """(T+1,) per-step α_t = ᾱ_t / ᾱ_{t-1} (index 0 unused, set to 1)."""
        prev, cur = self.alpha_bar[:-1], self.alpha_bar[1:]
        step = torch.where(prev > 0, cur / prev.clamp_min(1e-300), torch.zeros_like(cur))
        return torch.cat([torch.ones(1, dtype=step.dtype), step])

    @property
    def gamma(self) -> torch.Tensor:
        """(T+1,) per-step γ_t = 1 − (1 − γ̄_t) / (1 − γ̄_{t-1}) (index 0 unused, set to 0)."""
        prev, cur = 1.0 - self.gamma_bar[:-1], 1.0 - self.gamma_bar[1:]
        keep = torch.where(prev > 0, cur / prev.clamp_min(1e-300), torch.zeros_like(cur))
        return torch.cat([torch.zeros(1, dtype=keep.dtype), 1.0 - keep])

    @property
    def kbeta(self) -> torch.Tensor:
        """(T+1,) per-step K·β_t = 1 − α_t − γ_t, the total replacement probability of one step."""
        return (1.0 - self.alpha - self.gamma).clamp_min(0.0)


def linear_schedule(
    T: int, alpha_bar: tuple[float, float], gamma_bar: tuple[float, float], name: str = "linear"
) -> Schedule:
    """ᾱ_t and γ̄_t linear in t from their values at t = 1 to their values at t = T (ᾱ_0 = 1, γ̄_0 = 0)."""
    if not isinstance(T, int) or T < 1:
        raise ValueError(f"T must be a positive int, got {T!r}")
    frac = torch.arange(T, dtype=torch.float64) / max(T - 1, 1)  # 0 at t = 1, 1 at t = T
    a = alpha_bar[0] + frac * (alpha_bar[1] - alpha_bar[0])
    c = gamma_bar[0] + frac * (gamma_bar[1] - gamma_bar[0])
    one, zero = torch.ones(1, dtype=torch.float64), torch.zeros(1, dtype=torch.float64)
    return Schedule(name, torch.cat([one, a]), torch.cat([zero, c]))


def vqdiffusion_code_schedule(T: int = DEFAULT_T) -> Schedule:
    """The public VQ-Diffusion default: nearly pure masking (K·β̄_t = 1e-6 for every t)."""
    return linear_schedule(T, (0.99999, 0.000009), (0.000009, 0.99999), name="vqdiffusion_code")


def _check_vqdiffusion_paper_schedule_inputs(T: int, gamma_bar_T: float, kbeta_bar_T: float) -> None:
    """Reject negative end values, end values summing past 1, and a non-positive ``T``."""
    if gamma_bar_T < 0 or kbeta_bar_T < 0 or gamma_bar_T + kbeta_bar_T > 1:
        raise ValueError(f"need gamma_bar_T, kbeta_bar_T >= 0 with sum <= 1, got {gamma_bar_T}, {kbeta_bar_T}")
    if not isinstance(T, int) or T < 1:
        raise ValueError(f"T must be a positive int, got {T!r}")


def vqdiffusion_paper_schedule(T: int = DEFAULT_T, gamma_bar_T: float = 0.9, kbeta_bar_T: float = 0.1) -> Schedule:
    """The VQ-Diffusion paper's schedule: γ̄_t and K·β̄_t rise linearly from 0 to their values at T."""
    _check_vqdiffusion_paper_schedule_inputs(T, gamma_bar_T, kbeta_bar_T)
    u = torch.arange(1, T + 1, dtype=torch.float64) / T
    return linear_schedule(
        T,
        (1.0 - u[0].item() * (gamma_bar_T + kbeta_bar_T), 1.0 - gamma_bar_T - kbeta_bar_T),
        (u[0].item() * gamma_bar_T, gamma_bar_T),
        name="vqdiffusion_paper",
    )


SCHEDULES: dict[str, Callable[[int], Schedule]] = {
    "vqdiffusion_code": vqdiffusion_code_schedule,
    "vqdiffusion_paper": vqdiffusion_paper_schedule,
}


def get_schedule(name: str = DEFAULT_SCHEDULE, T: int = DEFAULT_T) -> Schedule:
    """A named schedule (see the module docstring) with ``T`` steps."""
    if name not in SCHEDULES:
        raise ValueError(f"unknown schedule {name!r}; expected one of {', '.join(SCHEDULES)}")
    return SCHEDULES[name](T)
