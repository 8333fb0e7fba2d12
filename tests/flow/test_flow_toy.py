"""The 2-D toy of Chapter 03: distributions, the MLP velocity field, trajectories and the two measurements."""

from __future__ import annotations

import math

import pytest
import torch

from motionlab.flow import sample, sample_noise
from motionlab.flow.toy import (
    TOY_DISTRIBUTIONS,
    ToyFlowConfig,
    build_toy_flow,
    energy_by_budget,
    energy_distance,
    flow_trajectory,
    sample_at_budget,
    sample_toy,
    straightness,
    toy_flow_config,
    train_or_load_toy_flow,
    train_toy_flow,
)
from motionlab.studies.toy_flow import energy_table


def gen(seed: int = 0) -> torch.Generator:
    return torch.Generator().manual_seed(seed)


# ----------------------------------------------------------------------------- distributions


@pytest.mark.parametrize("name", sorted(TOY_DISTRIBUTIONS))
def test_toy_samples_are_seeded_and_labelled(name):
    x, y = sample_toy(name, 500, gen(3))
    x2, y2 = sample_toy(name, 500, gen(3))
    assert x.shape == (500, 2) and y.shape == (500,) and y.dtype == torch.long
    assert torch.equal(x, x2) and torch.equal(y, y2)
    assert set(y.tolist()) == set(range(TOY_DISTRIBUTIONS[name]))
    assert not torch.equal(x, sample_toy(name, 500, gen(4))[0])


def test_ring_points_sit_near_their_own_centre():
    x, y = sample_toy("ring", 2000, gen(0))
    assert abs(x.norm(dim=1).mean().item() - 2.0) < 0.05
    angle = 2 * math.pi * y.float() / 8
    centres = 2.0 * torch.stack([torch.cos(angle), torch.sin(angle)], dim=1)
    assert (x - centres).norm(dim=1).max() < 1.0  # std 0.15: every point within ~6 std of its own Gaussian


def test_moons_are_two_separate_clusters():
    x, y = sample_toy("moons", 2000, gen(0))
    mean0, mean1 = x[y == 0].mean(0), x[y == 1].mean(0)
    assert (mean0 - mean1).norm() > 1.0
    assert x.mean(0).norm() < 0.3  # roughly centred


def test_toy_rejects_bad_arguments():
    with pytest.raises(ValueError, match="name"):
        sample_toy("spiral", 10, gen())
    with pytest.raises(ValueError, match="n must"):
        sample_toy("ring", 0, gen())
    with pytest.raises(ValueError, match="distribution"):
        ToyFlowConfig(distribution="spiral")
    with pytest.raises(ValueError, match="hidden"):
        ToyFlowConfig(hidden=0)
    with pytest.raises(ValueError, match="unknown"):
        toy_flow_config("smoke", width=3)


def test_profiles_only_change_the_budget():
    smoke, laptop = toy_flow_config("smoke"), toy_flow_config("laptop")
    assert smoke.steps < laptop.steps < toy_flow_config("full").steps
    assert smoke.hidden == laptop.hidden and toy_flow_config("smoke", conditional=True).conditional


# ----------------------------------------------------------------------------- the velocity field


def test_mlp_shapes_and_conditioning():
    model = build_toy_flow(ToyFlowConfig(conditional=True, hidden=16))
    x, t = torch.randn(5, 2, generator=gen(0)), torch.rand(5, generator=gen(1))
    a = model(x, t, torch.zeros(5, dtype=torch.long))
    b = model(x, t, torch.full((5,), 3))
    assert a.shape == (5, 2) and not torch.allclose(a, b)
    with pytest.raises(ValueError, match="conditional"):
        model(x, t)
    # weights are a function of the config alone
    again = build_toy_flow(ToyFlowConfig(conditional=True, hidden=16))
    torch.testing.assert_close(again(x, t, torch.zeros(5, dtype=torch.long)), a)


def test_training_lowers_the_loss_and_conditioning_finds_the_cluster():
    cfg = ToyFlowConfig(conditional=True, hidden=32, depth=2, steps=200, batch_size=128, lr=5e-3, warmup_steps=10)
    model = build_toy_flow(cfg)
    history = train_toy_flow(model, progress=False)
    losses = [row["loss"] for row in history]
    assert losses[-1] < 0.5 * losses[0]
    labels = torch.arange(8).repeat(50)  # (400,)
    with torch.no_grad():
        x = sample(model, sample_noise((400, 2), gen(5)), steps=4, solver="euler", cond=labels)
    angle = 2 * math.pi * labels.float() / 8
    centres = 2.0 * torch.stack([torch.cos(angle), torch.sin(angle)], dim=1)
    assert ((x - centres).norm(dim=1) < 0.75).float().mean() > 0.8  # samples land in their own Gaussian


def test_train_or_load_caches_the_model(isolated_cache, monkeypatch):
    import motionlab.flow.toy as toy

    trainings = []
    train = toy.train_toy_flow
    monkeypatch.setattr(toy, "train_toy_flow", lambda *a, **k: trainings.append(1) or train(*a, **k))
    cfg = ToyFlowConfig(hidden=8, depth=1, steps=20, batch_size=32, warmup_steps=0)
    first = train_or_load_toy_flow(cfg, profile="smoke", progress=False)
    second = train_or_load_toy_flow(cfg, profile="smoke", progress=False)
    assert trainings == [1]  # the second call loaded
    for p, q in zip(first.parameters(), second.parameters()):
        assert torch.equal(p, q)
    assert any(isolated_cache.rglob("model.safetensors"))


# ----------------------------------------------------------------------------- trajectories


@pytest.mark.parametrize("solver", ["euler", "midpoint"])
def test_trajectory_ends_where_sample_ends(solver):
    model = build_toy_flow(ToyFlowConfig(hidden=16))
    x0 = sample_noise((7, 2), gen(2))
    path = flow_trajectory(model, x0, 5, solver)
    assert path.shape == (6, 7, 2)
    torch.testing.assert_close(path[0], x0)
    with torch.no_grad():
        torch.testing.assert_close(path[-1], sample(model, x0, 5, solver))


def test_trajectory_rejects_bad_arguments():
    with pytest.raises(ValueError, match="solver"):
        flow_trajectory(lambda x, t, c: x, torch.zeros(2, 2), 3, "rk4")
    with pytest.raises(ValueError, match="steps"):
        flow_trajectory(lambda x, t, c: x, torch.zeros(2, 2), 0)


def test_straightness_of_known_paths():
    s = torch.linspace(0, 1, 11)[:, None, None]  # (11, 1, 1)
    line = s * torch.tensor([[3.0, -4.0]])  # (11, 1, 2)
    angle = torch.linspace(0, math.pi, 401)
    half_circle = torch.stack([torch.cos(angle), torch.sin(angle)], dim=-1)[:, None]  # (401, 1, 2)
    still = torch.ones(4, 1, 2)
    back_and_forth = torch.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]])[:, None]
    values = straightness(torch.cat([line[::4], half_circle[::200], still[:3], back_and_forth], dim=1))
    assert values.shape == (4,)
    torch.testing.assert_close(straightness(line), torch.ones(1))
    assert abs(straightness(half_circle).item() - 2 / math.pi) < 1e-4
    assert straightness(still).item() == 1.0 and values[3].item() == 0.0
    with pytest.raises(ValueError, match="path"):
        straightness(torch.zeros(1, 3, 2))


# ----------------------------------------------------------------------------- energy distance


def test_energy_distance_known_values():
    a = torch.randn(50, 3, generator=gen(0))
    assert abs(energy_distance(a, a).item()) < 1e-12
    assert energy_distance(torch.zeros(1, 1), torch.ones(1, 1)).item() == pytest.approx(2.0)
    b = torch.randn(60, 3, generator=gen(1))
    assert energy_distance(a, b).item() == pytest.approx(energy_distance(b, a).item())


def test_energy_distance_grows_with_the_mismatch():
    a = torch.randn(400, 2, generator=gen(0))
    b = torch.randn(400, 2, generator=gen(1))
    near, far = energy_distance(a, b + 0.5), energy_distance(a, b + 2.0)
    floor = energy_distance(a, b)
    assert 0 <= floor < near < far
    with pytest.raises(ValueError, match="same dimension"):
        energy_distance(a, torch.zeros(3, 3))
    with pytest.raises(ValueError, match="b must"):
        energy_distance(a, torch.zeros(3))


# ----------------------------------------------------------------------------- budgets and the energy grid


def test_sample_at_budget_spends_exactly_the_budget():
    model = build_toy_flow(ToyFlowConfig(hidden=16))
    x0 = sample_noise((5, 2), gen(3))
    calls = []

    def counting(x, t, cond):
        calls.append(1)
        return model(x, t, cond)

    for nfe, solver, steps in [(1, "euler", 1), (4, "euler", 4), (2, "midpoint", 1), (8, "midpoint", 4)]:
        calls.clear()
        x = sample_at_budget(counting, x0, nfe, solver)
        assert len(calls) == nfe
        with torch.no_grad():
            torch.testing.assert_close(x, sample(model, x0, steps, solver))
    assert sample_at_budget(model, x0, 1, "midpoint") is None and sample_at_budget(model, x0, 5, "midpoint") is None
    with pytest.raises(ValueError, match="nfe"):
        sample_at_budget(model, x0, 0)
    with pytest.raises(ValueError, match="solver"):
        sample_at_budget(model, x0, 2, "rk4")


def test_energy_by_budget_measures_every_field_solver_and_possible_budget():
    uncond = build_toy_flow(ToyFlowConfig(hidden=16))
    cond = build_toy_flow(ToyFlowConfig(hidden=16, conditional=True))
    x0 = sample_noise((40, 2), gen(4))
    ids = torch.randint(0, 8, (40,), generator=gen(5))
    reference, _ = sample_toy("ring", 40, gen(6))
    fields = {"u": (uncond, None), "c": (cond, ids)}
    quality = energy_by_budget(fields, x0, reference, [1, 2, 4])
    assert sorted(quality) == sorted(
        [(n, "euler", k) for n in "uc" for k in (1, 2, 4)] + [(n, "midpoint", k) for n in "uc" for k in (2, 4)]
    )
    x = sample_at_budget(cond, x0, 4, "midpoint", ids)
    assert quality["c", "midpoint", 4] == pytest.approx(energy_distance(x, reference).item())
    assert energy_by_budget({"u": (uncond, None)}, x0, reference, [3], solvers=["midpoint"]) == {}
    with pytest.raises(ValueError, match="at least one"):
        energy_by_budget({}, x0, reference, [1])


def test_energy_table_has_a_row_per_budget_and_a_column_per_field_and_solver():
    quality = {("u", "euler", 1): 1.0, ("u", "euler", 2): 0.5, ("u", "midpoint", 2): 0.25, ("c", "euler", 1): 0.125}
    table = energy_table(quality, floor=0.01, points=500)
    assert table.labels == [1, 2] and table.columns == ("u, Euler", "u, midpoint", "c, Euler")
    assert table.cell(1, "u, midpoint") is None and table.cell(2, "u, midpoint") == 0.25
    lines = table.to_markdown().splitlines()
    assert lines[:4] == [
        "| NFE | u, Euler | u, midpoint | c, Euler |",
        "|---|---:|---:|---:|",
        "| 1 | 1.0000 | – | 0.1250 |",
        "| 2 | 0.5000 | 0.2500 | – |",
    ]
    assert lines[-1] == "noise floor (two samples of the data, 500 points each): 0.0100"
    assert not energy_table(quality).notes
    with pytest.raises(ValueError, match="empty"):
        energy_table({})
