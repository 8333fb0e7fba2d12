"""Rectified-flow objective and fixed-grid samplers (no networks beyond a tiny MLP)."""

from __future__ import annotations

import math

import pytest
import torch
from torch import nn

from motionlab.flow.rectified_flow import (
    ODESolver,
    discord_default_grid,
    discord_default_solver,
    flow_matching_loss,
    interpolate,
    n_evaluations,
    sample,
    sample_noise,
    target_velocity,
    time_grid,
)


def gen(seed: int = 0) -> torch.Generator:
    return torch.Generator().manual_seed(seed)


# ----------------------------------------------------------------------------- objective


def test_interpolation_endpoints_and_target():
    x0, x1 = torch.randn(3, 5, generator=gen(1)), torch.randn(3, 5, generator=gen(2))
    torch.testing.assert_close(interpolate(x0, x1, torch.zeros(3)), x0)  # noise at t = 0
    torch.testing.assert_close(interpolate(x0, x1, torch.ones(3)), x1)  # data at t = 1
    t = torch.tensor([0.25, 0.5, 0.75])
    torch.testing.assert_close(interpolate(x0, x1, t), x0 + t[:, None] * (x1 - x0))
    torch.testing.assert_close(target_velocity(x0, x1), x1 - x0)


def test_loss_is_zero_for_the_exact_field_of_a_point_mass():
    # Data = one point c: then x1 − x0 = (c − x_t) / (1 − t) is known from (x_t, t) and the loss vanishes.
    c = torch.tensor([[1.5, -2.0, 0.5]], dtype=torch.float64).expand(64, 3)

    def exact(x_t, t, cond):
        return (c - x_t) / (1 - t)[:, None]

    assert flow_matching_loss(exact, c, None, gen(0)).item() < 1e-18
    assert flow_matching_loss(lambda x, t, cond: torch.zeros_like(x), c, None, gen(0)).item() > 1.0


def test_loss_is_seeded_and_passes_cond_through():
    x1 = torch.randn(16, 4, generator=gen(3))
    seen = {}

    def field(x_t, t, cond):
        seen["cond"] = cond
        return x_t * cond

    a = flow_matching_loss(field, x1, 2.0, gen(7))
    b = flow_matching_loss(field, x1, 2.0, gen(7))
    c = flow_matching_loss(field, x1, 2.0, gen(8))
    assert seen["cond"] == 2.0
    assert a.item() == b.item() and a.item() != c.item()


def test_loss_rejects_bad_inputs():
    with pytest.raises(ValueError, match="generator"):
        flow_matching_loss(lambda x, t, c: x, torch.zeros(2, 3), None, None)
    with pytest.raises(ValueError, match="x1"):
        flow_matching_loss(lambda x, t, c: x, torch.zeros(3), None, gen())


class TinyField(nn.Module):
    def __init__(self, width: int = 64) -> None:
        super().__init__()
        self.net = nn.Sequential(
            nn.Linear(3, width), nn.SiLU(), nn.Linear(width, width), nn.SiLU(), nn.Linear(width, 2)
        )

    def forward(self, x, t, cond=None):
        return self.net(torch.cat([x, t[:, None]], dim=-1))


def test_flow_on_2d_toy_learns_a_gaussian_mixture():
    torch.manual_seed(0)  # parameter init only; all sampling goes through explicit generators
    means = torch.tensor([[-3.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    g = gen(0)
    field = TinyField()
    opt = torch.optim.Adam(field.parameters(), lr=3e-3)
    losses = []
    for _ in range(500):
        k = torch.randint(0, 3, (256,), generator=g)
        x1 = means[k] + 0.2 * torch.randn(256, 2, generator=g)
        loss = flow_matching_loss(field, x1, None, g)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(loss.item())
    assert sum(losses[-50:]) / 50 < 0.7 * sum(losses[:20]) / 20  # measured ≈ 0.56

    with torch.no_grad():
        x = sample(field, sample_noise((600, 2), gen(1)), steps=20, solver="midpoint")
    dist = torch.cdist(x, means)  # (600, 3)
    nearest = dist.argmin(dim=1)
    assert (dist.min(dim=1).values < 1.0).float().mean() > 0.85  # samples land near a mean
    counts = torch.bincount(nearest, minlength=3).float() / 600
    assert counts.min() > 0.15  # every mode is populated


# ----------------------------------------------------------------------------- samplers


@pytest.mark.parametrize("solver", ["euler", "midpoint"])
@pytest.mark.parametrize("steps", [1, 3, 7])
def test_constant_velocity_is_integrated_exactly(solver, steps):
    x0 = torch.randn(4, 3, generator=gen(0), dtype=torch.float64)
    v = torch.tensor([1.0, -2.0, 0.5], dtype=torch.float64)
    x1 = sample(lambda x, t, c: v.expand_as(x), x0, steps, solver)
    torch.testing.assert_close(x1, x0 + v)


@pytest.mark.parametrize("steps", [1, 2, 5])
def test_midpoint_is_exact_for_velocity_linear_in_t_and_euler_is_not(steps):
    a, b = 0.7, 3.0  # v(t) = a + b·t integrates to a + b/2 over [0, 1]
    x0 = torch.zeros(2, 1, dtype=torch.float64)

    def field(x, t, c):
        return (a + b * t)[:, None].expand_as(x)

    torch.testing.assert_close(sample(field, x0, steps, "midpoint"), x0 + a + b / 2)
    # Left-endpoint Euler sums a + b·k/n over k < n: it misses exactly b / (2n).
    torch.testing.assert_close(sample(field, x0, steps, "euler"), x0 + a + b / 2 - b / (2 * steps))


@pytest.mark.parametrize("steps", [1, 4, 10])
def test_step_formulas_on_exponential_growth(steps):
    # dx/dt = x: Euler multiplies by (1 + h) per step, midpoint by (1 + h + h²/2).
    x0 = torch.ones(1, 1, dtype=torch.float64)
    h = 1.0 / steps
    euler = sample(lambda x, t, c: x, x0, steps, "euler").item()
    midpoint = sample(lambda x, t, c: x, x0, steps, "midpoint").item()
    assert euler == pytest.approx((1 + h) ** steps, rel=1e-12)
    assert midpoint == pytest.approx((1 + h + h * h / 2) ** steps, rel=1e-12)
    assert abs(midpoint - math.e) < abs(euler - math.e)


@pytest.mark.parametrize("solver,steps", [("euler", 1), ("euler", 8), ("midpoint", 1), ("midpoint", 15)])
def test_number_of_network_evaluations(solver, steps):
    calls = []

    def field(x, t, c):
        calls.append(t[0].item())
        return torch.zeros_like(x)

    sample(field, torch.zeros(2, 2), steps, solver)
    assert len(calls) == n_evaluations(steps, solver) == steps * (2 if solver == "midpoint" else 1)
    assert min(calls) == 0.0 and max(calls) < 1.0  # the field is never asked at t = 1


def test_discord_default_is_16_points_15_midpoint_intervals_30_evaluations():
    spec = discord_default_solver()
    assert (spec.steps, spec.solver, spec.n_evaluations) == (15, "midpoint", 30)
    grid = discord_default_grid()
    assert grid.shape == (16,) and grid[0] == 0 and grid[-1] == 1
    torch.testing.assert_close(grid, torch.linspace(0, 1, 16, dtype=torch.float64))
    torch.testing.assert_close(time_grid(4), torch.tensor([0, 0.25, 0.5, 0.75, 1], dtype=torch.float64))


def test_sampler_rejects_bad_settings():
    for bad in (0, -1, 2.0, True):
        with pytest.raises(ValueError, match="steps"):
            n_evaluations(bad, "euler")
    with pytest.raises(ValueError, match="solver"):
        sample(lambda x, t, c: x, torch.zeros(1, 1), 2, "rk4")
    with pytest.raises(ValueError, match="solver"):
        ODESolver(2, "heun")
    with pytest.raises(ValueError, match="x0"):
        sample(lambda x, t, c: x, [0.0], 2, "euler")


# ----------------------------------------------------------------------------- parameterisations


def test_x_prediction_implies_the_target_velocity_on_exact_data():
    from motionlab.flow.rectified_flow import X_PREDICTION_MIN_GAP, velocity_from_data

    x0 = torch.randn(64, 7, generator=gen(1), dtype=torch.float64)
    x1 = torch.randn(64, 7, generator=gen(2), dtype=torch.float64)
    t = torch.linspace(0.0, 1.0 - X_PREDICTION_MIN_GAP, 64, dtype=torch.float64)
    x_t = interpolate(x0, x1, t)
    torch.testing.assert_close(velocity_from_data(x1, x_t, t), target_velocity(x0, x1), rtol=1e-12, atol=1e-12)
    # an x-predictor that returns the data itself (passed in as cond) has zero loss where 1 − t is unclamped
    exact = flow_matching_loss(
        lambda x, tt, c: c,
        x1,
        x1,
        gen(0),
        prediction="x",
        time_distribution="logit_normal",
        time_loc=-3.0,
        time_scale=0.3,
    )  # t < 0.2
    assert exact.item() < 1e-20
    assert flow_matching_loss(lambda x, tt, c: c, x1, x1, gen(0), prediction="v").item() > 0.1


@pytest.mark.parametrize("prediction", ["v", "x"])
@pytest.mark.parametrize("solver", ["euler", "midpoint"])
@pytest.mark.parametrize("steps", [1, 2, 5, 9])
def test_both_parameterisations_integrate_a_known_field_exactly(prediction, solver, steps):
    from motionlab.flow.rectified_flow import as_velocity_fn

    # v(x, t) = a + b·t does not depend on x: Euler is exact for b = 0, midpoint for any b.
    a = torch.tensor([[0.5, -1.0, 2.0]], dtype=torch.float64)
    b = torch.tensor([[1.0, 0.25, -0.5]], dtype=torch.float64) * (solver == "midpoint")

    def field(x, t):
        return a + b * t[:, None]

    def network(x, t, cond):  # a perfect network of this parameterisation for that field
        if prediction == "v":
            return field(x, t)
        return x + (1 - t[:, None]) * field(x, t)  # x̂1 = E[x1 | x_t]: the field is (x̂1 − x) / (1 − t)

    x0 = torch.randn(4, 3, generator=gen(5), dtype=torch.float64)
    out = sample(as_velocity_fn(network, prediction), x0, steps, solver)
    torch.testing.assert_close(out, x0 + a + 0.5 * b, rtol=1e-12, atol=1e-12)


def test_logit_normal_times_lean_towards_loc_and_stay_inside_the_unit_interval():
    from motionlab.flow.rectified_flow import sample_time

    late = sample_time(20_000, gen(0), distribution="logit_normal", loc=1.0)
    assert 0.0 < late.min() and late.max() < 1.0 and 0.68 < late.median() < 0.76  # sigmoid(1) = 0.731
    torch.testing.assert_close(sample_time(8, gen(3)), torch.rand(8, generator=gen(3)))  # uniform unchanged
    with pytest.raises(ValueError, match="distribution"):
        sample_time(4, gen(0), distribution="beta")
    with pytest.raises(ValueError, match="scale"):
        sample_time(4, gen(0), distribution="logit_normal", scale=0.0)


def test_data_dense_grid_shrinks_towards_the_data_end():
    grid = time_grid(6, "data_dense")
    assert grid[0] == 0.0 and grid[-1] == 1.0 and len(grid) == 7
    gaps = grid.diff()
    assert bool((gaps[1:] < gaps[:-1]).all())
    assert ODESolver(6, "euler", "data_dense").grid.tolist() == grid.tolist()
    with pytest.raises(ValueError, match="spacing"):
        time_grid(4, "cosine")


def test_final_fn_replaces_the_last_interval():
    calls = []

    def velocity(x, t, cond):
        calls.append(float(t[0]))
        return torch.ones_like(x)

    out = sample(velocity, torch.zeros(2, 3), 4, "euler", final_fn=lambda x, t, c: x + 100.0)
    assert calls == [0.0, 0.25, 0.5] and torch.equal(out, torch.full((2, 3), 100.75))
