"""The BVH format on small hand-written files: parsing, forward kinematics, writing, errors."""

from __future__ import annotations

import numpy as np
import pytest

from motionlab.io import Bvh, BvhJoint, bvh_positions, bvh_world_transforms, format_bvh, parse_bvh, write_bvh
from motionlab.io.bvh import axis_rotations
from motionlab.representation import euler_to_quat, qrot, quat_to_matrix

# A root with 6 channels (ZXY), a 3-channel chain (XYZ, then ZYX) ending in an End Site, and a 6-channel
# non-root joint whose position channels replace its offset.
TWO_ARMS = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Arm
  {
    OFFSET 1 0 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    JOINT Hand
    {
      OFFSET 0 -2 0
      CHANNELS 3 Zrotation Yrotation Xrotation
      End Site
      {
        OFFSET 0 -0.5 0
      }
    }
  }
  JOINT Slider
  {
    OFFSET 0 5 0
    CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation
    End Site
    {
      OFFSET 0 0 1
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.05
0 0 0  0 0 0   0 0 0   0 0 0   0 5 0 0 0 0
1 2 3  90 0 0  0 0 0   0 0 0   0 7 0 0 0 0
0.5 1 0  10 20 30  40 50 60  70 80 90  -1 2 0.5 15 25 35
"""


def test_hierarchy_names_parents_channels():
    bvh = parse_bvh(TWO_ARMS)
    assert bvh.names == ("Hips", "Arm", "Hand", "Hand_end", "Slider", "Slider_end")
    assert bvh.parents == (-1, 0, 1, 2, 0, 4)
    assert bvh.joints[3].end_site and bvh.joints[3].channels == ()
    assert [j.rotation_order for j in bvh.joints] == ["ZXY", "XYZ", "ZYX", "", "YXZ", ""]
    assert bvh.n_channels == 18 and bvh.frames.shape == (3, 18)
    assert bvh.fps == pytest.approx(20.0)
    np.testing.assert_allclose(bvh.offsets[3], [0, -0.5, 0])


def test_rest_frame_is_the_sum_of_offsets():
    # Frame 0 has zero rotations, and the Slider's position channels repeat its OFFSET.
    p = bvh_positions(parse_bvh(TWO_ARMS))[0]
    np.testing.assert_allclose(p, [[0, 0, 0], [1, 0, 0], [1, -2, 0], [1, -2.5, 0], [0, 5, 0], [0, 5, 1]])


def test_root_translation_rotation_and_position_channels_by_hand():
    p = bvh_positions(parse_bvh(TWO_ARMS))[1]
    # Root at (1, 2, 3) turned 90 degrees about Z: x -> y, y -> -x.
    np.testing.assert_allclose(p[1], [1, 3, 3], atol=1e-12)
    np.testing.assert_allclose(p[2], [3, 3, 3], atol=1e-12)  # (0, -2, 0) -> (2, 0, 0)
    # The Slider's position channels (0, 7, 0) replace its OFFSET (0, 5, 0).
    np.testing.assert_allclose(p[4], [1 - 7, 2, 3], atol=1e-12)


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "ZYX", "YZX"])
def test_rotation_channels_are_intrinsic_in_channel_order(order):
    rng = np.random.default_rng(0)
    angles = rng.uniform(-170, 170, size=(5, 3))
    text = (
        "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 " + " ".join(f"{a}rotation" for a in order) + "\n"
        "End Site\n{\nOFFSET 0.3 -1 2\n}\n}\nMOTION\nFrames: 5\nFrame Time: 0.0083333\n"
        + "\n".join(" ".join(f"{v:.9f}" for v in row) for row in angles)
    )
    bvh = parse_bvh(text)
    world_r, world_p = bvh_world_transforms(bvh)
    q = euler_to_quat(angles, order=order, degrees=True)  # the project's intrinsic convention
    np.testing.assert_allclose(world_r[:, 0], quat_to_matrix(q), atol=1e-9)
    np.testing.assert_allclose(world_p[:, 1], qrot(q, np.broadcast_to([0.3, -1, 2], (5, 3))), atol=1e-9)
    # and explicitly R = R_a @ R_b @ R_c
    manual = axis_rotations(order[0], angles[:, 0]) @ axis_rotations(order[1], angles[:, 1])
    np.testing.assert_allclose(world_r[:, 0], manual @ axis_rotations(order[2], angles[:, 2]), atol=1e-9)


def test_parent_rotation_moves_children_not_itself():
    p = bvh_positions(parse_bvh(TWO_ARMS))[2]
    bvh = parse_bvh(TWO_ARMS)
    r = bvh_world_transforms(bvh)[0][2]
    # Arm's own position depends on the root only; Hand's on Arm's rotation.
    np.testing.assert_allclose(p[1], p[0] + r[0] @ [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(p[2], p[1] + r[1] @ [0, -2, 0], atol=1e-12)
    np.testing.assert_allclose(p[3], p[2] + r[2] @ [0, -0.5, 0], atol=1e-12)


def test_format_then_parse_is_identity():
    bvh = parse_bvh(TWO_ARMS)
    again = parse_bvh(format_bvh(bvh))
    assert again.joints == bvh.joints
    np.testing.assert_allclose(again.frames, bvh.frames, atol=1e-6)
    assert again.frame_time == bvh.frame_time


def test_tolerant_spacing_case_and_several_end_sites():
    text = (
        "HIERARCHY\r\nROOT a {\r\n\tOFFSET 0 0 0\r\n\tCHANNELS 3 zrotation XROTATION Yrotation\r\n"
        "\tEnd Site { OFFSET 1 0 0 }\r\n\tEnd Site { OFFSET 0 1 0 }\r\n}\r\nMOTION\r\nFrames: 1\r\n"
        "Frame Time: 0.1\r\n0 0 0\r\n\r\n"
    )
    bvh = parse_bvh(text)
    assert bvh.names == ("a", "a_end", "a_end2")
    assert bvh.joints[0].channels == ("Zrotation", "Xrotation", "Yrotation")


BAD = {
    "no motion": ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\n", "no MOTION"),
    "no hierarchy": ("ROOT a\n{\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n", "line 1: expected 'HIERARCHY'"),
    "offset not a number": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 x 0\nCHANNELS 0\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n",
        "line 4: OFFSET Y must be a number",
    ),
    "unknown channel": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Wrotation\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n",
        "line 5: unknown channel 'Wrotation'",
    ),
    "too few channel names": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Xrotation Yrotation\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n",
        "line 6: unknown channel '}'",
    ),
    "missing brace": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nJOINT b\n{\nOFFSET 0 1 0\nCHANNELS 0\n}\n"
        "MOTION\nFrames: 0\nFrame Time: 0.1\n",
        "line 10: unexpected end of file",
    ),
    "stray keyword": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nBONE b\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n",
        "line 6: expected JOINT, End Site or '}'",
    ),
    "frame count mismatch": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 3\nFrame Time: 0.1\n1\n2\n",
        "Frames: 3 but 2 frame lines",
    ),
    "short frame line": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Yrotation\n}\nMOTION\nFrames: 2\n"
        "Frame Time: 0.1\n1 2\n3\n",
        "line 11: expected 2 channel values, found 1",
    ),
    "non-numeric value": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\nabc\n",
        "line 10: channel value 'abc' is not a number",
    ),
    "nan value": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\nnan\n",
        "line 10: channel values must be finite",
    ),
    "bad frame time": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrames: 0\nFrame Time: 0\n",
        "line 9: the frame time must be positive",
    ),
    "missing frames header": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrame Time: 0.1\n",
        "line 8: expected 'Frames:'",
    ),
    "duplicate channel": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation xrotation\n}\nMOTION\nFrames: 0\nFrame Time: 0.1\n",
        "line 5: channel Xrotation listed twice",
    ),
    "duplicate names": (
        "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nJOINT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\n}\n"
        "MOTION\nFrames: 0\nFrame Time: 0.1\n",
        "repeated: a",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_files_raise_naming_the_problem(case):
    text, message = BAD[case]
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse_bvh(text)


def test_read_error_names_the_file(tmp_path):
    path = tmp_path / "broken.bvh"
    path.write_text(BAD["short frame line"][0])
    from motionlab.io import read_bvh

    with pytest.raises(ValueError, match=r"broken\.bvh: line 11"):
        read_bvh(path)


def test_bvh_object_validates_its_fields():
    root = BvhJoint("r", -1, (0.0, 0.0, 0.0), ("Xrotation",))
    with pytest.raises(ValueError, match=r"frames must have shape \(T, 1\)"):
        Bvh((root,), np.zeros((2, 3)), 0.1)
    with pytest.raises(ValueError, match="frame_time"):
        Bvh((root,), np.zeros((2, 1)), -1.0)
    with pytest.raises(ValueError, match="depth-first"):
        Bvh(
            (
                root,
                BvhJoint("a", 0, (1, 0, 0)),
                BvhJoint("b", 1, (1, 0, 0)),
                BvhJoint("c", 1, (1, 0, 0)),
                BvhJoint("d", 2, (1, 0, 0)),
            ),
            np.zeros((1, 1)),
            0.1,
        )


def test_write_is_atomic(tmp_path, monkeypatch):
    bvh = parse_bvh(TWO_ARMS)
    target = tmp_path / "out.bvh"
    target.write_text("old contents")

    def explode(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr("motionlab.io.common.os.replace", explode)
    with pytest.raises(RuntimeError, match="disk full"):
        write_bvh(bvh, target)
    assert target.read_text() == "old contents"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.bvh"]  # no temporary file left behind
    monkeypatch.undo()
    write_bvh(bvh, target)
    assert parse_bvh(target.read_text()).names == bvh.names
    with pytest.raises(ValueError, match="does not exist"):
        write_bvh(bvh, tmp_path / "missing" / "x.bvh")
