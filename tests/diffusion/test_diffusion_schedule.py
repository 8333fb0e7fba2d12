"""Schedules: per-step / cumulative consistency, the two named schedules, validation."""

from __future__ import annotations

import pytest
import torch

from motionlab.diffusion import Schedule, get_schedule, linear_schedule, vqdiffusion_paper_schedule


@pytest.mark.parametrize("name", ["vqdiffusion_code", "vqdiffusion_paper"])
def test_per_step_values_rebuild_the_cumulative_ones(name):
    s = get_schedule(name, T=100)
    assert s.T == 100
    a, c, kb = s.alpha[1:], s.gamma[1:], s.kbeta[1:]
    assert (a >= 0).all() and (c >= 0).all() and (kb >= 0).all()
    torch.testing.assert_close(a + c + kb, torch.ones(100, dtype=torch.float64))
    torch.testing.assert_close(torch.cumprod(a, 0), s.alpha_bar[1:], atol=1e-12, rtol=0)
    torch.testing.assert_close(torch.cumprod(1 - c, 0), 1 - s.gamma_bar[1:], atol=1e-12, rtol=0)


def test_vqdiffusion_code_default_is_nearly_pure_masking():
    """The documented problem: ᾱ_t + γ̄_t = 0.999999, so K·β̄_t = 1e-6 at every step."""
    s = get_schedule("vqdiffusion_code", T=100)
    torch.testing.assert_close(s.kbeta_bar[1:], torch.full((100,), 1e-6, dtype=torch.float64), atol=1e-12, rtol=0)
    assert s.kbeta[1:].max() < 1e-4
    assert s.alpha_bar[1].item() == pytest.approx(0.99999) and s.gamma_bar[-1].item() == pytest.approx(0.99999)


def test_vqdiffusion_paper_schedule_replaces_a_tenth():
    s = get_schedule("vqdiffusion_paper", T=100)
    t = torch.arange(101, dtype=torch.float64)
    torch.testing.assert_close(s.gamma_bar, 0.9 * t / 100)
    torch.testing.assert_close(s.kbeta_bar, 0.1 * t / 100)
    torch.testing.assert_close(s.alpha_bar, 1 - t / 100)
    assert s.kbeta_bar[50] > 1e4 * get_schedule("vqdiffusion_code").kbeta_bar[50]


def test_bad_schedules_raise():
    with pytest.raises(ValueError, match="unknown schedule"):
        get_schedule("cosine")
    with pytest.raises(ValueError, match="T must be"):
        get_schedule(T=0)
    with pytest.raises(ValueError, match="sum <= 1"):
        vqdiffusion_paper_schedule(10, gamma_bar_T=0.8, kbeta_bar_T=0.3)
    with pytest.raises(ValueError, match="starts at"):
        Schedule("x", torch.tensor([0.9, 0.5], dtype=torch.float64), torch.tensor([0.0, 0.1], dtype=torch.float64))
    with pytest.raises(ValueError, match="must not increase"):  # replaced mass would have to shrink: K·β_t < 0
        linear_schedule(2, (0.5, 0.45), (0.1, 0.5))
    with pytest.raises(ValueError, match="must not increase and gamma_bar"):
        linear_schedule(3, (0.5, 0.6), (0.1, 0.2))
