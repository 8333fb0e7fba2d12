"""ClipJoints: a clip set's joints recovered once, and the metrics that run on it without a loop over clips."""

import re

import numpy as np
import pytest

from motionlab.metrics import (
    ClipJoints,
    clip_log_jerk,
    ldlj_from_log_jerk,
    mpjpe,
    sjpe_dataset,
    sjpe_variants,
    transition_log_jerk,
)
from motionlab.representation import recover_from_ric


def smooth_features(rng: np.random.Generator, frames: int) -> np.ndarray:
    """Raw t2m features whose recovered joints move smoothly: integrated noise in every used column."""
    return np.cumsum(rng.normal(scale=0.02, size=(frames, 263)), axis=0)


@pytest.fixture(scope="module")
def pair():
    rng = np.random.default_rng(0)
    gt = [smooth_features(rng, n) for n in (4, 40, 41, 77, 196)]
    pred = [g + rng.normal(scale=0.003, size=g.shape) for g in gt]
    return pred, gt


def test_from_features_packs_each_clips_recovered_joints(pair):
    _, gt = pair
    joints = ClipJoints.from_features(gt)
    assert len(joints) == 5 and joints.n_joints == 22 and joints.skeleton == "t2m"
    assert joints.starts.tolist() == [0, 4, 44, 85, 162]
    for i, clip in enumerate(joints.clips()):
        np.testing.assert_allclose(clip, recover_from_ric(gt[i]), rtol=0, atol=1e-12)
        assert clip.base is joints.positions or clip.base is joints.positions.base  # a view, not a copy
    np.testing.assert_array_equal(joints.clip(3), joints.clips()[3])
    window = joints.windows([0, 1, 2, 3, 4], 4)  # (5, 4, 22, 3)
    np.testing.assert_array_equal(window[2], joints.clip(2)[2:6])
    with pytest.raises(ValueError, match="inside its clip"):
        joints.windows([0, 1, 2, 3, 193], 4)


def test_from_joints_reads_real_frames_only():
    rng = np.random.default_rng(1)
    clips = [rng.normal(size=(n, 22, 3)) for n in (6, 9)]
    padded = np.full((2, 12, 22, 3), np.inf)
    padded[0, :6], padded[1, :9] = clips
    packed = ClipJoints.from_joints(padded, [6, 9])
    np.testing.assert_array_equal(packed.positions, np.concatenate(clips))
    np.testing.assert_array_equal(ClipJoints.from_joints(clips).positions, packed.positions)
    with pytest.raises(ValueError, match="clip 1"):
        ClipJoints.from_joints(padded, [6, 10])
    with pytest.raises(ValueError, match="lengths must"):
        ClipJoints(packed.positions, np.array([6, 8]))


def test_metrics_on_clip_joints_equal_the_clip_lists(pair):
    pred, gt = pair
    p, g = ClipJoints.from_features(pred), ClipJoints.from_features(gt)
    lists = sjpe_variants(p.clips(), g.clips())
    for variant, result in sjpe_variants(p, g).items():
        np.testing.assert_array_equal(result.noise_per_clip, lists[variant].noise_per_clip)
        np.testing.assert_array_equal(result.static_per_clip, lists[variant].static_per_clip)
    assert mpjpe(p.positions, g.positions) == pytest.approx(mpjpe(p.clips(), g.clips()), rel=1e-12)
    with pytest.raises(ValueError, match="lengths is not used"):
        sjpe_dataset(p, g, lengths=[4, 40, 41, 77, 196])
    with pytest.raises(ValueError, match="clips"):
        sjpe_variants(p, ClipJoints.from_features(gt[:4]))


def test_clip_log_jerk_equals_transition_log_jerk_clip_by_clip(pair):
    pred, _ = pair
    joints = ClipJoints.from_features(pred)
    values = clip_log_jerk(joints, window=40)  # clips of 4 and 40 frames: the whole clip; longer: shifted inside
    expected = [transition_log_jerk(c, [len(c) // 2], window=40)[0] for c in joints.clips()]
    np.testing.assert_allclose(values, expected, rtol=1e-13)
    bounds = [1, 5, 40, 70, 190]
    np.testing.assert_allclose(
        clip_log_jerk(joints, bounds, window=10, time_unit="seconds"),
        [transition_log_jerk(c, [b], window=10, time_unit="seconds")[0] for c, b in zip(joints.clips(), bounds)],
        rtol=1e-13,
    )
    ldlj = ldlj_from_log_jerk(values, np.minimum(joints.lengths, 40))
    assert ldlj.shape == (5,)
    assert ldlj[3] == pytest.approx(ldlj_from_log_jerk(float(values[3]), 40))
    with pytest.raises(ValueError, match="strictly inside"):
        clip_log_jerk(joints, [0, 5, 40, 70, 190])


def test_clip_log_jerk_of_a_frozen_clip_is_nan():
    cubic = np.arange(8.0)[:, None, None] ** 3 * np.ones((1, 22, 3))  # constant, non-zero jerk
    still = ClipJoints.from_joints([np.zeros((8, 22, 3)), cubic])
    values = clip_log_jerk(still, window=6)
    assert np.isnan(values[0]) and np.isfinite(values[1])


def test_sjpe_scored_block_by_block_equals_one_pass(pair, monkeypatch):
    import importlib

    sjpe_module = importlib.import_module("motionlab.metrics.sjpe")  # the package exports a function of that name

    p, g = ClipJoints.from_features(pair[0]), ClipJoints.from_features(pair[1])
    whole = sjpe_variants(p, g)
    monkeypatch.setattr(sjpe_module, "_BLOCK_FRAMES", 50)  # blocks of 1-2 clips (4+40, 41, 77, 196 frames)
    assert sjpe_module._blocks(p.lengths) == [(0, 2), (2, 3), (3, 4), (4, 5)]
    for variant, result in sjpe_variants(p, g).items():
        for field in ("noise_per_clip", "static_per_clip", "jerk_pred_per_clip", "jerk_gt_per_clip"):
            np.testing.assert_array_equal(getattr(result, field), getattr(whole[variant], field))


def _walk(metres: float, frames: int = 40) -> np.ndarray:
    """A 22-joint rig whose root moves ``metres`` along x (and bobs up and down, which is not travel)."""
    t = np.linspace(0.0, 1.0, frames)
    clip = np.zeros((frames, 22, 3))
    clip[:, :, 0] = metres * t[:, None]
    clip[:, :, 1] = 0.9 + 0.05 * np.sin(12 * t)[:, None]
    return clip


def test_root_travel_is_the_net_distance_on_the_ground():
    joints = ClipJoints.from_joints([_walk(3.0), _walk(0.0), _walk(-1.5, 10)])
    np.testing.assert_allclose(joints.root_travel(), [3.0, 0.0, 1.5], atol=1e-12)


def test_a_reconstruction_that_loses_a_walks_travel_is_named():
    from motionlab.evaluation.reconstruction import lost_travel

    truth = ClipJoints.from_joints([_walk(3.27), _walk(0.2), _walk(2.0)])
    decoded = ClipJoints.from_joints([_walk(0.12), _walk(0.0), _walk(1.9)])  # the first walk decoded on the spot
    lost, note = lost_travel(truth, decoded)
    assert lost == [0]  # the 0.2 m shuffle is not travel to lose
    assert re.search(r"1 of 3 clips lose most of their travel .*clip 0: 3\.27 m -> 0\.12 m", note)


def test_kept_travel_is_not_noted():
    from motionlab.evaluation.reconstruction import lost_travel

    truth = ClipJoints.from_joints([_walk(3.0), _walk(1.0)])
    assert lost_travel(truth, ClipJoints.from_joints([_walk(2.5), _walk(0.6)])) == ([], None)


def test_one_lost_walk_among_many_is_no_pattern():
    """A dataset whose tokenizer keeps the travel of most walks is not warned about for one of them."""
    from motionlab.evaluation.reconstruction import lost_travel

    truth = ClipJoints.from_joints([_walk(2.0)] * 5)
    decoded = ClipJoints.from_joints([_walk(0.1)] + [_walk(1.9)] * 4)
    assert lost_travel(truth, decoded) == ([0], None)
