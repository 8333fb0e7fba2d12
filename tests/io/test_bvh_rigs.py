"""Which rig a BVH has: detected from its joint names (``mapping="auto"``), or read through a user's joint map.

The CMU take (../shared/data/cmu-bvh, test data only) comes from the CMU Graphics Lab Motion Capture Database.
"The data used in this project was obtained from mocap.cs.cmu.edu. The database was created with funding from
NSF EIA-0196217."
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from motionlab.data.embedded.generator import generate_clip
from motionlab.io import CMU_SCALE, bvh_to_joints, format_bvh, load_joints, motion_to_bvh, parse_bvh, read_bvh
from motionlab.io import bvh_export as bvh_export_module
from motionlab.io.bvh_export import helper_joints, t2m_bvh_rig
from motionlab.io.bvh_import import detect_rig, read_joint_map, resolve_rig
from motionlab.representation import T2M


def _joints(family: str = "walk", n_frames: int = 50):
    return generate_clip(family, np.random.default_rng(1), n_frames=n_frames).joints  # (T, 22, 3) metres


def _renamed(bvh, rename: dict[str, str]):
    text = format_bvh(bvh)
    for old, new in rename.items():
        text = text.replace(f"JOINT {old}\n", f"JOINT {new}\n").replace(f"ROOT {old}\n", f"ROOT {new}\n")
    return parse_bvh(text)


@pytest.mark.parametrize(("unit", "scale"), [("m", 1.0), ("cm", 0.01), ("mm", 0.001)])
def test_our_own_export_is_detected_in_any_unit(unit, scale):
    joints = _joints()
    bvh = motion_to_bvh(joints, unit=unit)
    rig = detect_rig(bvh)
    assert rig.name == "t2m" and rig.scale == scale and rig.up == "y"
    np.testing.assert_allclose(bvh_to_joints(bvh), joints, atol=1e-5)  # the default is "auto"


def test_a_cmu_take_is_detected(shared_data):
    path = shared_data / "cmu-bvh" / "131_03.bvh"
    if not path.is_file():
        pytest.skip("the CMU take is not here")
    bvh = read_bvh(path)
    rig = detect_rig(bvh)
    assert rig.name == "cmu" and rig.scale == CMU_SCALE
    np.testing.assert_allclose(bvh_to_joints(bvh, start=0, end=60), bvh_to_joints(bvh, "cmu", start=0, end=60))


def test_an_unknown_rig_is_named_with_its_joints_and_the_way_out():
    bvh = _renamed(motion_to_bvh(_joints()), {"pelvis": "Hips", "left_knee": "LeftLeg"})
    with pytest.raises(ValueError) as raised:
        bvh_to_joints(bvh)
    message = str(raised.value)
    assert "match no rig motionlab knows (cmu, t2m)" in message
    assert "the closest, 't2m', lacks 2 of its 22 joints (pelvis, left_knee)" in message
    assert "The BVH has 28 joints: Hips, pelvis_to_left_hip" in message and "LeftLeg" in message
    assert "--mapping FILE.json" in message and '{"pelvis": "Hips"' in message and "--scale" in message
    with pytest.raises(ValueError, match="needs the BVH"):
        resolve_rig("auto")


def test_a_joint_map_file_reads_a_renamed_rig(tmp_path):
    joints = _joints("wave")
    rename = {"pelvis": "Hips", "left_knee": "LeftLeg", "head": "Skull"}
    bvh = _renamed(motion_to_bvh(joints, unit="cm"), rename)
    (tmp_path / "rig.bvh").write_text(format_bvh(bvh))
    mapping = {n: rename.get(n, n) for n in T2M.joint_names}
    with_scale = tmp_path / "rig.json"
    with_scale.write_text(json.dumps({"joints": mapping, "scale": 0.01, "up": "y"}))
    np.testing.assert_allclose(load_joints(tmp_path / "rig.bvh", mapping=with_scale), joints, atol=1e-5)
    flat = tmp_path / "flat.json"
    flat.write_text(json.dumps(mapping))
    assert read_joint_map(flat) == (mapping, None, None)
    np.testing.assert_allclose(bvh_to_joints(bvh, mapping=str(flat), scale=0.01), joints, atol=1e-5)
    with pytest.raises(ValueError, match="needs a scale.*--scale"):
        bvh_to_joints(bvh, mapping=flat)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("not json", "not readable as JSON"),
        ("[1, 2]", "expected a JSON object"),
        ('{"pelvis": "Hips"}', "leaves these t2m joints unmapped: left_hip"),
        ('{"joints": {}, "units": "cm"}', "unknown keys units"),
        ('{"joints": {"pelvis": 3}}', "strings"),
        ('{"joints": {}, "scale": "cm"}', "scale must be a number"),
    ],
)
def test_a_bad_joint_map_is_named(tmp_path, content, message):
    path = tmp_path / "rig.json"
    path.write_text(content)
    with pytest.raises(ValueError, match=message):
        read_joint_map(path)
    with pytest.raises(ValueError, match="does not exist"):
        read_joint_map(tmp_path / "none.json")


def test_the_helper_joints_are_the_rigs_and_documented():
    rig = [n.joint for n in t2m_bvh_rig()]
    helpers = helper_joints()
    assert len(helpers) == 6 and all(rig[[j.name for j in rig].index(h)].offset == (0.0, 0.0, 0.0) for h in helpers)
    assert {j.name for j in rig if not j.end_site} == set(T2M.joint_names) | set(helpers)
    for helper in helpers:
        assert helper in bvh_export_module.__doc__
