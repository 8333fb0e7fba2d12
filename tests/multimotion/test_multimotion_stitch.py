"""Stitching decoded segments: the root trajectory continues across boundaries; the SLERP/linear blend."""

from __future__ import annotations

import numpy as np
import pytest

from motionlab.data.embedded import generate_clip
from motionlab.multimotion import (
    blend_segments,
    blend_weights,
    concatenate_segments,
    shortened_lengths,
    split_segments,
    transition_rows,
)
from motionlab.representation import cont6d_to_quat, feature_slices, joints_to_features, recover_from_ric

SL = feature_slices("t2m")


@pytest.fixture(scope="module")
def clips() -> list[np.ndarray]:
    """Three procedural clips as features: walk, turn (changes the heading), walk."""
    out = []
    for family, seed in (("walk", 0), ("turn", 1), ("walk", 2)):
        joints = generate_clip(family, np.random.default_rng(seed)).joints
        out.append(joints_to_features(joints, "t2m", retarget_to_target=False).astype(np.float32))
    return out


def rigid_fit_xz(source: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """Best rotation about Y + translation taking source (…, 3) onto target in x/z: (angle, max residual)."""
    s, t = source[..., [0, 2]].reshape(-1, 2), target[..., [0, 2]].reshape(-1, 2)
    s0, t0 = s - s.mean(0), t - t.mean(0)
    angle = np.arctan2((s0[:, 0] * t0[:, 1] - s0[:, 1] * t0[:, 0]).sum(), (s0 * t0).sum())
    c, si = np.cos(angle), np.sin(angle)
    rotated = s0 @ np.array([[c, si], [-si, c]])
    return float(angle), float(np.abs(rotated - t0).max())


def test_concatenated_segments_continue_the_root_trajectory(clips):
    features, boundaries = concatenate_segments(clips)
    assert features.shape == (sum(len(c) for c in clips), 263)
    assert boundaries == [len(clips[0]), len(clips[0]) + len(clips[1])]
    joints = recover_from_ric(features)  # (T, 22, 3)
    starts = [0, *boundaries]
    angles = []
    for clip, start in zip(clips, starts, strict=True):
        alone = recover_from_ric(clip)
        piece = joints[start : start + len(clip)]
        np.testing.assert_allclose(piece[..., 1], alone[..., 1], atol=1e-5)  # heights untouched
        angle, residual = rigid_fit_xz(alone, piece)
        assert residual < 1e-3  # each segment is its own motion, rigidly moved about Y
        angles.append(angle)
    assert abs(angles[2] - angles[1]) > 0.3  # the turn really changed the heading of what follows
    root = joints[:, 0, [0, 2]]
    steps = np.linalg.norm(np.diff(root, axis=0), axis=1)
    for b in boundaries:  # no jump: the step into a new segment is an ordinary step
        assert steps[b - 1] <= 2.0 * steps[b - 6 : b + 5].max() + 1e-3 and steps[b - 1] < 0.1
    naive = np.concatenate([recover_from_ric(c) for c in clips])  # every segment restarting at the origin
    assert np.linalg.norm(naive[boundaries[0], 0, [0, 2]] - naive[boundaries[0] - 1, 0, [0, 2]]) > 1.0


def test_split_segments_inverts_concatenation(clips):
    features, boundaries = concatenate_segments(clips)
    for a, b in zip(split_segments(features, boundaries), clips, strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="boundaries"):
        split_segments(features, [0])
    with pytest.raises(ValueError, match="boundaries"):
        split_segments(features, [50, 20])
    with pytest.raises(ValueError, match="non-empty"):
        concatenate_segments([])
    with pytest.raises(ValueError, match="D=263"):
        concatenate_segments([clips[0], clips[1][:, :100]])


def test_transition_rows_interpolate_each_group(clips):
    a, b = clips[0][-1], clips[1][0]
    W = 9
    rows = transition_rows(a, b, W)
    s = blend_weights(W)
    assert rows.shape == (W, 263) and s[0] == pytest.approx(0.1) and s[-1] == pytest.approx(0.9)
    for group in ("root_rot_vel", "root_lin_vel", "root_height", "ric", "local_vel"):
        expected = (1 - s[:, None]) * a[SL[group]] + s[:, None] * b[SL[group]]
        np.testing.assert_allclose(rows[:, SL[group]], expected, atol=1e-6)
    q = cont6d_to_quat(rows[:, SL["rot"]].reshape(W, 21, 6))
    qa, qb = (cont6d_to_quat(x[SL["rot"]].reshape(21, 6)) for x in (a, b))
    mid = q[W // 2]  # s = 1/2: the rotation halfway along the great arc
    half = qa + np.where((qa * qb).sum(-1, keepdims=True) < 0, -qb, qb)
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    np.testing.assert_allclose(np.abs((mid * half).sum(-1)), 1.0, atol=1e-5)
    contact = rows[:, SL["foot_contact"]]
    np.testing.assert_array_equal(contact[: W // 2], np.tile(a[SL["foot_contact"]], (W // 2, 1)))
    np.testing.assert_array_equal(contact[W // 2 :], np.tile(b[SL["foot_contact"]], (W - W // 2, 1)))
    np.testing.assert_allclose(transition_rows(a, a, 4), np.tile(a, (4, 1)), atol=1e-5)  # nothing to blend


def test_blend_segments_keeps_segments_and_lengths(clips):
    parts = [clips[0][:140], clips[1][:8], clips[2][:120]]
    assert [len(p) for p in parts] == [140, 8, 120]
    features, boundaries = blend_segments(parts, window=40)
    assert len(features) == 140 + 40 + 8 + 40 + 120
    assert boundaries == [140 + 20, 140 + 40 + 8 + 20]  # the middle of each blend
    np.testing.assert_array_equal(features[:140], parts[0])  # segment rows untouched
    np.testing.assert_array_equal(features[180:188], parts[1])
    np.testing.assert_array_equal(features[-120:], parts[2])
    np.testing.assert_allclose(features[140:180], transition_rows(parts[0][-1], parts[1][0], 40))
    np.testing.assert_allclose(features[188:228], transition_rows(parts[1][-1], parts[2][0], 40))
    single, none = blend_segments(parts[:1], window=40)
    assert none == [] and np.array_equal(single, parts[0])
    with pytest.raises(ValueError, match="even"):
        blend_segments(parts, window=7)


def test_slerp_lengths_round_trip_to_the_requested_layout(clips):
    target = [100, 80, 120]
    gen_lengths = shortened_lengths(target, 40)
    assert gen_lengths == [80, 40, 100]
    parts = [c[:n] for c, n in zip(clips, gen_lengths, strict=True)]
    features, boundaries = blend_segments(parts, window=40)
    assert len(features) == sum(target) and boundaries == [100, 180]
