"""Choosing the format by extension: save_motion, load_joints, convert_motion (what the CLI calls).

The CMU take used here comes from the CMU Graphics Lab Motion Capture Database. "The data used in this
project was obtained from mocap.cs.cmu.edu. The database was created with funding from NSF EIA-0196217."
"""

from __future__ import annotations

import os
import stat

import numpy as np
import pytest

from motionlab.data.embedded.generator import generate_clip
from motionlab.io import convert_motion, load_joints, read_bvh, save_motion
from motionlab.representation import joints_to_features


@pytest.fixture(scope="module")
def clip() -> np.ndarray:
    return generate_clip("wave", np.random.default_rng(2), n_frames=45).joints


def test_save_motion_picks_the_format(tmp_path, clip):
    assert read_bvh(save_motion(clip, tmp_path / "a.bvh")).n_frames == 45
    assert "<canvas" in save_motion(clip, tmp_path / "a.HTML").read_text()
    assert 'id="motion-data"' in save_motion(clip, tmp_path / "b.htm", title="waving").read_text()
    features = np.load(save_motion(clip, tmp_path / "a.npy"))
    np.testing.assert_allclose(features, joints_to_features(clip), atol=1e-5)
    assert features.shape == (44, 263) and features.dtype == np.float32
    np.testing.assert_allclose(np.load(save_motion(features, tmp_path / "b.npy")), features)  # as given


def test_segments_go_into_the_player_and_the_sidecar(tmp_path, clip):
    import json

    segments = [(0, "a person walks"), (20, "a person waves")]
    page = save_motion(clip, tmp_path / "two.html", segments=segments).read_text()
    assert "a person waves" in page and '"segments"' in page
    written = save_motion(clip, tmp_path / "two.bvh", segments=segments)
    sidecar = json.loads((tmp_path / "two.bvh.json").read_text())
    assert sidecar["segments"] == [
        {"start_frame": 0, "text": "a person walks"},
        {"start_frame": 20, "text": "a person waves"},
    ]
    assert read_bvh(written).n_frames == 45  # the BVH itself is unchanged
    with pytest.raises(ValueError, match="segment starts must begin at 0"):
        save_motion(clip, tmp_path / "bad.npy", segments=[(5, "starts late")])
    assert not (tmp_path / "bad.npy").exists()


def test_unknown_extension_and_bad_motion_write_nothing(tmp_path, clip):
    with pytest.raises(ValueError, match=r"unknown extension '\.gif'"):
        save_motion(clip, tmp_path / "a.gif")
    with pytest.raises(ValueError, match="NaN"):
        save_motion(np.full((10, 263), np.nan), tmp_path / "a.npy")
    with pytest.raises(ValueError, match="shape"):
        save_motion(np.zeros((10, 22)), tmp_path / "a.bvh")
    with pytest.raises(ValueError, match="at least 2 frames"):
        save_motion(clip[:1], tmp_path / "a.npy")
    assert list(tmp_path.iterdir()) == []


def test_load_joints_from_npy_and_bvh(tmp_path, clip):
    np.save(tmp_path / "joints.npy", clip)
    np.testing.assert_allclose(load_joints(tmp_path / "joints.npy", start=5, end=20), clip[5:20])
    save_motion(clip, tmp_path / "clip.bvh")
    np.testing.assert_allclose(load_joints(tmp_path / "clip.bvh", mapping="t2m"), clip, atol=1e-5)
    with pytest.raises(ValueError, match="does not exist"):
        load_joints(tmp_path / "missing.bvh")
    with pytest.raises(ValueError, match=r"unknown extension '\.csv'"):
        load_joints(tmp_path / "x.csv")
    np.save(tmp_path / "bad.npy", np.zeros((4, 5)))
    with pytest.raises(ValueError, match="bad.npy"):
        load_joints(tmp_path / "bad.npy")
    (tmp_path / "empty.npy").write_bytes(b"")
    with pytest.raises(ValueError, match="empty.npy cannot be read"):  # numpy raises EOFError here
        load_joints(tmp_path / "empty.npy")


def test_convert_npy_to_bvh_and_html(tmp_path, clip):
    np.save(tmp_path / "clip.npy", joints_to_features(clip).astype(np.float32))
    out = convert_motion(tmp_path / "clip.npy", tmp_path / "clip.bvh")
    assert read_bvh(out).n_frames == 44
    assert convert_motion(tmp_path / "clip.bvh", tmp_path / "clip.html", mapping="t2m").is_file()
    with pytest.raises(ValueError, match="output"):
        convert_motion(tmp_path / "clip.npy", tmp_path / "clip.fbx")


def test_convert_cmu_take_to_its_humanml3d_features(shared_data, tmp_path):
    take = shared_data / "cmu-bvh" / "131_02.bvh"
    if not take.is_file():
        pytest.skip("CMU BVH takes not found")
    out = convert_motion(take, tmp_path / "001417.npy", start=10, end=208)
    assert np.load(out).shape == (197, 263)  # HumanML3D's clip 001417 is frames 10-208 of this take


def test_atomic_writes_get_ordinary_file_permissions(tmp_path):
    from motionlab.io.common import write_text_atomic

    old = os.umask(0o022)
    try:
        path = write_text_atomic(tmp_path / "out.json", "{}\n")
    finally:
        os.umask(old)
    assert path.read_text() == "{}\n"
    assert stat.S_IMODE(path.stat().st_mode) == 0o644  # not mkstemp's owner-only 0600
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]
