"""What a conversion must never do silently: drop frames, write NaN, lay a body flat, hide bone stretch.

The CMU take used here comes from the CMU Graphics Lab Motion Capture Database. "The data used in this
project was obtained from mocap.cs.cmu.edu. The database was created with funding from NSF EIA-0196217."
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from motionlab.data.embedded.generator import generate_clip
from motionlab.io import bvh_to_joints, convert_motion, load_joints, read_bvh, save_motion
from motionlab.io.bvh_export import rigid_deviation
from motionlab.io.common import MotionWarning, bone_stretch
from motionlab.representation import T2M, joints_to_features


@pytest.fixture(scope="module")
def clip() -> np.ndarray:
    return generate_clip("wave", np.random.default_rng(2), n_frames=45).joints


def test_features_npy_to_npy_keeps_every_frame(tmp_path, clip):
    features = joints_to_features(clip).astype(np.float32)  # (44, 263)
    np.save(tmp_path / "a.npy", features)
    convert_motion(tmp_path / "a.npy", tmp_path / "b.npy")
    convert_motion(tmp_path / "b.npy", tmp_path / "c.npy")
    np.testing.assert_array_equal(np.load(tmp_path / "c.npy"), features)  # a round trip keeps every frame
    convert_motion(tmp_path / "a.npy", tmp_path / "d.npy", start=4, end=20)
    np.testing.assert_array_equal(np.load(tmp_path / "d.npy"), features[4:20])
    bad = features.copy()
    bad[3, 5] = np.nan
    np.save(tmp_path / "nan.npy", bad)
    with pytest.raises(ValueError, match="NaN"):
        convert_motion(tmp_path / "nan.npy", tmp_path / "e.npy")
    assert not (tmp_path / "e.npy").exists()


def test_degenerate_joints_never_become_nan_features(tmp_path, clip):
    flat = clip.copy()
    flat[:, [1, 2, 16, 17]] = flat[:, [0, 0, 0, 0]]  # hips and shoulders on the root: no facing direction
    with pytest.raises(ValueError, match="no facing direction"):
        save_motion(flat, tmp_path / "flat.npy")
    assert not (tmp_path / "flat.npy").exists()
    stacked = clip.copy()
    stacked[:, 18] = stacked[:, 16]  # an elbow on its shoulder in every frame: placed on the arm, with a warning
    np.save(tmp_path / "stacked.npy", stacked)
    with pytest.warns(MotionWarning, match="left_elbow"):
        joints = load_joints(tmp_path / "stacked.npy")
    assert np.isfinite(joints).all() and np.linalg.norm(joints[:, 18] - joints[:, 16], axis=-1).min() > 0.05


def test_a_y_up_file_read_as_z_up_warns(shared_data):
    take = shared_data / "cmu-bvh" / "131_02.bvh"
    with warnings.catch_warnings():
        warnings.simplefilter("error", MotionWarning)
        bvh_to_joints(take, up="y")  # upright: no warning
    with pytest.warns(MotionWarning, match=r"131_02.bvh: with up='z'.*--up y"):
        bvh_to_joints(take, up="z")


def test_z_up_file_is_read_upright_without_warning(tmp_path, clip):
    from motionlab.io import format_bvh
    from motionlab.io.bvh_export import motion_to_bvh

    z_up = clip @ np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]).T  # y-up -> z-up
    with pytest.warns(MotionWarning, match="up='y'.*--up z"):  # the exporter itself thinks it is y-up
        path = tmp_path / "z.bvh"
        path.write_text(format_bvh(motion_to_bvh(z_up)))
        bvh_to_joints(path, mapping="t2m", up="y")
    with warnings.catch_warnings():
        warnings.simplefilter("error", MotionWarning)
        np.testing.assert_allclose(bvh_to_joints(path, mapping="t2m", up="z"), clip, atol=1e-5)


def test_bvh_export_reports_bone_stretch(tmp_path, clip):
    with warnings.catch_warnings():
        warnings.simplefilter("error", MotionWarning)
        save_motion(clip, tmp_path / "rigid.bvh")  # rigid bones: nothing to report
    stretched = clip.copy()
    grow = 1.0 + 0.8 * np.sin(np.linspace(0, np.pi, len(clip)))[:, None]  # the left forearm 1x .. 1.8x
    stretched[:, 20] = stretched[:, 18] + grow * (clip[:, 20] - clip[:, 18])
    spread, bone, lo, hi = bone_stretch(stretched, T2M)
    assert bone == "left_elbow -> left_wrist" and hi / lo == pytest.approx(1.8, rel=0.01)
    with pytest.warns(MotionWarning, match=r"left_elbow -> left_wrist .*fixed bone lengths.*cm"):
        save_motion(stretched, tmp_path / "stretched.bvh")
    gap = rigid_deviation(read_bvh(tmp_path / "stretched.bvh"), stretched)
    assert gap == pytest.approx(0.8 * np.linalg.norm(clip[:, 20] - clip[:, 18], axis=-1).max(), rel=0.05)
