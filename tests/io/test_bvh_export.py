"""t2m motion -> BVH -> back: the rig, the rotations, and round trips through our reader (and bvhio's)."""

from __future__ import annotations

import numpy as np
import pytest

from motionlab.data.embedded.generator import generate_clip
from motionlab.io import bvh_positions, bvh_to_joints, format_bvh, motion_to_bvh, parse_bvh, read_bvh, save_bvh
from motionlab.io.bvh_export import t2m_bvh_rig
from motionlab.representation import T2M, joints_to_features, recover_from_ric

FAMILIES = ("walk", "run", "turn", "jump", "wave", "kick", "squat", "bow")


def _clip(family: str, seed: int = 0, n_frames: int = 60) -> np.ndarray:
    return generate_clip(family, np.random.default_rng(seed), n_frames=n_frames).joints


def test_rig_follows_the_t2m_tree():
    nodes = t2m_bvh_rig()
    joints = [n.joint for n in nodes]
    names = [j.name for j in joints]
    root = joints[0]
    assert root.name == "pelvis" and root.offset == (0.0, 0.0, 0.0)
    assert root.channels == ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
    # Every t2m joint is there once, under its t2m parent (directly or through one zero-length helper).
    for j, name in enumerate(T2M.joint_names[1:], start=1):
        node = joints[names.index(name)]
        parent = joints[node.parent]
        if parent.name.endswith(f"_to_{name}"):
            assert parent.offset == (0.0, 0.0, 0.0)
            parent = joints[parent.parent]
        assert parent.name == T2M.joint_names[T2M.parents[j]]
        np.testing.assert_allclose(node.offset, T2M.offsets[j])
    helpers = [n for n in names if "_to_" in n]
    assert sorted(helpers) == sorted(
        [
            "pelvis_to_left_hip",
            "pelvis_to_right_hip",
            "pelvis_to_spine1",
            "spine3_to_neck",
            "spine3_to_left_collar",
            "spine3_to_right_collar",
        ]
    )
    ends = [j for j in joints if j.end_site]
    assert sorted(j.name for j in ends) == sorted(
        f"{n}_end" for n in ("left_foot", "right_foot", "head", "left_wrist", "right_wrist")
    )


@pytest.mark.parametrize("family", FAMILIES)
def test_round_trip_on_procedural_motions(tmp_path, family):
    joints = _clip(family)
    path = save_bvh(joints, tmp_path / f"{family}.bvh")
    back = bvh_to_joints(path, mapping="t2m")
    assert back.shape == joints.shape
    assert np.abs(back - joints).max() < 1e-5  # 6 decimals in the file; the requirement is 1e-3 m


@pytest.mark.parametrize(("order", "unit", "scale"), [("ZXY", "cm", 0.01), ("XYZ", "mm", 0.001), ("YZX", "m", 1.0)])
def test_round_trip_in_other_orders_and_units(order, unit, scale):
    joints = _clip("jumping_jacks", seed=1)
    bvh = parse_bvh(format_bvh(motion_to_bvh(joints, unit=unit, rotation_order=order)))
    assert bvh.joints[1].channels == tuple(f"{a}rotation" for a in order)
    back = bvh_to_joints(bvh, mapping="t2m", scale=scale)
    assert np.abs(back - joints).max() < 1e-4


def test_end_sites_extend_the_last_bones():
    joints = _clip("wave")
    bvh = motion_to_bvh(joints)
    p = bvh_positions(bvh)
    for name in ("left_wrist", "head", "right_foot"):
        j, end = bvh.index(name), bvh.index(f"{name}_end")
        k = T2M.index(name)
        bone = joints[:, k] - joints[:, T2M.parents[k]]
        np.testing.assert_allclose(p[:, end] - p[:, j], 0.5 * bone, atol=1e-5)


def test_root_rotation_is_the_facing_rotation():
    # A still pose turned to face +X: the root turns +90 degrees about Y and the rest stays local.
    pose = recover_from_ric(joints_to_features(_clip("squat")))[:1]  # faces +Z
    quarter = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # +90 deg about Y: z -> x
    turned = np.concatenate([pose, pose @ quarter.T])
    bvh = motion_to_bvh(turned)
    zyx = bvh.frames[:, 3:6]  # root Zrotation, Yrotation, Xrotation
    np.testing.assert_allclose(zyx[1] - zyx[0], [0.0, 90.0, 0.0], atol=0.05)
    np.testing.assert_allclose(bvh.frames[0, 6:], bvh.frames[1, 6:], atol=1e-6)  # local angles unchanged
    # The middle angle is 90 degrees (gimbal lock for ZYX): the angles still rebuild the pose.
    positions = bvh_positions(bvh)[:, [bvh.index(n) for n in T2M.joint_names]]
    np.testing.assert_allclose(positions, turned, atol=1e-5)


def test_motions_off_the_target_skeleton_keep_their_bone_directions():
    joints = _clip("kick")
    stretched = joints[:, :1] + 1.1 * (joints - joints[:, :1])  # every bone 10% longer
    back = bvh_to_joints(motion_to_bvh(stretched), mapping="t2m")
    lengths = np.linalg.norm(back[:, 1:] - back[:, list(T2M.parents[1:])], axis=-1)
    np.testing.assert_allclose(lengths, np.broadcast_to(T2M.bone_lengths[1:], lengths.shape), atol=1e-5)
    for j, p in enumerate(T2M.parents[1:], start=1):
        a, b = back[:, j] - back[:, p], stretched[:, j] - stretched[:, p]
        cos = (a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1)
        assert cos.min() > 1 - 1e-8


def test_real_humanml3d_clip_round_trips(shared_data, tmp_path):
    folder = shared_data / "humanml3d-sample"
    joints = np.load(folder / "new_joints" / "012314.npy").astype(np.float64)
    back = bvh_to_joints(save_bvh(joints, tmp_path / "a.bvh"), mapping="t2m")
    assert np.abs(back - joints).max() < 1e-3  # the released joints carry the target lengths up to ~4e-5 m
    features = np.load(folder / "new_joint_vecs" / "012314.npy")
    back = bvh_to_joints(save_bvh(features, tmp_path / "b.bvh"), mapping="t2m")
    assert np.abs(back - joints).max() < 1e-3


def test_bad_input_raises_and_leaves_no_file(tmp_path):
    joints = _clip("walk")
    target = tmp_path / "x.bvh"
    with pytest.raises(ValueError, match=r"22 \(t2m\) or 21 \(kit\) joints"):
        save_bvh(joints[:, :20], target)
    nan = joints.copy()
    nan[5, 3, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        save_bvh(nan, target)
    flat = joints.copy()
    flat[:, 4] = flat[:, 1]
    with pytest.raises(ValueError, match="left_knee coincides with its parent"):
        save_bvh(flat, target)
    with pytest.raises(ValueError, match="unit"):
        save_bvh(joints, target, unit="inch")
    with pytest.raises(ValueError, match="rotation_order"):
        save_bvh(joints, target, rotation_order="XXY")
    with pytest.raises(ValueError, match=r"\.bvh"):
        save_bvh(joints, tmp_path / "x.fbx")
    with pytest.raises(ValueError, match="t2m"):
        save_bvh(np.zeros((5, 21, 3)) + np.arange(21)[:, None], target)  # a KIT motion
    assert list(tmp_path.iterdir()) == []


def test_independent_reader_bvhio_agrees(tmp_path):
    bvhio = pytest.importorskip("bvhio")
    joints = _clip("walk", n_frames=41)
    path = save_bvh(joints, tmp_path / "walk.bvh")
    ours = read_bvh(path)
    root = bvhio.readAsHierarchy(str(path))
    layout = [j for j, _, _ in root.layout()]
    for frame in (0, 17, 40):
        root.loadPose(frame)
        theirs = {j.Name: np.array(j.PositionWorld) for j in layout}
        for k, name in enumerate(T2M.joint_names):
            np.testing.assert_allclose(theirs[name], joints[frame, k], atol=1e-4)  # bvhio computes in float32
    assert len(layout) == sum(not j.end_site for j in ours.joints)
