"""BVH -> t2m joints -> HumanML3D features, on three real CMU takes and on synthetic files.

The CMU takes (../shared/data/cmu-bvh, test data only) come from the CMU Graphics Lab Motion Capture
Database. "The data used in this project was obtained from mocap.cs.cmu.edu. The database was created with
funding from NSF EIA-0196217."
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from motionlab.data.embedded.generator import generate_clip
from motionlab.io import (
    CMU_TO_T2M,
    bvh_positions,
    bvh_to_features,
    bvh_to_joints,
    fill_degenerate_joints,
    motion_to_bvh,
    parse_bvh,
    read_bvh,
    resample,
)
from motionlab.representation import T2M, feature_slices, recover_from_ric

# take -> (HumanML3D clip cut from it, start, end) at 20 fps, from the data folder's README.
TAKES = {"131_01": ("013683", 0, 166), "131_02": ("001417", 10, 208), "131_03": ("010943", 0, 184)}
FRAMES_120 = {"131_01": 994, "131_02": 1247, "131_03": 1102}


@functools.cache
def _read_take(path: str):
    return read_bvh(path)  # parsed once per test session


@pytest.fixture
def takes(shared_data):
    folder = shared_data / "cmu-bvh"
    if not folder.is_dir():
        pytest.skip(f"CMU BVH takes not found at {folder}")
    return {name: _read_take(str(folder / f"{name}.bvh")) for name in TAKES}


def _bone_lengths(joints):
    return np.linalg.norm(joints[:, 1:] - joints[:, list(T2M.parents[1:])], axis=-1)  # (T, 21)


def test_cmu_files_parse_as_described(takes):
    for name, bvh in takes.items():
        assert bvh.n_frames == FRAMES_120[name]
        assert round(bvh.fps) == 120
        assert bvh.joints[0].channels == ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
        assert sum(not j.end_site for j in bvh.joints) == 31
        assert set(CMU_TO_T2M.values()) <= set(bvh.names)


@pytest.mark.parametrize("name", sorted(TAKES))
def test_converted_take_has_the_frame_count_of_its_humanml3d_clip(takes, name):
    _, start, end = TAKES[name]
    joints = bvh_to_joints(takes[name])
    assert joints.shape == (len(range(0, FRAMES_120[name], 6)), 22, 3)  # 120 -> 20 fps is HumanML3D's [::6]
    cropped = bvh_to_joints(takes[name], start=start, end=end)
    assert cropped.shape == (end - start, 22, 3)
    features = bvh_to_features(takes[name], start=start, end=end)
    assert features.shape == (end - start - 1, 263)  # as HumanML3D's new_joint_vecs
    assert np.isfinite(features).all()


def test_resampling_120_to_20_is_decimation(takes):
    bvh = takes["131_03"]
    raw = bvh_positions(bvh)[::6]
    joints = bvh_to_joints(bvh)
    names = list(bvh.names)
    picked = raw[:, [names.index(CMU_TO_T2M[n]) for n in ("pelvis", "left_knee", "head")]] * 0.056444
    np.testing.assert_allclose(joints[:, [0, 4, 15]], picked, atol=1e-12)


def test_units_and_skeleton_are_plausible(takes):
    joints = bvh_to_joints(takes["131_01"])  # CMU proportions, metres
    lengths = _bone_lengths(joints).mean(axis=0)
    thigh, shin = lengths[T2M.index("left_knee") - 1], lengths[T2M.index("left_ankle") - 1]
    assert 0.35 < thigh < 0.5 and 0.35 < shin < 0.5
    assert 0.85 < joints[:5, 0, 1].mean() < 1.05  # standing root height
    assert joints[..., 1].min() > -0.01  # no joint below the floor
    # The degenerate CMU joints were placed halfway: spine1 between pelvis and spine2, collars off spine3.
    assert lengths.min() > 0.04
    np.testing.assert_allclose(joints[:, 3], 0.5 * (joints[:, 0] + joints[:, 6]), atol=1e-12)
    np.testing.assert_allclose(joints[:, 13], 0.5 * (joints[:, 9] + joints[:, 16]), atol=1e-12)
    # Handedness: the facing HumanML3D computes from the hips (up x (right - left)) agrees with where the
    # toes point; a mirrored import would face backwards.
    across = joints[:, T2M.index("right_hip")] - joints[:, T2M.index("left_hip")]
    forward = np.cross([0.0, 1.0, 0.0], across)
    toes = joints[:, T2M.index("left_foot")] - joints[:, T2M.index("left_ankle")]
    toes[:, 1] = 0.0
    cosine = (forward * toes).sum(-1) / np.linalg.norm(forward, axis=-1) / np.linalg.norm(toes, axis=-1)
    assert np.median(cosine) > 0.8


@pytest.mark.parametrize("name", sorted(TAKES))
def test_features_are_on_the_target_skeleton_with_feet_on_the_floor(takes, name):
    _, start, end = TAKES[name]
    features = bvh_to_features(takes[name], start=start, end=end)
    joints = recover_from_ric(features)  # (T-1, 22, 3)
    np.testing.assert_allclose(
        _bone_lengths(joints), np.broadcast_to(T2M.bone_lengths[1:], (len(joints), 21)), atol=1e-6
    )
    feet = joints[:, [7, 10, 8, 11], 1]  # left ankle, left foot, right ankle, right foot heights
    assert feet.min() == pytest.approx(0.0, abs=1e-6)  # HumanML3D's floor: the lowest joint of the clip
    lowest = feet.min(axis=1)
    # CMU's ankle sits higher above its toe joint than SMPL's, so after retargeting the stance foot's lowest
    # joint is typically 2-7 cm up (131_02 the most: one toe-point sets its floor); each foot still lands.
    assert np.percentile(lowest, 50) < 0.075
    for side in (slice(0, 2), slice(2, 4)):
        assert feet[:, side].min() < 0.06


@pytest.mark.parametrize("name", ["131_01", "131_02"])
def test_walking_has_alternating_foot_contacts_on_low_feet(takes, name):
    _, start, end = TAKES[name]
    features = bvh_to_features(takes[name], start=start, end=end)
    contacts = features[:, feature_slices()["foot_contact"]]  # (T-1, 4): l ankle, l foot, r ankle, r foot
    joints = recover_from_ric(features)
    for channel, joint in zip(range(4), (7, 10, 8, 11)):
        on = contacts[:, channel] > 0.5
        assert 0.2 < on.mean() < 0.98  # both states occur while walking
        assert joints[on, joint, 1].mean() < joints[~on, joint, 1].mean()  # contact = the lower foot
    left, right = contacts[:, 1] > 0.5, contacts[:, 3] > 0.5
    assert (left & ~right).sum() > 5 and (right & ~left).sum() > 5  # single support on each foot


def test_crop_and_arguments_are_validated(takes):
    bvh = takes["131_01"]
    with pytest.raises(ValueError, match=r"crop \[start, end\) = \[10, 500\)"):
        bvh_to_joints(bvh, start=10, end=500)
    with pytest.raises(ValueError, match="scale"):
        bvh_to_joints(bvh, scale=-1.0)
    with pytest.raises(ValueError, match="up must be"):
        bvh_to_joints(bvh, up="x")
    with pytest.raises(ValueError, match="unknown BVH rig 'vicon'"):
        bvh_to_joints(bvh, mapping="vicon")
    with pytest.raises(ValueError, match="needs scale"):
        bvh_to_joints(bvh, mapping=dict(CMU_TO_T2M))


def test_mapping_errors_name_the_joints(takes):
    bvh = takes["131_01"]
    partial = {k: v for k, v in CMU_TO_T2M.items() if k not in ("head", "left_wrist")}
    with pytest.raises(ValueError, match="unmapped: head, left_wrist"):
        bvh_to_joints(bvh, mapping=partial, scale=0.056444)
    wrong = dict(CMU_TO_T2M, head="Skull")
    with pytest.raises(ValueError, match="head -> 'Skull'"):
        bvh_to_joints(bvh, mapping=wrong, scale=0.056444)
    with pytest.raises(ValueError, match="does not have: tail"):
        bvh_to_joints(bvh, mapping=dict(CMU_TO_T2M, tail="Hips"), scale=0.056444)


# ----------------------------------------------------------------- synthetic files (no shared data needed)


def _renamed_t2m_bvh(rename: dict[str, str], fps: float = 20.0):
    joints = generate_clip("walk", np.random.default_rng(3), n_frames=60).joints
    bvh = motion_to_bvh(joints, fps=fps)
    text = bvh_text = _to_text(bvh)
    for old, new in rename.items():
        text = text.replace(f"JOINT {old}\n", f"JOINT {new}\n").replace(f"ROOT {old}\n", f"ROOT {new}\n")
    assert text != bvh_text or not rename
    return parse_bvh(text), joints


def _to_text(bvh):
    from motionlab.io import format_bvh

    return format_bvh(bvh)


def test_custom_mapping_dict_reads_a_renamed_rig():
    rename = {"pelvis": "Root", "left_knee": "LKnee", "head": "Skull"}
    bvh, joints = _renamed_t2m_bvh(rename)
    mapping = {n: rename.get(n, n) for n in T2M.joint_names}
    back = bvh_to_joints(bvh, mapping=mapping, scale=1.0)
    np.testing.assert_allclose(back, joints, atol=1e-5)
    with pytest.raises(ValueError, match="pelvis -> 'pelvis'"):
        bvh_to_joints(bvh, mapping="t2m")


def test_resampling_a_60fps_file_to_20fps():
    bvh, joints = _renamed_t2m_bvh({}, fps=60.0)  # the 20 fps clip played 3x faster
    back = bvh_to_joints(bvh, mapping="t2m", fps=20.0)
    np.testing.assert_allclose(back, joints[::3], atol=1e-5)
    half = bvh_to_joints(bvh, mapping="t2m", fps=40.0)  # in-between frames are linear interpolations
    np.testing.assert_allclose(half[1], 0.5 * (joints[1] + joints[2]), atol=1e-5)


def test_resample_frame_counts():
    x = np.arange(13.0)[:, None]
    np.testing.assert_allclose(resample(x, 120, 20), x[::6])
    np.testing.assert_allclose(resample(x, 30, 20)[:, 0], np.arange(0, 12.01, 1.5))
    with pytest.raises(ValueError, match="positive"):
        resample(x, 0, 20)


def test_z_up_files_are_turned_to_y_up_keeping_left_left():
    bvh, joints = _renamed_t2m_bvh({})
    # Make a Z-up file: hang the Y-up rig under a new root turned +90 degrees about X, (x, y, z) -> (x, -z, y).
    head, motion = _to_text(bvh).split("MOTION\n")
    body = head.replace("HIERARCHY\nROOT pelvis", "JOINT pelvis").replace("\n", "\n\t")
    hierarchy = f"HIERARCHY\nROOT zup\n{{\n\tOFFSET 0 0 0\n\tCHANNELS 1 Xrotation\n\t{body.rstrip()}\n}}\n"
    lines = motion.splitlines()
    zup = parse_bvh(hierarchy + "MOTION\n" + "\n".join(lines[:2] + ["90 " + line for line in lines[2:]]))
    assert bvh_positions(zup)[..., 2].max() > 1.0  # the head is high along Z now
    back = bvh_to_joints(zup, mapping="t2m", up="z")
    np.testing.assert_allclose(back, joints, atol=1e-5)  # left stays left: no mirror


def test_fill_degenerate_joints_places_and_rejects():
    joints = generate_clip("wave", np.random.default_rng(0), n_frames=50).joints.copy()
    collapsed = joints.copy()
    collapsed[:, 3] = collapsed[:, 0]  # spine1 on the pelvis, like CMU's lowerback
    fixed, moved = fill_degenerate_joints(collapsed, T2M, fill=0.25)
    assert moved == ["spine1"]
    np.testing.assert_allclose(fixed[:, 3], joints[:, 0] + 0.25 * (joints[:, 6] - joints[:, 0]))
    stacked = joints.copy()
    stacked[:, 20] = stacked[:, 18]  # a degenerate end joint has no next joint to move towards
    with pytest.raises(ValueError, match="left_elbow -> left_wrist"):
        fill_degenerate_joints(stacked, T2M)
