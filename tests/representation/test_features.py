import numpy as np
import pytest
import torch

from motionlab.representation import (
    KIT,
    T2M,
    axis_angle_to_quat,
    feature_slices,
    forward_kinematics,
    get_skeleton,
    inverse_kinematics,
    joints_to_features,
    process_joints,
    recover_from_ric,
    recover_from_rot,
)


def procedural_motion(skeleton=T2M, frames=60, seed=0) -> np.ndarray:
    """A smooth, turning, walking-ish motion on the skeleton's target bone lengths."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / skeleton.fps
    j = skeleton.n_joints
    axes = rng.normal(size=(j, 3))
    amp = rng.uniform(0.1, 0.6, size=j)
    phase = rng.uniform(0, 2 * np.pi, size=j)
    angles = amp[None] * np.sin(2 * np.pi * 0.8 * t[:, None] + phase[None])  # (T, J)
    local = axis_angle_to_quat(np.broadcast_to(axes, (frames, j, 3)), angles)
    local[:, 0] = axis_angle_to_quat(np.array([0.0, 1.0, 0.0]), 0.4 * t + 0.3)  # slow turn
    scale = 1000.0 if skeleton.unit == "mm" else 1.0
    root = np.stack([0.5 * t, 0.9 + 0.03 * np.sin(6 * t), 0.8 * t], axis=-1) * scale
    return forward_kinematics(local, root, skeleton)


def test_feature_dims_and_layout():
    assert T2M.feature_dim == 263 and KIT.feature_dim == 251
    s = feature_slices("t2m")
    assert (s["ric"], s["rot"], s["local_vel"], s["foot_contact"]) == (
        slice(4, 67),
        slice(67, 193),
        slice(193, 259),
        slice(259, 263),
    )
    assert feature_slices("kit")["foot_contact"] == slice(247, 251)


@pytest.mark.parametrize("skeleton", ["t2m", "kit"])
def test_procedural_round_trip_is_exact(skeleton):
    sk = get_skeleton(skeleton)
    joints = procedural_motion(sk)
    processed = process_joints(joints, sk)
    feats = processed.features
    assert feats.shape == (len(joints) - 1, sk.feature_dim)
    assert np.abs(recover_from_ric(feats, sk.n_joints) - processed.joints[:-1]).max() < 1e-5 * (
        1000 if sk.unit == "mm" else 1
    )
    assert np.abs(recover_from_rot(feats) - processed.joints[:-1]).max() < 1e-5 * (1000 if sk.unit == "mm" else 1)


def test_canonical_conventions():
    processed = process_joints(procedural_motion(), "t2m")
    j = processed.joints
    assert abs(j[..., 1].min()) < 1e-9  # floor at y = 0
    assert np.allclose(j[0, 0, [0, 2]], 0.0)  # root at the origin in frame 0
    across = (j[0, 2] - j[0, 1]) + (j[0, 17] - j[0, 16])
    forward = np.cross([0.0, 1.0, 0.0], across)
    assert forward[2] > 0 and abs(forward[0]) < 1e-9  # facing +Z


def test_retargeting_puts_motion_on_target_bone_lengths():
    joints = procedural_motion() * 1.2  # a taller person
    out = process_joints(joints, "t2m").joints
    for child, parent in enumerate(T2M.parents):
        if parent >= 0:
            assert np.allclose(np.linalg.norm(out[:, child] - out[:, parent], axis=-1), T2M.bone_lengths[child])


def test_ik_then_fk_reproduces_bone_directions():
    joints = procedural_motion()
    quats = inverse_kinematics(joints, "t2m")
    again = forward_kinematics(quats, joints[:, 0], "t2m")
    assert np.abs(again - joints).max() < 1e-9


def test_torch_inputs_give_torch_outputs():
    joints = torch.tensor(procedural_motion(), dtype=torch.float32)
    feats = joints_to_features(joints)
    assert isinstance(feats, torch.Tensor) and feats.dtype == torch.float32
    back = recover_from_ric(feats[None], 22)  # batched
    assert isinstance(back, torch.Tensor) and back.shape == (1, len(joints) - 1, 22, 3)


def test_foot_contacts_follow_foot_speed():
    joints = procedural_motion()
    moving = joints_to_features(joints, retarget_to_target=False)[:, 259:263]
    joints[:, [10]] = joints[:1, [10]]  # pin the left toe (contacts: left ankle, left toe, right ankle, right toe)
    pinned = joints_to_features(joints, retarget_to_target=False)[:, 259:263]
    assert set(np.unique(pinned)) <= {0.0, 1.0}
    assert (pinned[:, 1] == 1).all() and moving[:, 1].mean() < 0.5  # a still toe is in contact at every frame
    assert (pinned[:, [0, 2, 3]].mean(0) < 0.5).all()  # the walking feet touch the ground only part of the time
    np.testing.assert_array_equal(pinned[:, 2:], moving[:, 2:])  # pinning one foot leaves the other's contacts


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.zeros((10, 21, 3)), r"shape \(T, 22, 3\)"),
        (np.zeros((1, 22, 3)), "at least 2 frames"),
        (np.full((5, 22, 3), np.nan), "NaN"),
    ],
)
def test_bad_joints(bad, match):
    with pytest.raises(ValueError, match=match):
        joints_to_features(bad)


def test_bad_features_and_skeleton():
    with pytest.raises(ValueError, match="matches no skeleton"):
        recover_from_ric(np.zeros((5, 100)), 22)
    with pytest.raises(ValueError, match="not 21"):
        recover_from_ric(np.zeros((5, 263)), 21)
    with pytest.raises(ValueError, match="NaN"):
        recover_from_ric(np.full((5, 263), np.inf), 22)
    with pytest.raises(ValueError, match="unknown skeleton"):
        get_skeleton("smpl-x")


def test_real_clip_recovers_its_joints(shared_data):
    folder = shared_data / "humanml3d-sample"
    feats = np.load(folder / "new_joint_vecs" / "012314.npy")
    joints = np.load(folder / "new_joints" / "012314.npy")
    assert np.abs(recover_from_ric(feats, 22) - joints).max() < 1e-4


def test_real_clip_features_match_public_processing(shared_data):
    folder = shared_data / "humanml3d-sample"
    shipped = np.load(folder / "new_joint_vecs" / "012314.npy")
    joints = np.load(folder / "new_joints" / "012314.npy")
    ours = joints_to_features(joints)
    assert ours.shape == (len(joints) - 1, 263)
    shipped = shipped[: len(ours)]  # the shipped joints already lost the source's last pose
    s = feature_slices()
    err = {name: np.abs(ours[:, sl] - shipped[:, sl]).max() for name, sl in s.items()}
    # The public processing re-run on these joints agrees to about 1e-2 (positions/rotations: its forward
    # direction is Gaussian-smoothed over the clip, which changes at the clip's new end) and 1e-3 (velocities).
    assert err["ric"] < 1e-2 and err["rot"] < 2e-2 and err["root_height"] < 1e-3
    assert err["root_rot_vel"] < 1e-3 and err["root_lin_vel"] < 1e-3 and err["local_vel"] < 1e-3
    assert err["foot_contact"] == 0
    assert np.abs(ours[:, s["rot"]] - shipped[:, s["rot"]]).mean() < 1e-3


@pytest.mark.parametrize("skeleton", [T2M, KIT])
def test_packed_recovery_equals_recover_from_ric_clip_by_clip(skeleton):
    from motionlab.representation.features import recover_packed_from_ric

    rng = np.random.default_rng(11)
    clips = [rng.normal(scale=0.2, size=(n, skeleton.feature_dim)) for n in (5, 1, 37, 12)]
    expected = np.concatenate([recover_from_ric(c) for c in clips])  # float64, frame by frame
    packed, lengths = recover_packed_from_ric(clips)
    assert packed.shape == (55, skeleton.n_joints, 3) and packed.flags.c_contiguous
    assert lengths.tolist() == [5, 1, 37, 12]
    np.testing.assert_allclose(packed, expected, rtol=0, atol=1e-12)
    # the same clips padded, with NaN in the padding (never read) and as float32 tensors
    padded = np.full((4, 40, skeleton.feature_dim), np.nan)
    for i, c in enumerate(clips):
        padded[i, : len(c)] = c
    np.testing.assert_array_equal(recover_packed_from_ric(padded, lengths)[0], packed)
    as_float32 = recover_packed_from_ric([torch.from_numpy(c).float() for c in clips])[0]
    assert as_float32.dtype == np.float64
    np.testing.assert_allclose(as_float32, recover_packed_from_ric([c.astype(np.float32) for c in clips])[0])


def test_packed_recovery_rejects_bad_input():
    from motionlab.representation.features import recover_packed_from_ric

    good = np.zeros((6, 263))
    bad = good.copy()
    bad[4, 10] = np.nan
    with pytest.raises(ValueError, match="clip 1"):
        recover_packed_from_ric([good, bad])
    with pytest.raises(ValueError, match="lengths"):
        recover_packed_from_ric(np.zeros((2, 6, 263)), [6, 7])
    with pytest.raises(ValueError, match="lengths is only used"):
        recover_packed_from_ric([good], [6])
    with pytest.raises(ValueError, match="22 joints"):
        recover_packed_from_ric([good], n_joints=21)
    with pytest.raises(ValueError, match="empty"):
        recover_packed_from_ric([])


def test_packed_recovery_block_by_block_equals_one_block(monkeypatch):
    import motionlab.representation.features as features_module

    rng = np.random.default_rng(12)
    clips = [rng.normal(scale=0.2, size=(n, 263)) for n in (5, 1, 37, 12, 8)]
    whole, _ = features_module.recover_packed_from_ric(clips)
    monkeypatch.setattr(features_module, "_BLOCK_FRAMES", 10)  # blocks of whole clips: [5, 1], [37], [12], [8]
    np.testing.assert_array_equal(features_module.recover_packed_from_ric(clips)[0], whole)
    bad = [c.copy() for c in clips]
    bad[3][2, 40] = np.inf
    with pytest.raises(ValueError, match="clip 3"):
        features_module.recover_packed_from_ric(bad)
