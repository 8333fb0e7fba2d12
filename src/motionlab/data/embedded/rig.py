"""From authored joint angles to joint positions: local rotations, forward kinematics, feet on the floor.

Three steps turn a :class:`Plan` into a ``(T, 22, 3)`` motion in metres:

1. **Rotations.** Each bone has a rest rotation ``W_c`` taking its raw HumanML3D offset (arms hang along
   -y, feet point +z, the head bone points +z) onto a natural standing pose. An authored rotation ``A_c``
   (body axes) acts on the bone as if everything above it were at rest, and the parent's motion carries it:
   ``G_c = G_p W_p^-1 A_c W_c`` with ``G_0 = yaw * A_0``. Forward kinematics wants rotations relative to
   the previous joint of each *chain*, so ``local_c = G_q^-1 G_c``; ``q`` is the root for the arm chains,
   which HumanML3D starts from the root rotation although they hang off spine3.
2. **Forward kinematics** with the target offsets (constant bone lengths by construction), root at x = z = 0.
3. **Root placement.** Height: the lowest foot joint (a soft minimum, so the root moves smoothly when the
   support switches feet) touches y = 0, plus the plan's ballistic ``lift``. Horizontal: the root moves
   opposite to the feet's horizontal velocity, weighted toward the lowest foot, ``v_root = -sum_f w_f v_f``
   with ``w = softmax(-y_f / tau)``, so the stance foot does not slide and walking *emerges* from the leg
   swing. While ``airborne`` the root coasts with the plan's velocity instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.special import logsumexp, softmax

from motionlab.representation import T2M, forward_kinematics, qbetween, qinv, qmul, qrot

from .body import FPS, N_JOINTS

FOOT_JOINTS = (7, 10, 8, 11)  # left ankle, left foot, right ankle, right foot
SOFT_MIN_TAU = 0.01  # metres: how sharply the support switches to the lowest foot joint
_UP = np.array([0.0, 1.0, 0.0])


@dataclass
class Plan:
    """An authored motion, before kinematics. ``T`` frames at 20 fps."""

    angles: np.ndarray  # (T, 22, 3) body-axis joint angles in radians (see body.py)
    yaw: np.ndarray  # (T,) heading about +y in radians; positive turns to the left
    lift: np.ndarray  # (T,) metres of root height above the foot-contact height (jumps, running flight)
    airborne: np.ndarray  # (T,) in [0, 1]: 1 = no foot supports the body, the root coasts
    coast: np.ndarray  # (T, 3) body-frame root velocity in m/s while airborne; NaN rows = keep the stance pace

    def __post_init__(self):
        n = len(self.angles)
        if self.angles.shape != (n, N_JOINTS, 3):
            raise ValueError(f"angles must have shape (T, {N_JOINTS}, 3), got {self.angles.shape}")
        for name, shape in (("yaw", (n,)), ("lift", (n,)), ("airborne", (n,)), ("coast", (n, 3))):
            if getattr(self, name).shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {getattr(self, name).shape}")

    @classmethod
    def still(cls, angles: np.ndarray, yaw: np.ndarray | None = None) -> Plan:
        """A grounded plan (no lift, never airborne) from angles ``(T, 22, 3)``."""
        n = len(angles)
        return cls(angles, np.zeros(n) if yaw is None else yaw, np.zeros(n), np.zeros(n), np.full((n, 3), np.nan))

    def __len__(self) -> int:
        return len(self.angles)

    def pad(self, before: int, after: int) -> Plan:
        """Hold the first and last frames for ``before``/``after`` extra frames (idle lead-in and lead-out)."""
        if before < 0 or after < 0:
            raise ValueError(f"padding must be non-negative, got before={before}, after={after}")

        def edge(a: np.ndarray) -> np.ndarray:
            return np.pad(a, [(before, after)] + [(0, 0)] * (a.ndim - 1), mode="edge")

        return Plan(edge(self.angles), edge(self.yaw), edge(self.lift), edge(self.airborne), edge(self.coast))

    def then(self, other: Plan) -> Plan:
        """This plan followed by ``other``; ``other``'s heading continues from this one's last heading."""
        cat = np.concatenate
        return Plan(
            cat([self.angles, other.angles]),
            cat([self.yaw, other.yaw - other.yaw[0] + self.yaw[-1]]),
            cat([self.lift, other.lift]),
            cat([self.airborne, other.airborne]),
            cat([self.coast, other.coast]),
        )


# Natural standing pose: unit bone directions in body axes (x = left, y = up, z = forward), left side.
# Right-side bones mirror these; the others follow the raw offsets.
_NATURAL_LEFT = {
    1: (0.75, -0.65, 0.0),  # pelvis -> hip: out and down
    10: (0.1, -0.42, 0.9),  # ankle -> ball of the foot: forward and down
    13: (0.45, 0.9, 0.0),  # spine3 -> collar: up and out
    16: (0.97, -0.1, 0.1),  # collar -> shoulder: out
    18: (0.08, -1.0, 0.0),  # upper arm: down, slightly out
    20: (0.05, -1.0, 0.12),  # forearm: down, slightly forward
}
_NATURAL_CENTRE = {15: (0.0, 0.85, 0.5)}  # neck -> head: up and a little forward


def _natural_directions() -> np.ndarray:
    dirs = T2M.raw_offsets.copy()
    for j, d in _NATURAL_LEFT.items():
        dirs[j] = d
        right = {1: 2, 10: 11, 13: 14, 16: 17, 18: 19, 20: 21}[j]
        dirs[right] = (-d[0], d[1], d[2])
    for j, d in _NATURAL_CENTRE.items():
        dirs[j] = d
    dirs[1:] /= np.linalg.norm(dirs[1:], axis=-1, keepdims=True)
    return dirs


def rest_rotations() -> np.ndarray:
    """``(22, 4)`` rest rotations ``W_c``: the shortest arc from each raw offset to its natural direction."""
    w = qbetween(T2M.raw_offsets[1:], _natural_directions()[1:])
    return np.concatenate([np.array([[1.0, 0.0, 0.0, 0.0]]), w])


REST = rest_rotations()
_REST_INV = qinv(REST)

# Parent of each bone along the anatomy, and the joint whose rotation forward kinematics composes before it.
_ANATOMY_PARENT = T2M.parents
_FK_PREVIOUS = [0] * N_JOINTS
for _chain in T2M.chains:
    for _i, _child in enumerate(_chain[1:]):
        _FK_PREVIOUS[_child] = 0 if _i == 0 else _chain[_i]


def _axis_quat(axis: int, angle: np.ndarray) -> np.ndarray:
    """Quaternions ``(..., 4)`` rotating by ``angle`` about body axis ``axis`` (0 = x, 1 = y, 2 = z)."""
    q = np.zeros(angle.shape + (4,))
    q[..., 0] = np.cos(angle / 2)
    q[..., 1 + axis] = np.sin(angle / 2)
    return q


def angles_to_quats(angles: np.ndarray) -> np.ndarray:
    """Rotations ``(..., 4)`` from body-axis angles ``(..., 3)``: ``R = Rz(z) Rx(x) Ry(y)``."""
    qx, qy, qz = (_axis_quat(k, angles[..., k]) for k in range(3))
    return qmul(qz, qmul(qx, qy))


def local_rotations(angles: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """HumanML3D local rotations ``(T, 22, 4)`` for authored angles ``(T, 22, 3)`` and heading ``(T,)``."""
    a = angles_to_quats(angles)  # (T, 22, 4)
    a[:, 0] = qmul(_axis_quat(1, yaw), a[:, 0])  # G_0 = yaw * A_0
    posed = qmul(a, REST)  # A_c W_c for every bone at once
    world = np.empty_like(a)  # G_c
    world[:, 0] = a[:, 0]
    for c in range(1, N_JOINTS):  # SMPL order lists every parent before its children
        p = _ANATOMY_PARENT[c]
        world[:, c] = qmul(qmul(world[:, p], _REST_INV[p]), posed[:, c])  # parent's motion away from rest, then A W
    local = qmul(qinv(world[:, _FK_PREVIOUS]), world)
    local[:, 0] = world[:, 0]
    return local


def _stance_velocity(joints: np.ndarray) -> np.ndarray:
    """``(T-1, 3)`` world root velocity (m/frame) that keeps the lowest foot joints in place."""
    feet = joints[:, FOOT_JOINTS]  # (T, 4, 3)
    weight = softmax(-feet[..., 1] / SOFT_MIN_TAU, axis=1)  # (T, 4)
    weight = 0.5 * (weight[1:] + weight[:-1])
    step = np.diff(feet, axis=0) * np.array([1.0, 0.0, 1.0])  # horizontal foot displacement, (T-1, 4, 3)
    return -(weight[..., None] * step).sum(axis=1)


def place_root(joints: np.ndarray, plan: Plan) -> np.ndarray:
    """Root positions ``(T, 3)`` for poses ``joints`` computed with the root at the origin."""
    feet_y = joints[:, FOOT_JOINTS, 1]  # (T, 4)
    ground = -SOFT_MIN_TAU * logsumexp(-feet_y / SOFT_MIN_TAU, axis=1)  # soft minimum of the foot heights
    # A one-frame blur rounds off the corners where the support switches feet or a flight begins.
    height = gaussian_filter1d(plan.lift - ground, 1.0, mode="nearest")

    stance = _stance_velocity(joints)  # (T-1, 3), world frame
    air = 0.5 * (plan.airborne[1:] + plan.airborne[:-1])[:, None]
    heading = _axis_quat(1, 0.5 * (plan.yaw[1:] + plan.yaw[:-1]))
    # The pace the body keeps while airborne: the stance velocity averaged over about a stride, in body axes.
    body = qrot(qinv(heading), stance)
    ground_w = 1.0 - air
    pace = gaussian_filter1d(body * ground_w, 8.0, axis=0) / np.maximum(gaussian_filter1d(ground_w, 8.0, axis=0), 1e-6)
    coast = 0.5 * (plan.coast[1:] + plan.coast[:-1]) / FPS
    coast = np.where(np.isnan(coast), pace, coast)
    velocity = (1.0 - air) * stance + air * qrot(heading, coast)

    root = np.zeros((len(joints), 3))
    root[1:] = np.cumsum(velocity, axis=0)
    root[:, 1] = height
    return root


def realise(plan: Plan) -> np.ndarray:
    """Joint positions ``(T, 22, 3)`` in metres of an authored plan (floor at y ~ 0, start near the origin)."""
    local = local_rotations(plan.angles, plan.yaw)
    posed = forward_kinematics(local, np.zeros((len(plan), 3)), T2M)  # (T, 22, 3), root at the origin
    return posed + place_root(posed, plan)[:, None, :]


@dataclass
class Segment:
    """One authored action: its plan, the verb phrases that describe it, and the parameters drawn for it."""

    plan: Plan
    phrases: list[str]  # third-person verb phrases, e.g. "walks forward slowly" (at least three)
    params: dict  # JSON-serialisable parameters (family-specific)
    stationary: bool = True  # done while standing in place (captions may say "while standing")
    continuous: bool = False  # a steady activity with no count or goal (walking, running): may be cut into anywhere
