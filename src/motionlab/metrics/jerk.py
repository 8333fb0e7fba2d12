"""Jerk: one finite-difference jerk for the whole book, M2D2M's transition Jerk (Eq. 10), and LDLJ.

Jerk is the third time derivative of position. Every jerk in motionlab is the *plain* third difference

    j[t] = (p[t+3] - 3 p[t+2] + 3 p[t+1] - p[t]) / dt^3,        t = 0 .. T-4,

so a clip of ``T`` frames has ``T - 3`` jerk frames. Velocity is the first plain difference
``v[t] = (p[t+1] - p[t]) / dt`` (``T - 1`` frames). sJPE (DisCoRD), Eq. 10 (M2D2M) and the plots all use it.

Three smoothness numbers built on it live here:

* :func:`log_jerk` -- M2D2M's Eq. 10 for one window (per joint, then averaged over joints);
* :func:`log_dimensionless_jerk` -- the standard LDLJ of a speed profile (Balasubramanian et al.);
* :func:`ldlj_from_log_jerk` -- the exact bridge between the two.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from ._checks import as_float_array, check_joints
from .joints import ClipJoints

TIME_UNITS = ("frames", "seconds")


def _check_finite_difference_jerk_inputs(positions, fps: float, axis: int) -> torch.Tensor | np.ndarray:
    """Reject a non-positive ``fps`` and fewer than 4 frames; return ``positions`` (a tensor, or a float array)."""
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if isinstance(positions, torch.Tensor):
        if positions.dim() == 0 or positions.shape[axis] < 4:
            raise ValueError(f"positions need at least 4 frames on axis {axis}, got shape {tuple(positions.shape)}")
        if not torch.isfinite(positions).all():
            raise ValueError("positions contain NaN or inf values")
        return positions
    arr = as_float_array(positions, "positions")
    if arr.ndim == 0 or arr.shape[axis] < 4:
        raise ValueError(f"positions need at least 4 frames on axis {axis}, got shape {arr.shape}")
    return arr


def finite_difference_jerk(positions, fps: float, axis: int = -3):
    """Jerk ``(p[t+3] - 3p[t+2] + 3p[t+1] - p[t]) * fps^3`` along ``axis`` (time).

    ``positions`` is a NumPy array or torch tensor, by default ``(..., T, J, 3)``; the result has the
    same type and ``T - 3`` frames on the time axis. Multiplying by ``fps^3`` turns "per frame^3" into
    "per second^3" (``dt = 1 / fps``).
    """
    positions = _check_finite_difference_jerk_inputs(positions, fps, axis)
    if isinstance(positions, torch.Tensor):
        return torch.diff(positions, n=3, dim=axis) * fps**3
    return np.diff(positions, n=3, axis=axis) * fps**3


def squared_length(v: np.ndarray) -> np.ndarray:
    """``x² + y² + z²`` of vectors ``(..., 3)`` -> ``(...)``: ``np.linalg.norm(v, axis=-1) ** 2`` without numpy's
    slow reduction over an axis of three (the sums run in the same order, so ``sqrt`` of it equals ``norm``)."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return x * x + y * y + z * z


def _time_step(time_unit: str, fps: float) -> float:
    if time_unit not in TIME_UNITS:
        raise ValueError(f"time_unit must be one of {TIME_UNITS}, got {time_unit!r}")
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    return 1.0 if time_unit == "frames" else 1.0 / fps


def _per_joint_log_jerk(windows: np.ndarray, dt: float) -> np.ndarray:
    """ln( sum_t ||j_t||^2 dt / v_peak^2 ) for windows ``(..., W, J, 3)`` -> ``(..., J)``; NaN where static."""
    jerk = finite_difference_jerk(windows, 1.0 / dt, axis=-3)  # (..., W-3, J, 3)
    speed = np.sqrt(squared_length(np.diff(windows, axis=-3))) / dt  # (..., W-1, J)
    v_peak = speed.max(axis=-2)  # (..., J)
    energy = squared_length(jerk).sum(axis=-2) * dt  # (..., J): the integral of ||da/dt||^2
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.log(energy / v_peak**2)
    out[v_peak == 0] = np.nan  # a perfectly still joint has no defined smoothness
    return out


def log_jerk(window_joints, time_unit: str = "frames", fps: float = 20.0) -> float:
    """M2D2M's transition Jerk (Eq. 10) of one window ``(W, J, 3)`` of joint positions (metres).

    Per joint ``p``::

        E_p = ln( (1 / v_peak_p^2) * integral_{t1}^{t2} || d a_p / dt ||^2 dt )

    discretised like sJPE: ``da/dt`` is the plain third difference / dt^3, the integral is the sum over
    the ``W - 3`` jerk frames times ``dt``, and ``v_peak_p`` the largest speed ``||p[t+1] - p[t]|| / dt``
    over the window's ``W - 1`` first differences. The paper's equation writes a *sum* over joints but its
    text says the per-joint values are *averaged*; we follow the text and return ``mean_p E_p``.

    ``time_unit="frames"`` (``dt = 1``, the default) reproduces the paper's scale (real single motions
    about 1.19, two real motions concatenated about 1.37, TPS about 1.24 on HumanML3D). In seconds
    (``dt = 1 / fps``) every value is exactly ``3 ln(fps)`` larger, since the ratio scales as ``dt^-3``.
    Scaling space (m vs mm) changes nothing: both ``||j||^2`` and ``v_peak^2`` scale alike.
    Joints that do not move at all in the window (``v_peak = 0``) are left out of the mean; a window in
    which nothing moves raises ``ValueError``. Lower = smoother; the paper wants values close to real data.
    """
    dt = _time_step(time_unit, fps)
    w = check_joints(window_joints, "window_joints")
    per_joint = _per_joint_log_jerk(w, dt)
    if np.isnan(per_joint).all():
        raise ValueError("window_joints is perfectly static (zero peak speed for every joint)")
    return float(np.nanmean(per_joint))


def boundaries_from_lengths(segment_lengths: Sequence[int]) -> list[int]:
    """Transition frames of segments played back to back: the first frame of every segment but the first."""
    lengths = [int(n) for n in segment_lengths]
    if any(n <= 0 for n in lengths):
        raise ValueError(f"segment_lengths must be positive, got {lengths}")
    return np.cumsum(lengths)[:-1].tolist()


def transition_windows(motion_len: int, boundaries: Sequence[int], window: int = 40) -> list[tuple[int, int]]:
    """Frame ranges ``[start, stop)`` of ``window`` frames centred on each boundary.

    A boundary ``b`` is the first frame of the next action, so the centred window is
    ``[b - window//2, b - window//2 + window)``: 20 frames before the boundary and 20 from it on for the
    default 40. Near an edge of the sequence the window is *shifted* inside ``[0, motion_len)`` rather
    than cut, so every window keeps ``window`` frames (Eq. 10 has no duration normalisation, so windows of
    different lengths would not be comparable). A sequence shorter than ``window`` gives the whole
    sequence ``[0, motion_len)``.
    """
    motion_len, window = int(motion_len), int(window)
    if window < 4:
        raise ValueError(f"window must be at least 4 frames (a third difference), got {window}")
    if motion_len < 4:
        raise ValueError(f"motion_len must be at least 4 frames, got {motion_len}")
    out = []
    for b in boundaries:
        b = int(b)
        if not 0 < b < motion_len:
            raise ValueError(f"boundary {b} must lie strictly inside (0, motion_len={motion_len})")
        if motion_len <= window:
            out.append((0, motion_len))
            continue
        start = min(max(b - window // 2, 0), motion_len - window)
        out.append((start, start + window))
    return out


def transition_log_jerk(
    joints, boundaries: Sequence[int], window: int = 40, time_unit: str = "frames", fps: float = 20.0
) -> np.ndarray:
    """Eq. 10 around every boundary of one multi-motion sequence ``(T, J, 3)`` -> ``(n_boundaries,)``.

    Windows come from :func:`transition_windows`. A window in which no joint moves gives NaN (rather than
    an error) so that one frozen transition does not abort a dataset evaluation; use ``np.nanmean``.
    """
    dt = _time_step(time_unit, fps)
    x = check_joints(joints, "joints")
    spans = transition_windows(x.shape[0], boundaries, window)
    values = [_per_joint_log_jerk(x[a:b], dt) for a, b in spans]
    with np.errstate(invalid="ignore"):
        return np.array([np.nan if np.isnan(v).all() else np.nanmean(v) for v in values])


def log_jerk_batch(windows, time_unit: str = "frames", fps: float = 20.0) -> np.ndarray:
    """Eq. 10 for a stack of equal-length windows ``(N, W, J, 3)`` -> ``(N,)`` (NaN for a static window)."""
    dt = _time_step(time_unit, fps)
    w = as_float_array(windows, "windows")
    if w.ndim != 4 or w.shape[-1] != 3 or w.shape[1] < 4:
        raise ValueError(f"windows must have shape (N, W>=4, J, 3), got {w.shape}")
    return _mean_over_joints(_per_joint_log_jerk(w, dt))


def _mean_over_joints(per_joint: np.ndarray) -> np.ndarray:
    """``(N, J)`` -> ``(N,)``: the mean over the joints that move, NaN where none does."""
    counts = (~np.isnan(per_joint)).sum(axis=1)
    with np.errstate(invalid="ignore"):
        return np.where(counts > 0, np.nansum(per_joint, axis=1) / np.maximum(counts, 1), np.nan)


_WINDOW_BLOCK = 64  # windows gathered at a time: the (block, W, J, 3) copy and its temporaries stay in cache


def clip_log_jerk(
    joints: ClipJoints,
    boundaries: Sequence[int] | None = None,
    window: int = 40,
    time_unit: str = "frames",
    fps: float = 20.0,
) -> np.ndarray:
    """Eq. 10 around one boundary of every clip of a set ``(N,)``, without a loop over clips.

    ``boundaries[i]`` (default: each clip's middle frame, ``T_i // 2``) is a frame strictly inside clip ``i``;
    its window is :func:`transition_windows`' (``window`` frames, shifted inside the clip; the whole clip if
    it has no more than ``window`` frames), so value ``i`` equals ``transition_log_jerk(clip_i, [b_i],
    window)[0]``. Windows of equal length are gathered from the packed joints and scored together. The
    LDLJ of the same windows is ``ldlj_from_log_jerk(values, np.minimum(joints.lengths, window))``.
    """
    dt = _time_step(time_unit, fps)
    if window < 4:
        raise ValueError(f"window must be at least 4 frames (a third difference), got {window}")
    n = joints.lengths
    if (n < 4).any():
        raise ValueError(f"clip {int(np.argmax(n < 4))} has fewer than 4 frames")
    b = n // 2 if boundaries is None else np.asarray(boundaries, np.int64)
    if b.shape != n.shape or (b <= 0).any() or (b >= n).any():
        raise ValueError(f"boundaries must be {len(n)} frames, each strictly inside its clip")
    size = np.minimum(n, window)  # (N,) frames of each window
    first = joints.starts + np.clip(b - window // 2, 0, n - size)  # (N,) the window's first row in positions
    out = np.empty(len(n))
    for w in np.unique(size):
        chosen = np.flatnonzero(size == w)
        for s in range(0, len(chosen), _WINDOW_BLOCK):
            part = chosen[s : s + _WINDOW_BLOCK]
            windows = joints.positions[first[part, None] + np.arange(w)]  # (M, w, J, 3)
            out[part] = _mean_over_joints(_per_joint_log_jerk(windows, dt))
    return out


# ---------------------------------------------------------------------------------------------------------
# Standard LDLJ (Balasubramanian, Melendez-Calderon, Burdet 2012) and its relation to Eq. 10.


def _check_speed(speed, fs: float) -> np.ndarray:
    v = as_float_array(speed, "speed")
    if v.ndim != 1 or v.shape[0] < 3:
        raise ValueError(f"speed must be a 1-D profile of at least 3 samples, got shape {v.shape}")
    if fs <= 0:
        raise ValueError(f"fs must be positive, got {fs}")
    if np.abs(v).max() == 0:
        raise ValueError("speed is identically zero: the dimensionless jerk is undefined")
    return v


def dimensionless_jerk(speed, fs: float) -> float:
    """DLJ of a speed profile ``v`` sampled at ``fs`` Hz::

        DLJ = -(D^3 / max|v|^2) * sum_t j[t]^2 * dt,   dt = 1/fs,  D = N dt,  j = diff(v, 2) / dt^2

    ``N`` is the number of speed samples (so ``D = N dt``, not ``(N-1) dt``, as the canonical code has it).
    For ``v = exp(-5 t^2)``, ``t = -1, -0.99, ..., 0.99`` and ``fs = 100``: DLJ = -335.74684.
    """
    v = _check_speed(speed, fs)
    dt = 1.0 / fs
    duration = v.shape[0] * dt
    jerk = np.diff(v, n=2) / dt**2
    return float(-(duration**3 / np.abs(v).max() ** 2) * np.sum(jerk**2) * dt)


def log_dimensionless_jerk(speed, fs: float) -> float:
    """LDLJ ``= -ln|DLJ|`` (negative; *higher* = smoother). The canonical bell profile gives -5.81636."""
    return float(-np.log(abs(dimensionless_jerk(speed, fs))))


def ldlj_from_log_jerk(value, n_frames, time_unit: str = "frames", fps: float = 20.0):
    """Turn an Eq. 10 value of a ``n_frames`` window into the LDLJ of the same signal.

    Eq. 10 is ``E = ln(integral ||j||^2 dt / v_peak^2)`` with no duration factor and no minus sign, while
    LDLJ is ``-ln(D^3 integral ||j||^2 dt / v_peak^2)``. With ``D = (n_frames - 1) dt`` (the window has
    ``n_frames - 1`` velocity samples, matching ``D = N dt`` above)::

        LDLJ = -E - 3 ln(D)

    The ``3 ln D`` term is what makes LDLJ unit-free: ``E`` grows by ``3 ln(fps)`` from frames to
    seconds and ``3 ln D`` shrinks by the same amount. For one joint whose velocity keeps its direction,
    the speed's second difference equals the vector jerk and the identity is exact; Eq. 10 (averaged
    over joints) is therefore "minus LDLJ, without the duration term, of each joint's 3-D path".
    ``value`` and ``n_frames`` may be arrays (e.g. from :func:`clip_log_jerk`): the result is then an array.
    """
    dt = _time_step(time_unit, fps)
    frames = np.asarray(n_frames)
    if not np.issubdtype(frames.dtype, np.integer) and not np.all(frames == np.round(frames)):
        raise ValueError(f"n_frames must be whole numbers, got {n_frames}")
    if (frames < 4).any():
        raise ValueError(f"n_frames must be at least 4, got {n_frames}")
    out = -np.asarray(value, dtype=np.float64) - 3.0 * np.log((frames.astype(np.int64) - 1) * dt)
    return float(out) if out.ndim == 0 else out


# ---------------------------------------------------------------------------------------------------------
# M2D2M Table 1's two rows of real motion: Eq. 10 inside real clips and on naive seams between them

_PARTNER_STREAM = 300  # the partner permutations' seed stream: default_rng([seed, 300, r])


def real_motion_log_jerk(
    features: Sequence[np.ndarray], partners: int = 1, seed: int = 0, window: int = 40, n_joints: int = 22
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 10 (frames) of real motion, M2D2M Table 1's "single" and "concatenated" rows: ``(single, concatenated)``.

    ``single[i]``: a ``window``-frame window centred in clip ``i`` (raw ``(T, D)`` features, joints recovered from
    them). ``concatenated``: for each of ``partners`` random pairings (permutation ``r`` from
    ``default_rng([seed, 300, r])``), clip ``a``'s features followed by its partner's, the window centred on the seam
    (the root carries on from where the first clip stopped; the pose jumps); a clip paired with itself is skipped.
    Windows in which nothing moves (NaN) are dropped from both.
    """
    from ..representation import recover_from_ric

    if isinstance(partners, bool) or not isinstance(partners, int) or partners < 1:
        raise ValueError(f"partners must be a positive int, got {partners!r}")
    clips = [np.asarray(f) for f in features]
    if len(clips) < 2:
        raise ValueError(f"need at least 2 clips to pair, got {len(clips)}")
    single = np.array(
        [
            transition_log_jerk(j, [len(j) // 2], window=window)[0]
            for j in (recover_from_ric(f, n_joints) for f in clips)
        ]
    )
    concatenated = []
    for r in range(partners):
        partner = np.random.default_rng([seed, _PARTNER_STREAM, r]).permutation(len(clips))
        for a, b in enumerate(partner):
            if a == b:
                continue
            joined = recover_from_ric(np.concatenate([clips[a], clips[b]]), n_joints)
            concatenated.append(transition_log_jerk(joined, [len(clips[a])], window=window)[0])
    concatenated = np.array(concatenated)
    return single[np.isfinite(single)], concatenated[np.isfinite(concatenated)]
