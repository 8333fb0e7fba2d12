"""BVH motion capture -> the 22 HumanML3D (t2m) joints -> HumanML3D features.

The steps, each a function below::

    bvh --forward kinematics--> all joints (T_src, N, 3), file units, file axes
        --resample to fps (linear in time)--> (T, N, 3)
        --pick 22 joints by name--> (T, 22, 3)
        --scale to metres, turn to Y-up--> ...
        --crop [start, end)--> (T', 22, 3)
        --place joints that coincide with their parent--> joints (T', 22, 3)
        --joints_to_features (retarget, floor, face +Z)--> features (T'-1, 263)

Conventions:

* **Rigs.** ``mapping`` names the BVH joint that plays each of the 22 t2m joints. ``"auto"`` (the default)
  picks the preset of :data:`RIGS` whose joint names the file has: ``"t2m"`` (the t2m names, as in the files
  :func:`~motionlab.io.bvh_export.save_bvh` and ``motionlab generate ... --out x.bvh`` write) or ``"cmu"``. Any
  other rig needs its own joint map: a dict, or a ``.json`` file (:func:`read_joint_map`) holding
  ``{"pelvis": "Hips", "left_hip": "LeftUpLeg", ...}`` for all 22 t2m joints, or
  ``{"joints": {...}, "scale": 0.01, "up": "y"}`` with its units and up axis.
* **Units.** ``scale`` is metres per file unit. CMU's files use their own unit: ``CMU_SCALE = 0.056444``
  (a standing root is then ~0.96 m high). A file detected as ``"t2m"`` gets its unit from its bone offsets
  (metres, centimetres or millimetres, as ``save_bvh(unit=...)`` writes them).
* **Axes.** HumanML3D is Y-up and right-handed; ``up="y"`` (BVH's usual convention, CMU's too) keeps the
  axes, ``up="z"`` turns Z-up data by -90 degrees about X, ``(x, y, z) -> (x, z, -y)``. Both are proper
  rotations, so the subject's left stays left. The horizontal facing is left as in the file:
  ``joints_to_features`` turns frame 0 to face +Z (CMU's takes already face +Z, left side at +X).
* **Resampling.** World positions are interpolated linearly at times ``k / fps``; when the source rate is a
  multiple of ``fps`` (120 -> 20 for CMU) this is exactly HumanML3D's decimation ``[::6]``. The source rate
  is ``1 / Frame Time``, snapped to the nearest integer when within 1e-4 of it (files print ``.0083333``).
* **Cropping.** HumanML3D cuts each take to ``[start_frame, end_frame)`` at 20 fps (its ``index.csv``);
  ``start``/``end`` here do the same, so a converted take has the frame count of its HumanML3D clip:
  ``end - start`` poses and ``end - start - 1`` feature rows, as in ``new_joint_vecs``.
* **Floor check.** With the head below or level with the ankles in most frames, the chosen ``up`` is
  probably wrong (a Y-up file read with ``up="z"`` lies flat): a :class:`~motionlab.io.common.MotionWarning`
  says so, and names the other axis when the body would stand on it.
* **Degenerate joints.** Some rigs put several joints at one point (CMU: ``lowerback`` on ``Hips``; the
  collars on ``Chest2``). A t2m joint that stays within ``1e-4 m`` of its t2m parent is placed at
  ``parent + fill * (child - parent)``, on the segment to its next joint along the chain; otherwise the
  bone would have no direction and inverse kinematics would fail.

The bundled CMU takes come from the CMU Graphics Lab Motion Capture Database (mocap.cs.cmu.edu). Requested
acknowledgement: "The data used in this project was obtained from mocap.cs.cmu.edu. The database was created
with funding from NSF EIA-0196217."
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..representation import T2M, Skeleton
from .bvh import Bvh, bvh_positions, read_bvh
from .common import checked_features, warn

CMU_SCALE = 0.056444  # metres per unit of the CMU BVH release

# t2m joint -> joint of the CMU BVH skeleton ("3ds Max friendly" release), in t2m order.
CMU_TO_T2M: dict[str, str] = dict(
    zip(
        T2M.joint_names,
        (
            "Hips",
            "LeftHip",
            "RightHip",
            "lowerback",
            "LeftKnee",
            "RightKnee",
            "Chest",
            "LeftAnkle",
            "RightAnkle",
            "Chest2",
            "LeftToe",
            "RightToe",
            "Neck",
            "LeftCollar",
            "RightCollar",
            "Head",
            "LeftShoulder",
            "RightShoulder",
            "LeftElbow",
            "RightElbow",
            "LeftWrist",
            "RightWrist",
        ),
    )
)


@dataclass(frozen=True)
class BvhRig:
    """How to read one family of BVH files: joint names onto t2m, metres per unit, up axis."""

    name: str
    joint_map: Mapping[str, str]  # t2m joint name -> BVH joint name
    scale: float  # metres per file unit
    up: str = "y"


RIGS: dict[str, BvhRig] = {
    "cmu": BvhRig("cmu", CMU_TO_T2M, CMU_SCALE, "y"),
    # Files written by motionlab.io.bvh_export (unit="m"): joints carry the t2m names.
    "t2m": BvhRig("t2m", {n: n for n in T2M.joint_names}, 1.0, "y"),
}

AUTO = "auto"  # detect the rig from the BVH's joint names
MAPPINGS = (AUTO, *RIGS)  # the names ``mapping`` takes (besides a dict or a .json file)
FILE_UNITS = {1.0: "m", 0.01: "cm", 0.001: "mm"}  # metres per unit of the units an exported t2m BVH may use

_Y_UP = {"y": np.eye(3), "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])}
DEGENERATE_TOLERANCE = 1e-4  # metres: closer than this to its parent in every frame = "the same point"


def source_fps(frame_time: float) -> float:
    """Frames per second of a BVH, snapped to an integer when the printed frame time was rounded."""
    fps = 1.0 / frame_time
    return float(round(fps)) if abs(fps - round(fps)) < 1e-4 * fps else fps


def resample(positions: np.ndarray, src_fps: float, fps: float) -> np.ndarray:
    """Positions ``(T, ...)`` sampled at ``src_fps`` -> ``(T', ...)`` at ``fps``, linear in time.

    Output frame ``k`` is at time ``k / fps``, i.e. at source index ``s = k * src_fps / fps``:
    ``x(s) = (1 - w) x[floor s] + w x[floor s + 1]`` with ``w = s - floor s``. ``T' = floor((T-1) fps/src) + 1``.
    """
    if not (src_fps > 0 and fps > 0):
        raise ValueError(f"frame rates must be positive, got src_fps={src_fps}, fps={fps}")
    n_src = positions.shape[0]
    ratio = src_fps / fps
    n_out = int(np.floor((n_src - 1) / ratio + 1e-9)) + 1
    s = np.arange(n_out) * ratio
    lo = np.minimum(np.floor(s + 1e-9).astype(int), n_src - 1)
    hi = np.minimum(lo + 1, n_src - 1)
    w = np.clip(s - lo, 0.0, 1.0).reshape((-1,) + (1,) * (positions.ndim - 1))
    return (1.0 - w) * positions[lo] + w * positions[hi]


def map_joints(
    names: tuple[str, ...], positions: np.ndarray, mapping: Mapping[str, str], skeleton: Skeleton = T2M
) -> np.ndarray:
    """Pick the skeleton's joints ``(T, J, 3)`` out of ``positions (T, N, 3)`` by name.

    ``mapping`` sends each target joint name (e.g. ``"left_knee"``) to a source joint name (``"LeftKnee"``).
    """
    unknown = sorted(set(mapping) - set(skeleton.joint_names))
    if unknown:
        raise ValueError(f"mapping names joints that {skeleton.name} does not have: {', '.join(unknown)}")
    missing = [n for n in skeleton.joint_names if n not in mapping]
    if missing:
        raise ValueError(f"mapping leaves these {skeleton.name} joints unmapped: {', '.join(missing)}")
    absent = [f"{t} -> {mapping[t]!r}" for t in skeleton.joint_names if mapping[t] not in names]
    if absent:
        raise ValueError(
            f"the BVH lacks the joints mapped to these {skeleton.name} joints: {'; '.join(absent)}. "
            f"BVH joints: {', '.join(names)}"
        )
    return positions[:, [names.index(mapping[t]) for t in skeleton.joint_names]]


def fill_degenerate_joints(
    joints: np.ndarray, skeleton: Skeleton = T2M, fill: float = 0.5, tolerance: float = DEGENERATE_TOLERANCE
) -> tuple[np.ndarray, list[str]]:
    """Move joints that coincide with their parent onto the segment towards their next joint.

    Returns the repaired joints ``(T, J, 3)`` and the names of the joints that were moved. A bone that
    still has zero length afterwards (two stacked degenerate joints, a degenerate end joint) raises.
    """
    joints = joints.copy()
    parents = skeleton.parents
    next_joint: dict[int, int] = {}
    for chain in skeleton.chains:
        for a, b in zip(chain[:-1], chain[1:]):
            next_joint.setdefault(a, b)
    order = [j for chain in skeleton.chains for j in chain[1:]]  # parents are always placed first
    moved = []
    for j in order:
        p = parents[j]
        if np.linalg.norm(joints[:, j] - joints[:, p], axis=-1).max() < tolerance and j in next_joint:
            joints[:, j] = joints[:, p] + fill * (joints[:, next_joint[j]] - joints[:, p])
            moved.append(skeleton.joint_names[j])
    for j in order:
        shortest = np.linalg.norm(joints[:, j] - joints[:, parents[j]], axis=-1).min()
        if shortest < tolerance:
            raise ValueError(
                f"bone {skeleton.joint_names[parents[j]]} -> {skeleton.joint_names[j]} has (near) zero length "
                f"({shortest:.2g} m) even after placing degenerate joints; check the mapping"
            )
    return joints, moved


UPRIGHT = 0.5  # the head counts as "above the feet" when its offset from them points this much upwards


def uprightness(joints: np.ndarray, skeleton: Skeleton = T2M) -> float:
    """Median over frames of the vertical (y) component of the unit vector from the ankles' midpoint to the
    head: about 1 standing, 0 lying flat, -1 upside down."""
    names = skeleton.joint_names
    head = joints[:, names.index("head")]
    feet = joints[:, [names.index("left_ankle"), names.index("right_ankle")]].mean(axis=1)
    v = head - feet  # (T, 3)
    norm = np.linalg.norm(v, axis=-1)
    return float(np.median(v[:, 1] / np.maximum(norm, 1e-9)))


def _check_floor(joints_file_axes: np.ndarray, up: str, source: str) -> None:
    """Warn when the body does not stand on the floor the chosen ``up`` axis implies (``joints_file_axes``
    in the file's own axes, metres)."""
    score = uprightness(joints_file_axes @ _Y_UP[up].T)
    if score >= UPRIGHT:
        return
    other = "y" if up == "z" else "z"
    hint = ""
    if uprightness(joints_file_axes @ _Y_UP[other].T) >= UPRIGHT:
        hint = f"; with up={other!r} it stands upright (--up {other})"
    warn(
        f"{source}: with up={up!r} the head is not above the feet in most frames (the body lies flat or "
        f"upside down){hint}"
    )


def read_joint_map(path: str | os.PathLike) -> tuple[dict[str, str], float | None, str | None]:
    """A user's joint map from a JSON file: ``(t2m joint -> BVH joint, scale or None, up or None)``.

    The file holds either the map itself, ``{"pelvis": "Hips", "left_hip": "LeftUpLeg", ...}`` (all 22 t2m
    joints), or ``{"joints": {...}, "scale": 0.01, "up": "y"}`` where ``scale`` (metres per file unit) and
    ``up`` are optional. Problems raise ``ValueError`` naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"joint map {str(path)!r} does not exist")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise ValueError(f"joint map {path}: not readable as JSON ({err})") from None
    if not isinstance(data, dict):
        raise ValueError(f"joint map {path}: expected a JSON object of t2m joint name -> BVH joint name")
    scale = up = None
    if "joints" in data:
        extra = sorted(set(data) - {"joints", "scale", "up"})
        if extra:
            raise ValueError(f"joint map {path}: unknown keys {', '.join(extra)} (expected joints, scale, up)")
        scale, up, data = data.get("scale"), data.get("up"), data["joints"]
        if scale is not None and (isinstance(scale, bool) or not isinstance(scale, (int, float))):
            raise ValueError(f"joint map {path}: scale must be a number (metres per file unit), got {scale!r}")
        if up is not None and not isinstance(up, str):
            raise ValueError(f'joint map {path}: up must be "y" or "z", got {up!r}')
    if not isinstance(data, dict) or not all(isinstance(v, str) for v in data.values()):
        raise ValueError(f"joint map {path}: the joints must map t2m joint names to BVH joint names (strings)")
    unknown = sorted(set(data) - set(T2M.joint_names))
    missing = [n for n in T2M.joint_names if n not in data]
    if unknown or missing:
        problems = ([f"names joints t2m does not have: {', '.join(unknown)}"] if unknown else []) + (
            [f"leaves these t2m joints unmapped: {', '.join(missing)}"] if missing else []
        )
        raise ValueError(
            f"joint map {path} {'; '.join(problems)}. Its keys are the 22 t2m joints: {', '.join(T2M.joint_names)}"
        )
    return dict(data), (None if scale is None else float(scale)), up


def _is_map_file(mapping) -> bool:
    return isinstance(mapping, os.PathLike) or (isinstance(mapping, str) and mapping.lower().endswith(".json"))


def _file_units(bvh: Bvh, joint_map: Mapping[str, str]) -> float:
    """Metres per file unit of a BVH with t2m bones: its t2m bones' rest lengths against the t2m skeleton's,
    snapped to metres, centimetres or millimetres when within 25% of one."""
    names = bvh.names
    lengths = np.linalg.norm(bvh.offsets, axis=-1)
    ours = sum(lengths[names.index(joint_map[n])] for n in T2M.joint_names[1:])
    if not ours > 0:
        return 1.0
    scale = float(np.linalg.norm(T2M.offsets[1:], axis=-1).sum() / ours)
    near = min(FILE_UNITS, key=lambda unit: abs(np.log(scale / unit)))
    return near if abs(np.log(scale / near)) < np.log(1.25) else scale


def detect_rig(bvh: Bvh, source: str = "the BVH") -> BvhRig:
    """The preset of :data:`RIGS` whose joint names ``bvh`` has (all 22 of its mapped joints).

    A file with t2m names gets its unit from its bone offsets (:data:`FILE_UNITS`). A file that matches no
    preset raises ``ValueError`` listing the joints it has, what the closest preset lacks, and how to give a
    joint map (``--mapping FILE.json``).
    """
    have = set(bvh.names)
    missing = {name: [b for b in rig.joint_map.values() if b not in have] for name, rig in RIGS.items()}
    for name, rig in RIGS.items():
        if not missing[name]:
            return BvhRig(name, rig.joint_map, _file_units(bvh, rig.joint_map) if name == "t2m" else rig.scale, rig.up)
    closest = min(RIGS, key=lambda name: len(missing[name]))
    lacks = missing[closest]
    joints = [j.name for j in bvh.joints if not j.end_site]
    example = json.dumps({n: joints[0] if n == "pelvis" else "..." for n in T2M.joint_names[:3]})
    raise ValueError(
        f"{source}: its joint names match no rig motionlab knows ({', '.join(RIGS)}); the closest, {closest!r}, "
        f"lacks {len(lacks)} of its 22 joints ({', '.join(lacks[:6])}{', ...' if len(lacks) > 6 else ''}). "
        f"The BVH has {len(joints)} joints: {', '.join(joints)}. Give its joint map as --mapping FILE.json, "
        f"a JSON object from each of the 22 t2m joints ({', '.join(T2M.joint_names)}) to one of these joints, "
        f"e.g. {example[:-1]}, ...}}, with --scale (metres per file unit)"
    )


def resolve_rig(
    mapping: str | os.PathLike | Mapping[str, str] = AUTO,
    scale: float | None = None,
    up: str | None = None,
    bvh: Bvh | None = None,
    source: str = "the BVH",
) -> BvhRig:
    """A :class:`BvhRig` from ``mapping``: ``"auto"`` (detected from ``bvh``'s joint names, :func:`detect_rig`),
    a preset name (``"cmu"``, ``"t2m"``), a dict t2m -> BVH joint name, or a ``.json`` joint-map file
    (:func:`read_joint_map`).

    ``scale``/``up`` override the rig's (or the file's); a custom map needs a scale, from the file or ``scale``
    (units are not guessed).
    """
    check_scale_up(scale, up)
    if _is_map_file(mapping):
        joints, file_scale, file_up = read_joint_map(mapping)
        name = Path(mapping).name
        if scale is None and file_scale is None:
            raise ValueError(
                f"the joint map {name} needs a scale (metres per file unit: 0.01 for centimetres, 1 for metres): "
                'give --scale, or "scale" in the file beside "joints"'
            )
        rig = BvhRig(f"custom ({name})", joints, file_scale if file_scale is not None else 1.0, file_up or "y")
    elif isinstance(mapping, str):
        if mapping.lower() == AUTO:
            if bvh is None:
                raise ValueError("mapping 'auto' detects the rig from a BVH's joint names: it needs the BVH")
            rig = detect_rig(bvh, source)
        elif mapping.lower() in RIGS:
            rig = RIGS[mapping.lower()]
        else:
            raise ValueError(
                f"unknown BVH rig {mapping!r}; presets: {', '.join(MAPPINGS)}, or a .json joint map file "
                "(in Python also a dict)"
            )
    elif isinstance(mapping, Mapping):
        if scale is None:
            raise ValueError("a custom mapping needs scale= (metres per file unit; CMU uses 0.056444, cm files 0.01)")
        rig = BvhRig("custom", dict(mapping), scale)
    else:
        raise ValueError(f"mapping must be a preset name or a dict of t2m -> BVH joint names, got {type(mapping)}")
    scale = rig.scale if scale is None else float(scale)
    up = rig.up if up is None else str(up).lower().lstrip("+")
    check_scale_up(scale, up)
    return BvhRig(rig.name, rig.joint_map, scale, up)


def check_scale_up(scale: float | None, up: str | None) -> None:
    """Refuse a ``scale`` that is not a positive number and an ``up`` other than ``"y"``/``"z"`` (None: unset)."""
    if scale is not None:
        try:
            value = float(scale)
        except (TypeError, ValueError):
            raise ValueError(f"scale (metres per file unit) must be a positive number, got {scale!r}") from None
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"scale (metres per file unit) must be positive, got {scale}")
    if up is not None and str(up).lower().lstrip("+") not in _Y_UP:
        raise ValueError(f"up must be 'y' or 'z' (the file's up axis), got {up!r}")


def bvh_to_joints(
    bvh: Bvh | str | os.PathLike,
    mapping: str | os.PathLike | Mapping[str, str] = AUTO,
    scale: float | None = None,
    up: str | None = None,
    fps: float = 20.0,
    start: int = 0,
    end: int | None = None,
    fill: float = 0.5,
) -> np.ndarray:
    """The 22 t2m joints ``(T, 22, 3)`` in metres, Y-up, at ``fps``, of a BVH (object or file path).

    ``mapping`` is ``"auto"`` (the rig detected from the joint names, :func:`detect_rig`), a preset of
    :data:`RIGS` (``"cmu"``: CMU names and units; ``"t2m"``: files written by
    :func:`~motionlab.io.bvh_export.save_bvh`), a dict t2m name -> BVH joint name, or a ``.json`` file holding
    one (:func:`read_joint_map`); ``scale`` (metres per file unit) and ``up`` (``"y"`` or ``"z"``) override the
    rig's. ``start``/``end`` crop frames at
    ``fps`` (``end=None``: to the last frame). The skeleton keeps the BVH's own proportions;
    :func:`bvh_to_features` retargets.
    """
    source = "the BVH"
    if not isinstance(bvh, Bvh):
        source = os.path.basename(os.fspath(bvh))
        bvh = read_bvh(bvh)
    rig = resolve_rig(mapping, scale, up, bvh, source)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps}")
    if not 0.0 < fill < 1.0:
        raise ValueError(f"fill must lie strictly between 0 and 1, got {fill}")
    if bvh.n_frames < 1:
        raise ValueError("the BVH has no frames")

    positions = resample(bvh_positions(bvh), source_fps(bvh.frame_time), fps)  # (T, N, 3) file units
    raw = map_joints(bvh.names, positions, rig.joint_map) * rig.scale  # (T, 22, 3) metres, the file's axes
    _check_floor(raw, rig.up, source)
    joints = raw @ _Y_UP[rig.up].T

    n = joints.shape[0]
    end = n if end is None else end
    if not all(isinstance(v, (int, np.integer)) for v in (start, end)):
        raise ValueError(f"start and end must be integers (frames at {fps:g} fps), got {start!r}, {end!r}")
    if not (0 <= start < end <= n):
        raise ValueError(f"crop [start, end) = [{start}, {end}) must lie within the {n} frames at {fps:g} fps")
    joints = joints[start:end]
    joints, _ = fill_degenerate_joints(joints, T2M, fill)
    return joints


def bvh_to_features(bvh: Bvh | str | os.PathLike, **kwargs) -> np.ndarray:
    """HumanML3D features ``(T-1, 263)`` of a BVH: :func:`bvh_to_joints` then ``joints_to_features``.

    Keyword arguments are those of :func:`bvh_to_joints`. ``joints_to_features`` retargets to the t2m
    target skeleton, puts the lowest joint on the floor (y = 0), the root at the origin and frame 0
    facing +Z.
    """
    joints = bvh_to_joints(bvh, **kwargs)
    if joints.shape[0] < 2:
        raise ValueError(f"features need at least 2 frames, the crop leaves {joints.shape[0]}")
    return checked_features(joints, T2M, name="the BVH")
