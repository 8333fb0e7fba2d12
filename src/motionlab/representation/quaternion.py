"""Quaternions (w, x, y, z) and the 6D rotation representation.

Every function accepts either a NumPy array or a torch tensor and returns the same kind: the
arithmetic is written once, in torch, and NumPy inputs are converted on the way in and out (in
float64, so nothing is lost against a NumPy implementation). Leading dimensions broadcast.

The 6D representation follows Zhou et al. (2019) as HumanML3D stores it: the first two *columns* of the
rotation matrix, ``[R[:, 0], R[:, 1]]``.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
import torch

Array = TypeVar("Array", np.ndarray, torch.Tensor)

_EPS = 1e-12


def to_torch(x) -> tuple[torch.Tensor, bool]:
    """Return ``x`` as a tensor and whether it came in as NumPy (float64 for NumPy inputs)."""
    if isinstance(x, torch.Tensor):
        return x, False
    return torch.from_numpy(np.array(x, dtype=np.float64)), True


def like_input(out: torch.Tensor, was_numpy: bool):
    """Convert a result back to the kind of the input it was computed from."""
    return out.detach().cpu().numpy() if was_numpy else out


def _apply(fn, *args):
    """Run a torch implementation on mixed inputs and return NumPy if the first input was NumPy."""
    tensors, numpy_flags = zip(*(to_torch(a) for a in args))
    if any(not f for f in numpy_flags):
        ref = next(t for t, f in zip(tensors, numpy_flags) if not f)
        tensors = tuple(t.to(device=ref.device, dtype=ref.dtype) for t in tensors)
    return like_input(fn(*tensors), numpy_flags[0])


# --- torch kernels --------------------------------------------------------------------------------


def _qnormalize(q: torch.Tensor) -> torch.Tensor:
    return q / q.norm(dim=-1, keepdim=True).clamp_min(_EPS)


def _qmul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack(
        (
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ),
        dim=-1,
    )


def _qinv(q: torch.Tensor) -> torch.Tensor:
    return q * q.new_tensor([1.0, -1.0, -1.0, -1.0])


def _qrot(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    # v' = v + 2 w (u x v) + 2 u x (u x v), with u the vector part of a unit quaternion.
    q, v = torch.broadcast_tensors(q, torch.cat((torch.zeros_like(v[..., :1]), v), dim=-1))
    v = v[..., 1:]
    u, w = q[..., 1:], q[..., :1]
    uv = torch.linalg.cross(u, v, dim=-1)
    return v + 2.0 * (w * uv + torch.linalg.cross(u, uv, dim=-1))


def _qbetween(v0: torch.Tensor, v1: torch.Tensor) -> torch.Tensor:
    v0, v1 = torch.broadcast_tensors(v0, v1)
    axis = torch.linalg.cross(v0, v1, dim=-1)
    w = (v0.norm(dim=-1, keepdim=True) * v1.norm(dim=-1, keepdim=True)) + (v0 * v1).sum(-1, keepdim=True)
    q = torch.cat((w, axis), dim=-1)
    # Opposite vectors leave q = 0: rotate by pi about any axis orthogonal to v0.
    degenerate = q.norm(dim=-1) < 1e-9 * (1.0 + v0.norm(dim=-1) * v1.norm(dim=-1))
    if degenerate.any():
        helper = torch.zeros_like(v0)
        use_x = v0[..., 0].abs() < 0.9 * v0.norm(dim=-1).clamp_min(_EPS)
        helper[..., 0] = use_x.to(v0.dtype)
        helper[..., 1] = (~use_x).to(v0.dtype)
        ortho = torch.linalg.cross(v0, helper, dim=-1)
        flip = torch.cat((torch.zeros_like(w), ortho), dim=-1)
        q = torch.where(degenerate[..., None], flip, q)
    return _qnormalize(q)


def _quat_to_matrix(q: torch.Tensor) -> torch.Tensor:
    w, x, y, z = _qnormalize(q).unbind(-1)
    rows = (
        1 - 2 * (y * y + z * z),
        2 * (x * y - w * z),
        2 * (x * z + w * y),
        2 * (x * y + w * z),
        1 - 2 * (x * x + z * z),
        2 * (y * z - w * x),
        2 * (x * z - w * y),
        2 * (y * z + w * x),
        1 - 2 * (x * x + y * y),
    )
    return torch.stack(rows, dim=-1).reshape(q.shape[:-1] + (3, 3))


def _matrix_to_quat(m: torch.Tensor) -> torch.Tensor:
    # Shepperd's method: pick the largest of the four candidate denominators for stability.
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    candidates = torch.stack(
        (1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22), dim=-1
    )
    best = candidates.argmax(dim=-1)
    s = torch.sqrt(candidates.gather(-1, best[..., None]).clamp_min(_EPS)).squeeze(-1) * 2.0
    q_w = torch.stack(
        (
            s / 4,
            (m[..., 2, 1] - m[..., 1, 2]) / s,
            (m[..., 0, 2] - m[..., 2, 0]) / s,
            (m[..., 1, 0] - m[..., 0, 1]) / s,
        ),
        dim=-1,
    )
    q_x = torch.stack(
        (
            (m[..., 2, 1] - m[..., 1, 2]) / s,
            s / 4,
            (m[..., 0, 1] + m[..., 1, 0]) / s,
            (m[..., 0, 2] + m[..., 2, 0]) / s,
        ),
        dim=-1,
    )
    q_y = torch.stack(
        (
            (m[..., 0, 2] - m[..., 2, 0]) / s,
            (m[..., 0, 1] + m[..., 1, 0]) / s,
            s / 4,
            (m[..., 1, 2] + m[..., 2, 1]) / s,
        ),
        dim=-1,
    )
    q_z = torch.stack(
        (
            (m[..., 1, 0] - m[..., 0, 1]) / s,
            (m[..., 0, 2] + m[..., 2, 0]) / s,
            (m[..., 1, 2] + m[..., 2, 1]) / s,
            s / 4,
        ),
        dim=-1,
    )
    q = torch.stack((q_w, q_x, q_y, q_z), dim=-2).gather(-2, best[..., None, None].expand(best.shape + (1, 4)))
    q = q.squeeze(-2)
    return _qnormalize(q * torch.where(q[..., :1] < 0, -1.0, 1.0).to(q.dtype))


def _cont6d_to_matrix(r6: torch.Tensor) -> torch.Tensor:
    a, b = r6[..., :3], r6[..., 3:]
    x = a / a.norm(dim=-1, keepdim=True).clamp_min(_EPS)
    z = torch.linalg.cross(x, b, dim=-1)
    z = z / z.norm(dim=-1, keepdim=True).clamp_min(_EPS)
    y = torch.linalg.cross(z, x, dim=-1)
    return torch.stack((x, y, z), dim=-1)  # columns


def _matrix_to_cont6d(m: torch.Tensor) -> torch.Tensor:
    return torch.cat((m[..., 0], m[..., 1]), dim=-1)


def _axis_angle_to_quat(axis: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    axis = axis / axis.norm(dim=-1, keepdim=True).clamp_min(_EPS)
    half = angle[..., None] / 2
    return torch.cat((torch.cos(half), torch.sin(half) * axis), dim=-1)


def _slerp(q0: torch.Tensor, q1: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    q0, q1 = _qnormalize(q0), _qnormalize(q1)
    dot = (q0 * q1).sum(-1, keepdim=True)
    q1 = torch.where(dot < 0, -q1, q1)  # take the short way round
    dot = dot.abs().clamp(max=1.0)
    t = t[..., None] if t.dim() == q0.dim() - 1 else t
    theta = torch.acos(dot)
    sin_theta = torch.sin(theta)
    near = sin_theta < 1e-6
    w0 = torch.where(near, 1 - t, torch.sin((1 - t) * theta) / sin_theta.clamp_min(_EPS))
    w1 = torch.where(near, t, torch.sin(t * theta) / sin_theta.clamp_min(_EPS))
    return _qnormalize(w0 * q0 + w1 * q1)


# --- public API (NumPy or torch) --------------------------------------------------------------------


def qnormalize(q: Array) -> Array:
    """Unit quaternion(s) ``(..., 4)``."""
    return _apply(_qnormalize, q)


def qmul(a: Array, b: Array) -> Array:
    """Hamilton product ``a * b`` of quaternions ``(..., 4)``: apply ``b`` first, then ``a``."""
    return _apply(_qmul, a, b)


def qinv(q: Array) -> Array:
    """Inverse (conjugate) of unit quaternion(s)."""
    return _apply(_qinv, q)


def qrot(q: Array, v: Array) -> Array:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)``."""
    return _apply(_qrot, q, v)


def qbetween(v0: Array, v1: Array) -> Array:
    """The shortest-arc unit quaternion rotating direction ``v0`` onto direction ``v1``."""
    return _apply(_qbetween, v0, v1)


def quat_to_matrix(q: Array) -> Array:
    """Rotation matrices ``(..., 3, 3)`` from quaternions ``(..., 4)``."""
    return _apply(_quat_to_matrix, q)


def matrix_to_quat(m: Array) -> Array:
    """Unit quaternions with ``w >= 0`` from rotation matrices ``(..., 3, 3)``."""
    return _apply(_matrix_to_quat, m)


def quat_to_cont6d(q: Array) -> Array:
    """6D rotation ``(..., 6)``: the first two columns of the rotation matrix, concatenated."""
    return _apply(lambda t: _matrix_to_cont6d(_quat_to_matrix(t)), q)


def matrix_to_cont6d(m: Array) -> Array:
    """6D rotation ``(..., 6)`` from rotation matrices ``(..., 3, 3)``."""
    return _apply(_matrix_to_cont6d, m)


def cont6d_to_matrix(r6: Array) -> Array:
    """Rotation matrices from 6D vectors, re-orthonormalised by Gram-Schmidt."""
    return _apply(_cont6d_to_matrix, r6)


def cont6d_to_quat(r6: Array) -> Array:
    """Unit quaternions from 6D vectors."""
    return _apply(lambda t: _matrix_to_quat(_cont6d_to_matrix(t)), r6)


def axis_angle_to_quat(axis: Array, angle: Array) -> Array:
    """Quaternion rotating by ``angle`` (radians, ``(...)``) about ``axis`` (``(..., 3)``)."""
    return _apply(_axis_angle_to_quat, axis, angle)


def slerp(q0: Array, q1: Array, t: Array) -> Array:
    """Spherical linear interpolation between unit quaternions; ``t`` in [0, 1] broadcasts."""
    return _apply(_slerp, q0, q1, t)


def euler_to_quat(angles: Array, order: str = "XYZ", degrees: bool = True) -> Array:
    """Quaternions from intrinsic Euler angles ``(..., 3)`` applied in ``order`` (e.g. BVH ``"ZXY"``).

    Intrinsic rotations compose left to right: ``R = R_order[0] @ R_order[1] @ R_order[2]``.
    """
    order = order.upper()
    if sorted(order) != ["X", "Y", "Z"]:
        raise ValueError(f"order must be a permutation of 'XYZ', got {order!r}")

    def kernel(a: torch.Tensor) -> torch.Tensor:
        a = torch.deg2rad(a) if degrees else a
        basis = {"X": [1.0, 0, 0], "Y": [0, 1.0, 0], "Z": [0, 0, 1.0]}
        q = None
        for k, letter in enumerate(order):
            axis = a.new_tensor(basis[letter]).expand(a.shape[:-1] + (3,))
            qk = _axis_angle_to_quat(axis, a[..., k])
            q = qk if q is None else _qmul(q, qk)
        return q

    return _apply(kernel, angles)
