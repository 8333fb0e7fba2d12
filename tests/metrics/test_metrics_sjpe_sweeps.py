"""Chapter 06's measurements: the noise and smoothing sweeps, their table, and Eq. 10 on real and concatenated clips."""

from __future__ import annotations

import numpy as np
import pytest

from motionlab.data.embedded.writer import build_clip, plan_families
from motionlab.estimate import Estimate
from motionlab.metrics import sjpe_from_features, transition_log_jerk
from motionlab.metrics.jerk import real_motion_log_jerk
from motionlab.metrics.perturbations import add_frame_noise
from motionlab.representation import Normalizer, recover_from_ric
from motionlab.studies.sjpe_sensitivity import MeasurementTable, noise_sweep, smoothing_sweep


@pytest.fixture(scope="module")
def clips():
    """Eight procedural clips (raw 263-d features) of 59 to 196 frames."""
    specs = plan_families(21, seed=0)
    return [build_clip(0, i, specs[i])[0] for i in range(8)]


@pytest.fixture(scope="module")
def normalizer(clips):
    stacked = np.concatenate(clips)
    return Normalizer(stacked.mean(0), stacked.std(0) + 1e-3)


def embed(features):
    """A fixed 4-d embedding: FID's algebra needs no trained evaluator."""
    return np.stack([np.concatenate([f.mean(0)[:2], f.std(0)[:2]]) for f in features])


def test_the_noise_sweep_scores_each_draw_as_the_evaluation_does(clips, normalizer):
    sigmas = [0.0, 0.001, 0.002, 0.01]
    table = noise_sweep(clips, sigmas, normalizer, embed, repeats=1, seed=3)
    assert table.levels == sigmas and table.columns == ("disp_mm", "noise", "static", "fid")
    clean = table.rows[0.0]
    assert clean["noise"].mean == 0 and clean["static"].mean == 0 and clean["disp_mm"].mean == 0
    assert abs(clean["fid"].mean) < 1e-6
    for i, sigma in enumerate(sigmas):  # draw 0 of level i is default_rng([seed, i, 0]), scored from the features
        noisy = add_frame_noise(clips, sigma, normalizer, np.random.default_rng([3, i, 0]))
        direct = sjpe_from_features(noisy, clips)
        assert table.estimate(sigma, "noise").mean == pytest.approx(direct.noise, abs=1e-9)
        assert table.estimate(sigma, "static").mean == pytest.approx(direct.static, abs=1e-9)
    noise = [e.mean for e in table.column("noise")]
    assert all(b > a for a, b in zip(noise, noise[1:]))
    # small noise moves the joints in proportion to σ
    shift = [table.estimate(s, "disp_mm").mean for s in (0.001, 0.002, 0.01)]
    assert shift[1] / shift[0] == pytest.approx(2, rel=0.1) and shift[2] / shift[0] == pytest.approx(10, rel=0.1)


def test_the_noise_sweep_intervals_are_over_the_draws(clips, normalizer):
    table = noise_sweep(clips[:4], [0.005], normalizer, embed, repeats=3, seed=0)
    cell = table.estimate(0.005, "noise")
    assert cell.n == 3 and cell.half_width > 0
    assert table.estimate(0.005, "fid").n == 3
    again = noise_sweep(clips[:4], [0.005], normalizer, embed, repeats=3, seed=0)
    assert again.rows == table.rows  # seeded: the same draws
    with pytest.raises(ValueError, match="repeats"):
        noise_sweep(clips, [0.01], normalizer, embed, repeats=0)
    with pytest.raises(ValueError, match="sigmas"):
        noise_sweep(clips, [], normalizer, embed, repeats=1)


def test_the_smoothing_sweep_raises_static_sjpe_and_is_over_clips(clips):
    table = smoothing_sweep(clips, [0.0, 1.0, 4.0], embed)
    assert table.columns == ("noise", "static", "fid")
    assert table.estimate(0.0, "static").mean == 0 and table.estimate(0.0, "noise").mean == 0
    static = [e.mean for e in table.column("static")]
    assert static[0] < static[1] < static[2]
    assert table.estimate(4.0, "static").n == len(clips)  # deterministic: the spread is across clips
    assert table.estimate(4.0, "fid").n == 1 and table.estimate(4.0, "fid").half_width == 0


def test_the_measurement_table_prints_each_estimate_with_its_own_digits():
    table = MeasurementTable(
        "σ (normalised)",
        {
            0.001: {"noise": Estimate(0.1234, 0.0123, 3), "fid": Estimate(2.4e-5, 1.1e-6, 3)},
            0.1: {"noise": Estimate(2.3)},
        },
        notes=("a note",),
    )
    lines = table.to_markdown().splitlines()
    assert lines[0] == "| σ (normalised) | Noise sJPE | FID |"
    assert lines[2] == "| 0.001 | 0.123 ± 0.012 | 0.0000240 ± 0.0000011 |"
    assert lines[3] == "| 0.1 | 2.30 | – |"  # a value without interval; a missing cell
    assert lines[-1] == "a note" and table._repr_markdown_() == table.to_markdown()
    with pytest.raises(KeyError, match="rows"):
        table.estimate(0.5, "noise")
    with pytest.raises(KeyError, match="has no 'fid'"):
        table.estimate(0.1, "fid")
    with pytest.raises(ValueError, match="empty"):
        MeasurementTable("x", {})


def test_the_measurement_table_trend_uses_the_one_rule():
    rising = MeasurementTable(
        "σ", {s: {"noise": Estimate(v, 0.01, 3)} for s, v in [(0.0, 0.1), (0.1, 0.5), (1.0, 0.9)]}
    )
    trend = rising.trend("noise", name="σ = ")
    assert trend.rising and trend.established
    assert str(trend).startswith("Noise sJPE: σ = 0 0.100 ± 0.010, σ = 0.1 0.500 ± 0.010")
    noisy = MeasurementTable("σ", {s: {"noise": Estimate(v, 0.3, 3)} for s, v in [(0.0, 0.1), (0.1, 0.2)]})
    assert noisy.trend("noise").rising and not noisy.trend("noise").established


def test_real_motion_jerk_is_eq10_inside_each_clip_and_on_seams(clips):
    single, concatenated = real_motion_log_jerk(clips, partners=1, seed=0)
    joints = [recover_from_ric(f, 22) for f in clips]
    expected = [transition_log_jerk(j, [len(j) // 2], window=40)[0] for j in joints]
    np.testing.assert_allclose(single, expected)
    partner = np.random.default_rng([0, 300, 0]).permutation(len(clips))
    pairs = [(a, b) for a, b in enumerate(partner) if a != b]  # a clip never pairs with itself
    assert len(concatenated) == len(pairs)
    a, b = pairs[0]
    joined = recover_from_ric(np.concatenate([clips[a], clips[b]]), 22)
    assert concatenated[0] == pytest.approx(transition_log_jerk(joined, [len(clips[a])], window=40)[0])
    # more partners add pairings after the first ones
    _, more = real_motion_log_jerk(clips, partners=2, seed=0)
    np.testing.assert_array_equal(more[: len(concatenated)], concatenated)
    assert len(more) > len(concatenated)


def test_real_motion_jerk_checks_its_inputs(clips):
    with pytest.raises(ValueError, match="partners"):
        real_motion_log_jerk(clips, partners=0)
    with pytest.raises(ValueError, match="at least 2"):
        real_motion_log_jerk(clips[:1])
