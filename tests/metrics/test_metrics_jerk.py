"""Jerk, M2D2M's Eq. 10 (log_jerk), transition windows and the standard LDLJ."""

from pathlib import Path

import numpy as np
import pytest
import torch

from motionlab.metrics import (
    boundaries_from_lengths,
    dimensionless_jerk,
    finite_difference_jerk,
    ldlj_from_log_jerk,
    log_dimensionless_jerk,
    log_jerk,
    log_jerk_batch,
    transition_log_jerk,
    transition_windows,
)

REPO = Path(__file__).resolve().parents[2]
SAMPLE_DIRS = [Path("/work/shared/data/humanml3d-sample"), REPO.parent / "shared" / "data" / "humanml3d-sample"]


def smooth_joints(rng: np.random.Generator, frames: int, joints: int = 22) -> np.ndarray:
    """Random smooth trajectories: cumulative sums of low-passed noise."""
    steps = rng.normal(size=(frames, joints, 3))
    kernel = np.ones(5) / 5
    steps = np.apply_along_axis(lambda s: np.convolve(s, kernel, mode="same"), 0, steps)
    return np.cumsum(steps, axis=0) * 0.01


# --- finite_difference_jerk ------------------------------------------------------------------------------


def test_jerk_of_a_cubic_is_its_third_derivative():
    fps, c = 20.0, 0.7
    t = np.arange(10) / fps
    pos = np.zeros((10, 2, 3))
    pos[:, 1, 0] = c * t**3  # x = c t^3  ->  x''' = 6c
    jerk = finite_difference_jerk(pos, fps)
    assert jerk.shape == (7, 2, 3)
    np.testing.assert_allclose(jerk[:, 1, 0], 6 * c, rtol=1e-9)
    np.testing.assert_allclose(jerk[:, 0], 0.0)


def test_jerk_is_the_plain_third_difference_and_keeps_torch():
    rng = np.random.default_rng(0)
    pos = rng.normal(size=(3, 12, 4, 3))
    expected = (pos[:, 3:] - 3 * pos[:, 2:-1] + 3 * pos[:, 1:-2] - pos[:, :-3]) * 12.5**3
    np.testing.assert_allclose(finite_difference_jerk(pos, 12.5), expected, rtol=1e-12)
    out = finite_difference_jerk(torch.from_numpy(pos), 12.5)
    assert isinstance(out, torch.Tensor)
    np.testing.assert_allclose(out.numpy(), expected, rtol=1e-12)


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.zeros((3, 2, 3)), "at least 4 frames"),
        (np.full((5, 2, 3), np.nan), "NaN"),
        (torch.zeros(2, 1, 3), "4 frames"),
    ],
)
def test_jerk_rejects_bad_input(bad, match):
    with pytest.raises(ValueError, match=match):
        finite_difference_jerk(bad, 20)


# --- Eq. 10 -------------------------------------------------------------------------------------------------


def test_log_jerk_hand_computed():
    # x = n^3: velocities 1, 7, 19, 37 (peak 37); third differences 6, 6 -> integral 72 (frames, dt = 1)
    w = np.zeros((5, 1, 3))
    w[:, 0, 0] = np.arange(5) ** 3
    assert log_jerk(w) == pytest.approx(np.log(72 / 37**2), abs=1e-12)


def test_log_jerk_averages_joints_and_skips_still_ones():
    w = np.zeros((6, 3, 3))
    w[:, 0, 0] = np.arange(6) ** 3
    w[:, 1, 1] = np.arange(6) ** 2 + np.arange(6) ** 3 * 0.5
    single = [log_jerk(w[:, [j]]) for j in (0, 1)]
    # joint 2 never moves: it is left out of the mean instead of producing ln(0/0)
    assert log_jerk(w) == pytest.approx(np.mean(single), abs=1e-12)
    with pytest.raises(ValueError, match="static"):
        log_jerk(np.ones((8, 2, 3)))


@pytest.mark.parametrize("fps", [20.0, 12.5])
def test_log_jerk_seconds_exceed_frames_by_3_ln_fps(fps):
    w = smooth_joints(np.random.default_rng(1), 40)
    frames = log_jerk(w, "frames", fps)
    seconds = log_jerk(w, "seconds", fps)
    assert seconds - frames == pytest.approx(3 * np.log(fps), abs=1e-10)


def test_log_jerk_is_invariant_to_spatial_scale():
    w = smooth_joints(np.random.default_rng(2), 40)
    assert log_jerk(w * 1000) == pytest.approx(log_jerk(w), abs=1e-10)


def test_log_jerk_rejects_bad_input():
    with pytest.raises(ValueError, match="time_unit"):
        log_jerk(np.zeros((10, 2, 3)), time_unit="ms")
    with pytest.raises(ValueError, match="at least 4 frames"):
        log_jerk(np.zeros((3, 2, 3)))
    with pytest.raises(ValueError, match=r"\(T, J, 3\)"):
        log_jerk(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="NaN"):
        log_jerk(np.full((10, 2, 3), np.inf))


def test_log_jerk_batch_matches_single_windows():
    rng = np.random.default_rng(3)
    windows = np.stack([smooth_joints(rng, 40, 5) for _ in range(4)])
    windows[2] = 0.0  # a frozen window -> NaN, not an exception
    batch = log_jerk_batch(windows)
    assert np.isnan(batch[2])
    for i in (0, 1, 3):
        assert batch[i] == pytest.approx(log_jerk(windows[i]), abs=1e-12)


# --- transition windows -----------------------------------------------------------------------------------


def test_transition_windows_are_centred_and_shifted_at_edges():
    assert transition_windows(200, [100], 40) == [(80, 120)]  # 20 frames before the boundary, 20 from it
    assert transition_windows(200, [5], 40) == [(0, 40)]  # shifted right, still 40 frames
    assert transition_windows(200, [195], 40) == [(160, 200)]  # shifted left
    assert transition_windows(30, [10], 40) == [(0, 30)]  # shorter than the window: the whole sequence
    assert boundaries_from_lengths([60, 50, 70]) == [60, 110]


@pytest.mark.parametrize("boundary", [0, 200, -3])
def test_transition_windows_reject_boundaries_outside(boundary):
    with pytest.raises(ValueError, match="strictly inside"):
        transition_windows(200, [boundary])


def test_transition_log_jerk_uses_those_windows():
    joints = smooth_joints(np.random.default_rng(4), 150)
    bounds = boundaries_from_lengths([50, 60, 40])
    values = transition_log_jerk(joints, bounds, window=40)
    expected = [log_jerk(joints[a:b]) for a, b in transition_windows(150, bounds, 40)]
    np.testing.assert_allclose(values, expected, rtol=1e-12)


# --- LDLJ -----------------------------------------------------------------------------------------------------


def bell_speed():
    t = np.arange(-1, 1, 0.01)
    return np.exp(-5 * t**2)


def test_ldlj_canonical_values():
    assert dimensionless_jerk(bell_speed(), 100) == pytest.approx(-335.74684, abs=1e-5)
    assert log_dimensionless_jerk(bell_speed(), 100) == pytest.approx(-5.81636, abs=1e-5)


def test_ldlj_rejects_bad_input():
    with pytest.raises(ValueError, match="identically zero"):
        dimensionless_jerk(np.zeros(20), 100)
    with pytest.raises(ValueError, match="1-D"):
        dimensionless_jerk(np.ones((5, 2)), 100)


@pytest.mark.parametrize("time_unit", ["frames", "seconds"])
def test_eq10_relates_to_ldlj_by_duration_and_sign(time_unit):
    # A point moving along +x with the canonical bell speed: its 3-D jerk equals the speed's 2nd difference.
    fs, speed = 100.0, bell_speed()
    x = np.concatenate(([0.0], np.cumsum(speed) / fs))  # N + 1 positions -> N velocities = speed
    window = np.zeros((x.size, 1, 3))
    window[:, 0, 0] = x
    eq10 = log_jerk(window, time_unit, fps=fs)
    ldlj = ldlj_from_log_jerk(eq10, window.shape[0], time_unit, fps=fs)
    assert ldlj == pytest.approx(log_dimensionless_jerk(speed, fs), abs=1e-9)
    assert ldlj == pytest.approx(-5.81636, abs=1e-5)


def test_ldlj_from_log_jerk_is_unit_free():
    w = smooth_joints(np.random.default_rng(5), 40)
    a = ldlj_from_log_jerk(log_jerk(w, "frames", 20), 40, "frames", 20)
    b = ldlj_from_log_jerk(log_jerk(w, "seconds", 20), 40, "seconds", 20)
    assert a == pytest.approx(b, abs=1e-10)


# --- the real HumanML3D clip ------------------------------------------------------------------------------


def sample_dir() -> Path:
    for d in SAMPLE_DIRS:
        if (d / "new_joints" / "012314.npy").is_file():
            return d
    pytest.skip("HumanML3D sample clip not available")


def test_real_clip_windows_match_the_measured_values():
    joints = np.load(sample_dir() / "new_joints" / "012314.npy").astype(np.float64)  # (170, 22, 3), metres
    values = {s: log_jerk(joints[s : s + 40]) for s in (0, 40, 80, 120)}  # frames, mean over 22 joints
    # The notes list the four values in sorted order: -0.79, 0.13, 0.34, 1.33.
    assert values == pytest.approx({0: 0.1306, 40: 0.3419, 80: -0.7901, 120: 1.3263}, abs=5e-4)
    for s, v in values.items():
        assert log_jerk(joints[s : s + 40], "seconds") - v == pytest.approx(3 * np.log(20), abs=1e-9)


def test_real_clip_from_features_agrees_with_stored_joints():
    from motionlab.representation import recover_from_ric

    d = sample_dir()
    feats = np.load(d / "new_joint_vecs" / "012314.npy").astype(np.float64)
    joints = np.asarray(recover_from_ric(feats, 22))
    stored = np.load(d / "new_joints" / "012314.npy").astype(np.float64)
    for s in (0, 40, 80, 120):
        assert log_jerk(joints[s : s + 40]) == pytest.approx(log_jerk(stored[s : s + 40]), abs=1e-3)
