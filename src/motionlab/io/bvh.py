"""The Biovision Hierarchy (BVH) format: parse, forward kinematics, write.

A BVH file has two sections::

    HIERARCHY
    ROOT Hips                      # a tree of named joints ...
    {
        OFFSET 0 0 0               # ... each placed by an offset in its parent's frame,
        CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
        JOINT Chest { OFFSET ... CHANNELS 3 ... End Site { OFFSET ... } }
    }
    MOTION
    Frames: 2                      # ... and one line of channel values per frame,
    Frame Time: 0.05               # in the order the CHANNELS lines appear in the file.
    0 0.9 0 0 0 0  0 0 0
    ...

Conventions kept here (the ones the format leaves implicit):

* Rotation channels are Euler angles in **degrees**, applied **intrinsically in the order they are listed**:
  ``CHANNELS 3 Zrotation Xrotation Yrotation`` means ``R = Rz(a) @ Rx(b) @ Ry(c)``. Each joint may have
  its own order.
* Position channels give the joint's translation in its parent's frame and **replace** the OFFSET components
  they name (as Blender reads them). Exported files keep the root OFFSET at zero, where both readings agree.
* Forward kinematics: ``W_j = W_parent @ R_j`` and ``p_j = p_parent + W_parent @ t_j`` with ``t_j`` the
  offset (or position channels). A joint's rotation moves its children, not itself.
* An ``End Site`` becomes a joint without channels, named ``<parent>_end`` (``_end2``, ... if several).

Positions come out in the file's own units; converting units and axes is the caller's business (see
:mod:`motionlab.io.bvh_import`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .common import write_text_atomic

AXES = "XYZ"
_CHANNEL_NAMES = {f"{a}{kind}".lower(): f"{a}{kind}" for a in AXES for kind in ("position", "rotation")}


@dataclass(frozen=True)
class BvhJoint:
    """One node of the hierarchy (a joint or an end site)."""

    name: str
    parent: int  # index into Bvh.joints; -1 for the root
    offset: tuple[float, float, float]  # rest translation in the parent's frame
    channels: tuple[str, ...] = ()  # e.g. ("Xposition", ..., "Zrotation"); () for end sites
    end_site: bool = False

    @property
    def rotation_order(self) -> str:
        """The axes of the rotation channels in file order, e.g. ``"ZXY"`` (intrinsic)."""
        return "".join(c[0] for c in self.channels if c.endswith("rotation"))


@dataclass
class Bvh:
    """A parsed BVH file: joints in file (depth-first) order and the raw channel values per frame."""

    joints: tuple[BvhJoint, ...]
    frames: np.ndarray = field(repr=False)  # (T, C) channel values, C = total channel count
    frame_time: float  # seconds per frame

    def __post_init__(self):
        self.joints = tuple(self.joints)
        self.frames = np.asarray(self.frames, dtype=np.float64)
        if not self.joints or self.joints[0].parent != -1:
            raise ValueError("a BVH needs a root joint first (parent -1)")
        ancestors = [0]  # the path from the root to the previous joint: depth-first order keeps columns aligned
        for i, joint in enumerate(self.joints[1:], start=1):
            while ancestors and ancestors[-1] != joint.parent:
                ancestors.pop()
            if not ancestors:
                raise ValueError(f"joints must be in depth-first order; {joint.name!r} (#{i}) is out of place")
            if joint.end_site and joint.channels:
                raise ValueError(f"end site {joint.name!r} cannot have channels")
            if self.joints[joint.parent].end_site:
                raise ValueError(f"{joint.name!r} cannot hang off the end site {self.joints[joint.parent].name!r}")
            ancestors.append(i)
        names = [j.name for j in self.joints]
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"joint names must be unique; repeated: {', '.join(dup)}")
        if self.frames.ndim != 2 or self.frames.shape[1] != self.n_channels:
            raise ValueError(f"frames must have shape (T, {self.n_channels}), got {self.frames.shape}")
        if not np.isfinite(self.frames).all():
            raise ValueError("frames contain NaN or inf values")
        if not (np.isfinite(self.frame_time) and self.frame_time > 0):
            raise ValueError(f"frame_time must be a positive number of seconds, got {self.frame_time}")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def parents(self) -> tuple[int, ...]:
        return tuple(j.parent for j in self.joints)

    @property
    def offsets(self) -> np.ndarray:
        return np.array([j.offset for j in self.joints], dtype=np.float64)  # (N, 3)

    @property
    def n_channels(self) -> int:
        return sum(len(j.channels) for j in self.joints)

    @property
    def n_frames(self) -> int:
        return self.frames.shape[0]

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    def channel_columns(self) -> list[slice]:
        """For each joint, the slice of ``frames`` columns that holds its channels."""
        out, start = [], 0
        for joint in self.joints:
            out.append(slice(start, start + len(joint.channels)))
            start += len(joint.channels)
        return out

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise ValueError(f"the BVH has no joint {name!r}; joints: {', '.join(self.names)}") from None


# ----------------------------------------------------------------------------------------------- parsing


class _Tokens:
    """Whitespace-separated words of the HIERARCHY section, each with its 1-based line number."""

    def __init__(self, lines: list[str]):
        self.words = [(w, n) for n, line in enumerate(lines, start=1) for w in line.split()]
        self.pos = 0

    def peek(self) -> tuple[str, int]:
        last_line = self.words[-1][1] if self.words else 1
        return self.words[self.pos] if self.pos < len(self.words) else ("<end of file>", last_line)

    def take(self, expected: str | None = None) -> tuple[str, int]:
        word, line = self.peek()
        if word == "<end of file>":
            raise ValueError(f"line {line}: unexpected end of file" + (f", expected {expected!r}" if expected else ""))
        if expected is not None and word.upper() != expected.upper():
            raise ValueError(f"line {line}: expected {expected!r}, found {word!r}")
        self.pos += 1
        return word, line

    def number(self, what: str) -> float:
        word, line = self.take()
        try:
            value = float(word)
        except ValueError:
            raise ValueError(f"line {line}: {what} must be a number, found {word!r}") from None
        if not np.isfinite(value):
            raise ValueError(f"line {line}: {what} is not finite ({word!r})")
        return value


def _parse_offset(tokens: _Tokens) -> tuple[float, float, float]:
    tokens.take("OFFSET")
    return tuple(tokens.number(f"OFFSET {a}") for a in AXES)


def _parse_channels(tokens: _Tokens) -> tuple[str, ...]:
    _, line = tokens.take("CHANNELS")
    count = tokens.number("the channel count")
    if count != int(count) or not 0 <= count <= 6:
        raise ValueError(f"line {line}: the channel count must be an integer in 0..6, got {count:g}")
    channels = []
    for _ in range(int(count)):
        word, wline = tokens.take()
        canonical = _CHANNEL_NAMES.get(word.lower())
        if canonical is None:
            raise ValueError(
                f"line {wline}: unknown channel {word!r} (CHANNELS {int(count)} needs {int(count)} names "
                "among Xposition Yposition Zposition Xrotation Yrotation Zrotation)"
            )
        if canonical in channels:
            raise ValueError(f"line {wline}: channel {canonical} listed twice")
        channels.append(canonical)
    return tuple(channels)


def _parse_node(tokens: _Tokens, joints: list[BvhJoint], parent: int, name: str) -> None:
    tokens.take("{")
    offset = _parse_offset(tokens)
    channels = _parse_channels(tokens)
    index = len(joints)
    joints.append(BvhJoint(name, parent, offset, channels))
    n_end_sites = 0
    while True:
        word, line = tokens.peek()
        key = word.upper()
        if word == "<end of file>":
            raise ValueError(f"line {line}: unexpected end of file inside {name!r} (a '}}' is missing)")
        if key == "}":
            tokens.take()
            return
        if key == "JOINT":
            tokens.take()
            child_name, _ = tokens.take()
            _parse_node(tokens, joints, index, child_name)
        elif key == "END":
            tokens.take()
            tokens.take("Site")
            tokens.take("{")
            n_end_sites += 1
            suffix = "_end" if n_end_sites == 1 else f"_end{n_end_sites}"
            joints.append(BvhJoint(name + suffix, index, _parse_offset(tokens), (), end_site=True))
            tokens.take("}")
        else:
            raise ValueError(f"line {line}: expected JOINT, End Site or '}}' inside {name!r}, found {word!r}")


def _parse_motion(lines: list[str], start: int, n_channels: int) -> tuple[np.ndarray, float]:
    # lines[start] is the line after MOTION; returns frames (T, C) and the frame time.
    def header(k: int, label: str) -> tuple[str, int]:
        while k < len(lines) and not lines[k].strip():
            k += 1
        if k >= len(lines):
            raise ValueError(f"line {len(lines)}: unexpected end of file, expected '{label}'")
        text = lines[k].strip()
        if not text.lower().startswith(label.lower()):
            raise ValueError(f"line {k + 1}: expected '{label}', found {text[:40]!r}")
        return text[len(label) :].strip(), k

    value, k = header(start, "Frames:")
    try:
        n_frames = int(value)
    except ValueError:
        raise ValueError(f"line {k + 1}: the frame count must be an integer, found {value!r}") from None
    if n_frames < 0:
        raise ValueError(f"line {k + 1}: the frame count must not be negative, got {n_frames}")
    value, k = header(k + 1, "Frame Time:")
    try:
        frame_time = float(value)
    except ValueError:
        raise ValueError(f"line {k + 1}: the frame time must be a number, found {value!r}") from None
    if not (np.isfinite(frame_time) and frame_time > 0):
        raise ValueError(f"line {k + 1}: the frame time must be positive, got {value!r}")

    rows = [(n, line) for n, line in enumerate(lines[k + 1 :], start=k + 2) if line.strip()]
    if len(rows) != n_frames:
        raise ValueError(f"the header says Frames: {n_frames} but {len(rows)} frame lines follow")
    frames = np.zeros((n_frames, n_channels))
    for t, (n, line) in enumerate(rows):
        words = line.split()
        if len(words) != n_channels:
            raise ValueError(f"line {n}: expected {n_channels} channel values, found {len(words)}")
        try:
            frames[t] = [float(w) for w in words]
        except ValueError:
            bad = next(w for w in words if not _is_float(w))
            raise ValueError(f"line {n}: channel value {bad!r} is not a number") from None
        if not np.isfinite(frames[t]).all():
            raise ValueError(f"line {n}: channel values must be finite")
    return frames, frame_time


def _is_float(word: str) -> bool:
    try:
        float(word)
        return True
    except ValueError:
        return False


def parse_bvh(text: str) -> Bvh:
    """Parse the text of a BVH file. Problems raise ``ValueError`` naming the line."""
    if not isinstance(text, str):
        raise ValueError(f"text must be a str, got {type(text).__name__}")
    lines = text.splitlines()
    motion_at = next((k for k, line in enumerate(lines) if line.strip().upper() == "MOTION"), None)
    if motion_at is None:
        raise ValueError("no MOTION section: a BVH file needs a line 'MOTION' after the hierarchy")
    tokens = _Tokens(lines[:motion_at])
    tokens.take("HIERARCHY")
    _, line = tokens.take("ROOT")
    root_name, _ = tokens.take()
    joints: list[BvhJoint] = []
    _parse_node(tokens, joints, -1, root_name)
    word, line = tokens.peek()
    if word != "<end of file>":
        raise ValueError(f"line {line}: expected MOTION after the root's closing brace, found {word!r}")
    n_channels = sum(len(j.channels) for j in joints)
    frames, frame_time = _parse_motion(lines, motion_at + 1, n_channels)
    return Bvh(tuple(joints), frames, frame_time)


def read_bvh(path: str | os.PathLike) -> Bvh:
    """Read and parse a BVH file (errors name the file and the line)."""
    path = Path(path)
    try:
        return parse_bvh(path.read_text(encoding="utf-8", errors="replace"))
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None


# ------------------------------------------------------------------------------------ forward kinematics


def axis_rotations(axis: str, degrees: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` about ``axis`` ("X", "Y" or "Z") by ``degrees`` ``(...)``."""
    a = np.deg2rad(np.asarray(degrees, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    i, j = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[axis]  # the plane the rotation turns
    k = 3 - i - j
    m = np.zeros(a.shape + (3, 3))
    m[..., k, k] = 1.0
    m[..., i, i], m[..., i, j] = c, -s
    m[..., j, i], m[..., j, j] = s, c
    return m


def bvh_local_transforms(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """Per joint and frame: local rotation matrices ``(T, N, 3, 3)`` and translations ``(T, N, 3)``.

    ``R_j = R_{c1}(a_1) @ R_{c2}(a_2) @ ...`` over the joint's rotation channels in file order (intrinsic).
    """
    n_frames, n_joints = bvh.n_frames, len(bvh.joints)
    rotations = np.broadcast_to(np.eye(3), (n_frames, n_joints, 3, 3)).copy()
    translations = np.broadcast_to(bvh.offsets, (n_frames, n_joints, 3)).copy()
    for j, (joint, cols) in enumerate(zip(bvh.joints, bvh.channel_columns())):
        values = bvh.frames[:, cols]  # (T, channels of this joint)
        for channel, column in zip(joint.channels, values.T):
            axis = AXES.index(channel[0])
            if channel.endswith("position"):
                translations[:, j, axis] = column
            else:
                rotations[:, j] = rotations[:, j] @ axis_rotations(channel[0], column)
    return rotations, translations


def bvh_world_transforms(bvh: Bvh) -> tuple[np.ndarray, np.ndarray]:
    """World rotations ``(T, N, 3, 3)`` and positions ``(T, N, 3)`` of every joint and end site.

    ``W_j = W_parent @ R_j`` and ``p_j = p_parent + W_parent @ t_j``; the root's parent is the identity at
    the origin. Units are the file's.
    """
    local_r, local_t = bvh_local_transforms(bvh)
    world_r, world_p = np.empty_like(local_r), np.empty_like(local_t)
    for j, parent in enumerate(bvh.parents):
        if parent < 0:
            world_r[:, j], world_p[:, j] = local_r[:, j], local_t[:, j]
        else:
            world_r[:, j] = world_r[:, parent] @ local_r[:, j]
            world_p[:, j] = world_p[:, parent] + (world_r[:, parent] @ local_t[:, j, :, None])[..., 0]
    return world_r, world_p


def bvh_positions(bvh: Bvh) -> np.ndarray:
    """World positions ``(T, N, 3)`` of all joints and end sites, in ``bvh.names`` order."""
    return bvh_world_transforms(bvh)[1]


# ------------------------------------------------------------------------------------------------ writing


def format_bvh(bvh: Bvh, precision: int = 6) -> str:
    """The text of a BVH file (tabs for indentation, one frame per line, ``precision`` decimals)."""
    children: dict[int, list[int]] = {j: [] for j in range(len(bvh.joints))}
    for j, parent in enumerate(bvh.parents):
        if parent >= 0:
            children[parent].append(j)

    def fmt(values) -> str:
        return " ".join(f"{v:.{precision}f}" for v in values)

    out = ["HIERARCHY"]

    def node(j: int, depth: int) -> None:
        tab, joint = "\t" * depth, bvh.joints[j]
        if joint.end_site:
            out.extend([f"{tab}End Site", f"{tab}{{", f"{tab}\tOFFSET {fmt(joint.offset)}", f"{tab}}}"])
            return
        out.append(f"{tab}{'ROOT' if joint.parent < 0 else 'JOINT'} {joint.name}")
        out.append(f"{tab}{{")
        out.append(f"{tab}\tOFFSET {fmt(joint.offset)}")
        out.append(f"{tab}\tCHANNELS {len(joint.channels)} {' '.join(joint.channels)}".rstrip())
        for child in children[j]:
            node(child, depth + 1)
        out.append(f"{tab}}}")

    node(0, 0)
    out += ["MOTION", f"Frames: {bvh.n_frames}", f"Frame Time: {bvh.frame_time:.10g}"]
    out += [fmt(row) for row in bvh.frames]
    return "\n".join(out) + "\n"


def write_bvh(bvh: Bvh, path: str | os.PathLike, precision: int = 6) -> Path:
    """Write ``bvh`` to ``path`` atomically (temporary file + ``os.replace``)."""
    for joint in bvh.joints:
        if not joint.name or any(ch.isspace() for ch in joint.name) or joint.name in ("{", "}"):
            raise ValueError(f"joint name {joint.name!r} cannot be written to BVH (no spaces or braces)")
    return write_text_atomic(path, format_bvh(bvh, precision))
