"""A small language for authoring poses on the HumanML3D ``t2m`` skeleton.

A motion is authored as per-bone joint angles in *body axes* (x = the body's left, y = up, z = forward),
one ``(x, y, z)`` triple per bone, composed as ``R = Rz(z) @ Rx(x) @ Ry(y)``: twist about the bone, then
flexion, then abduction. Angles are indexed by the joint at the *end* of the bone, as HumanML3D indexes
local rotations, so ``angles[:, RIGHT_SHOULDER]`` (joint 19, the right elbow's index) swings the right
upper arm. Sign conventions, written for the right side (the left side is the mirror image):

==================  ==========================  ===========================================
bone                angle                       meaning (positive value)
==================  ==========================  ===========================================
thigh, upper arm    x = -a                      swing forward (hip / shoulder flexion)
upper arm, thigh    z = -a                      swing out to the right (abduction)
shin                x = +a                      knee flexion
forearm             x = -a                      elbow flexion (forearm forward)
foot                x = -a                      toes up (dorsiflexion)
spine, neck         x = +a                      bend forward
==================  ==========================  ===========================================

Keyframed movements interpolate with the minimum-jerk profile ``10 s^3 - 15 s^4 + 6 s^5``, the shape of
human point-to-point reaching, so a fast punch gets real (but bounded) jerk and a slow raise stays smooth.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy.ndimage import gaussian_filter1d

from motionlab.representation import T2M

FPS = T2M.fps  # 20 frames per second
N_JOINTS = T2M.n_joints  # 22

# Bones by anatomical role (index = the joint at the bone's far end, as in HumanML3D's local rotations).
PELVIS = 0
SPINE_LOW, SPINE_MID, SPINE_UP, NECK, HEAD = 3, 6, 9, 12, 15
LEFT_HIP, RIGHT_HIP = 4, 5  # thighs
LEFT_KNEE, RIGHT_KNEE = 7, 8  # shins
LEFT_ANKLE, RIGHT_ANKLE = 10, 11  # feet
LEFT_COLLAR, RIGHT_COLLAR = 13, 14
LEFT_SHOULDER, RIGHT_SHOULDER = 18, 19  # upper arms
LEFT_ELBOW, RIGHT_ELBOW = 20, 21  # forearms

BONES = {
    "pelvis": PELVIS,
    "spine_low": SPINE_LOW,
    "spine_mid": SPINE_MID,
    "spine_up": SPINE_UP,
    "neck": NECK,
    "head": HEAD,
    "hip_l": LEFT_HIP,
    "hip_r": RIGHT_HIP,
    "knee_l": LEFT_KNEE,
    "knee_r": RIGHT_KNEE,
    "ankle_l": LEFT_ANKLE,
    "ankle_r": RIGHT_ANKLE,
    "collar_l": LEFT_COLLAR,
    "collar_r": RIGHT_COLLAR,
    "shoulder_l": LEFT_SHOULDER,
    "shoulder_r": RIGHT_SHOULDER,
    "elbow_l": LEFT_ELBOW,
    "elbow_r": RIGHT_ELBOW,
}

# Joint pairs swapped by a left/right mirror (x -> -x).
MIRROR_PAIRS = ((1, 2), (4, 5), (7, 8), (10, 11), (13, 14), (16, 17), (18, 19), (20, 21))
MIRROR_INDEX = np.arange(N_JOINTS)
for _a, _b in MIRROR_PAIRS:
    MIRROR_INDEX[_a], MIRROR_INDEX[_b] = _b, _a

LEFT_ARM = (LEFT_COLLAR, 16, LEFT_SHOULDER, LEFT_ELBOW)
RIGHT_ARM = (RIGHT_COLLAR, 17, RIGHT_SHOULDER, RIGHT_ELBOW)
LEFT_LEG = (LEFT_HIP, LEFT_KNEE, LEFT_ANKLE)
RIGHT_LEG = (RIGHT_HIP, RIGHT_KNEE, RIGHT_ANKLE)

SIDES = ("left", "right", "both")


def seconds(n_frames: int) -> np.ndarray:
    """Time stamps ``(n,)`` in seconds of ``n`` frames at 20 fps."""
    return np.arange(n_frames) / FPS


def frames(duration_s: float) -> int:
    """Number of frames covering ``duration_s`` seconds (at least one)."""
    return max(1, int(round(duration_s * FPS)))


def min_jerk(s: np.ndarray) -> np.ndarray:
    """Minimum-jerk ease ``10 s^3 - 15 s^4 + 6 s^5`` on ``s`` clipped to [0, 1] (zero velocity and acceleration
    at both ends)."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 + s * (-15.0 + 6.0 * s))


def envelope(n: int, ramp_in: int, ramp_out: int) -> np.ndarray:
    """``(n,)`` weights rising from 0 to 1 over ``ramp_in`` frames and falling back over the last ``ramp_out``."""
    i = np.arange(n, dtype=np.float64)
    rise = min_jerk(i / max(ramp_in, 1))
    fall = min_jerk((n - 1 - i) / max(ramp_out, 1))
    return np.minimum(rise, fall)


def keyframes(n: int, times: Sequence[float], values: Sequence) -> np.ndarray:
    """Piecewise minimum-jerk interpolation of ``values`` (each any shape) at ``times`` (seconds, increasing).

    Holds the first value before the first key and the last one after it. Returns ``(n, *value_shape)``.
    """
    times = np.asarray(times, dtype=np.float64)
    vals = np.asarray(values, dtype=np.float64)  # (K, ...)
    t = seconds(n)
    idx = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1)
    nxt = np.minimum(idx + 1, len(times) - 1)
    span = np.maximum(times[nxt] - times[idx], 1e-9)
    s = min_jerk((t - times[idx]) / span)
    s = s.reshape((n,) + (1,) * (vals.ndim - 1))
    return vals[idx] + s * (vals[nxt] - vals[idx])


def smooth_noise(rng: np.random.Generator, shape: tuple[int, ...], sigma_frames: float, scale: float) -> np.ndarray:
    """Low-pass Gaussian noise: white noise blurred along axis 0 by ``sigma_frames``, rescaled to std ``scale``.

    Blurring keeps the perturbation's derivatives small, so it adds variety without adding jerk.
    """
    pad = int(4 * sigma_frames) + 1
    raw = rng.standard_normal((shape[0] + 2 * pad,) + tuple(shape[1:]))
    smooth = gaussian_filter1d(raw, sigma_frames, axis=0)[pad:-pad]
    return smooth * (scale / np.sqrt(1.0 / (2.0 * np.sqrt(np.pi) * sigma_frames)))


def pose(**bones: tuple[float, float, float]) -> np.ndarray:
    """A ``(22, 3)`` angle array in radians from ``name=(x, y, z)`` in degrees, e.g. ``pose(hip_r=(-30, 0, 0))``."""
    out = np.zeros((N_JOINTS, 3))
    for name, xyz in bones.items():
        if name not in BONES:
            raise ValueError(f"unknown bone {name!r}; expected one of {sorted(BONES)}")
        out[BONES[name]] = np.deg2rad(xyz)
    return out


def mirror(angles: np.ndarray) -> np.ndarray:
    """Left/right mirror image ``(..., 22, 3)``: swap the sides and negate the y and z angles."""
    out = angles[..., MIRROR_INDEX, :].copy()
    out[..., 1:] *= -1.0
    return out


def to_side(angles: np.ndarray, side: str, bones: Sequence[int] = RIGHT_ARM + RIGHT_LEG) -> np.ndarray:
    """Retarget a right-sided movement to ``side``: "right" keeps it, "left" mirrors it, "both" copies the
    mirror image of the right-sided ``bones`` onto their left counterparts."""
    if side == "right":
        return angles
    mirrored = mirror(angles)
    if side == "left":
        return mirrored
    both = angles.copy()
    other = [MIRROR_INDEX[b] for b in bones]
    both[..., other, :] = mirrored[..., other, :]
    return both


def blend(base: np.ndarray, layers: Mapping[int, np.ndarray]) -> np.ndarray:
    """``base`` (T, 22, 3) with extra angle curves ``(T, 3)`` added to the given bones."""
    out = base.copy()
    for bone, curve in layers.items():
        out[:, bone] += curve
    return out


def pick(rng: np.random.Generator, name: str, value, options: Sequence):
    """``value`` if given (checked against ``options``), else a uniform draw from ``options``."""
    if value is None:
        return options[int(rng.integers(len(options)))]
    if value not in options:
        raise ValueError(f"{name} must be one of {list(options)}, got {value!r}")
    return value


def draw(rng: np.random.Generator, name: str, value, low: float, high: float) -> float:
    """``value`` if given (checked to lie in [low, high]), else a uniform draw from that range."""
    if value is None:
        return float(rng.uniform(low, high))
    if not low <= float(value) <= high:
        raise ValueError(f"{name} must lie in [{low}, {high}], got {value!r}")
    return float(value)


def count(rng: np.random.Generator, name: str, value, low: int, high: int) -> int:
    """``value`` if given (an integer in [low, high]), else a uniform integer draw from that range."""
    if value is None:
        return int(rng.integers(low, high + 1))
    if int(value) != value or not low <= value <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    return int(value)


def times_phrase(n: int) -> str:
    """ "once", "twice", "three times", ... for repetition counts in captions."""
    words = {
        1: "once",
        2: "twice",
        3: "three times",
        4: "four times",
        5: "five times",
        6: "six times",
        7: "seven times",
        8: "eight times",
    }
    return words.get(n, "several times")
