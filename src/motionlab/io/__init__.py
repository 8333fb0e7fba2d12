"""Motion files: BVH import/export and standalone HTML animations.

* :mod:`.bvh` -- the BVH format itself: parse, forward kinematics, write.
* :mod:`.bvh_import` -- a BVH (its rig detected from the joint names, or a joint map) onto the 22 t2m joints
  and HumanML3D features.
* :mod:`.bvh_export` -- t2m joints/features to a BVH rig whose rotations come from inverse kinematics.
* :mod:`.html` -- one offline HTML page with a canvas stick figure.
* :mod:`.files` -- choose by file extension (what the CLI calls).

The CMU takes used in the tests and book come from the CMU Graphics Lab Motion Capture Database
(mocap.cs.cmu.edu). "The data used in this project was obtained from mocap.cs.cmu.edu. The database was
created with funding from NSF EIA-0196217."
"""

from .bvh import Bvh, BvhJoint, bvh_positions, bvh_world_transforms, format_bvh, parse_bvh, read_bvh, write_bvh
from .bvh_export import helper_joints, motion_to_bvh, save_bvh
from .bvh_import import (
    CMU_SCALE,
    CMU_TO_T2M,
    RIGS,
    BvhRig,
    bvh_to_features,
    bvh_to_joints,
    detect_rig,
    fill_degenerate_joints,
    map_joints,
    read_joint_map,
    resample,
    resolve_rig,
)
from .files import MOTION_SUFFIXES, convert_motion, load_joints, save_motion
from .html import html_animation, save_html_animation

__all__ = [
    "CMU_SCALE",
    "CMU_TO_T2M",
    "MOTION_SUFFIXES",
    "RIGS",
    "Bvh",
    "BvhJoint",
    "BvhRig",
    "bvh_positions",
    "bvh_to_features",
    "bvh_to_joints",
    "bvh_world_transforms",
    "convert_motion",
    "detect_rig",
    "fill_degenerate_joints",
    "format_bvh",
    "helper_joints",
    "html_animation",
    "load_joints",
    "map_joints",
    "motion_to_bvh",
    "parse_bvh",
    "read_bvh",
    "read_joint_map",
    "resample",
    "resolve_rig",
    "save_bvh",
    "save_html_animation",
    "save_motion",
    "write_bvh",
]
