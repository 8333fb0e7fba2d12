"""Locomotion families: walk, run, side-step and turn in place.

The legs swing through a gait cycle in place (like on a treadmill); the rig then moves the root so the
lowest foot stays planted, so the distance covered follows from the leg swing instead of being imposed.
Phase ``phi`` advances at the stride frequency; the right leg uses ``phi``, the left ``phi + pi``. A leg
swings forward while ``cos(phi) > 0`` (its hip angle ``H sin(phi)`` is growing) and then lifts its foot with
a knee bump; running swings longer than half the cycle, which leaves short flight phases.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .body import (
    FPS,
    LEFT_ANKLE,
    LEFT_ELBOW,
    LEFT_HIP,
    LEFT_KNEE,
    LEFT_SHOULDER,
    N_JOINTS,
    NECK,
    PELVIS,
    RIGHT_ANKLE,
    RIGHT_ELBOW,
    RIGHT_HIP,
    RIGHT_KNEE,
    RIGHT_SHOULDER,
    SPINE_LOW,
    SPINE_UP,
    count,
    draw,
    envelope,
    frames,
    min_jerk,
    mirror,
    pick,
    times_phrase,
)
from .rig import Plan, Segment

SPEEDS = ("slow", "normal", "fast")
_DEGREES = {90: "ninety", 180: "one hundred and eighty", 360: "three hundred and sixty"}


@dataclass
class GaitStyle:
    """How a gait cycle looks. Angles in degrees; ``cadence`` in steps per second (two steps per stride)."""

    cadence: float
    hip: float  # sagittal hip swing amplitude
    knee_swing: float  # extra knee flexion at mid-swing
    knee_stance: float = 3.0  # knee flexion kept during stance
    swing_start: float = 0.0  # the foot lifts while cos(phi) > -swing_start (0: half the cycle)
    arm: float = 15.0  # arm swing amplitude
    elbow: float = 15.0  # elbow flexion
    lean: float = 3.0  # forward trunk lean
    lateral: float = 0.0  # side-step hip swing (z angle), instead of the sagittal one


def _phase(env: np.ndarray, cadence: float, backward: bool = False) -> np.ndarray:
    """Stride phase ``(T,)``: integrates 2 pi (cadence / 2) env dt, so the gait starts and stops with ``env``."""
    step = 2.0 * np.pi * (cadence / 2.0) * env / FPS
    phi = np.concatenate([[0.0], np.cumsum(step[:-1])]) - np.pi / 2  # start with the legs together
    return -phi if backward else phi


def _swing_bump(phi: np.ndarray, start: float) -> np.ndarray:
    """0 during stance, rising to 1 at mid-swing: ``max(0, cos(phi) + start)^2 / (1 + start)^2``."""
    return np.maximum(0.0, np.cos(phi) + start) ** 2 / (1.0 + start) ** 2


def gait_angles(phi: np.ndarray, env: np.ndarray, style: GaitStyle) -> np.ndarray:
    """Joint angles ``(T, 22, 3)`` of a gait with stride phase ``phi`` (T,), faded in and out by ``env``."""
    out = np.zeros((len(phi), N_JOINTS, 3))
    d = np.deg2rad
    for hip, knee, ankle, shoulder, elbow, p in (
        (RIGHT_HIP, RIGHT_KNEE, RIGHT_ANKLE, RIGHT_SHOULDER, RIGHT_ELBOW, phi),
        (LEFT_HIP, LEFT_KNEE, LEFT_ANKLE, LEFT_SHOULDER, LEFT_ELBOW, phi + np.pi),
    ):
        bump = _swing_bump(p, style.swing_start)
        if style.lateral:  # side steps toward the right: both legs sweep to the right while swinging
            offset = 1.0 if hip == RIGHT_HIP else -1.0
            out[:, hip, 2] = -d(style.lateral) * (offset + np.sin(p)) * env
        else:
            out[:, hip, 0] = -d(style.hip) * np.sin(p) * env
        out[:, knee, 0] = d(style.knee_stance + style.knee_swing * bump) * env
        out[:, ankle, 0] = -d(12.0) * bump * env  # toes up while swinging, for clearance
        out[:, shoulder, 0] = d(style.arm) * np.sin(p) * env  # each arm swings with the opposite leg
        out[:, elbow, 0] = -d(style.elbow) * env
    out[:, PELVIS, 1] = d(0.25 * style.hip) * np.sin(phi) * env  # pelvis rotates with the stepping leg ...
    out[:, SPINE_UP, 1] = -d(0.3 * style.hip) * np.sin(phi) * env  # ... and the chest counter-rotates
    out[:, PELVIS, 2] = d(2.0) * np.cos(phi) * env  # small side-to-side sway
    out[:, SPINE_LOW, 0] = d(style.lean) * env
    out[:, NECK, 0] = -d(0.5 * style.lean) * env  # keep the gaze level
    return out


def _walk_style(speed: str, rng: np.random.Generator) -> GaitStyle:
    cadence, hip, knee = {"slow": (1.45, 17.0, 38.0), "normal": (1.8, 23.0, 48.0), "fast": (2.15, 28.0, 55.0)}[speed]
    j = rng.uniform(0.9, 1.1, size=3)
    return GaitStyle(cadence * j[0], hip * j[1], knee * j[2], arm=0.6 * hip * j[1], lean=2.0 + 2.0 * j[2])


def walk(rng, max_frames, *, direction=None, speed=None, path=None, duration=None) -> Segment:
    """Walk forward, backward or diagonally, on a straight or curved path, at one of three speeds."""
    direction = pick(rng, "direction", direction, ("forward", "forward", "backward", "diagonal_left", "diagonal_right"))
    speed = pick(rng, "speed", speed, SPEEDS)
    path = pick(rng, "path", path, ("straight", "straight", "curve_left", "curve_right"))
    if direction == "backward" and path != "straight":
        path = "straight"  # curved backward walks are rare in the real data and hard to caption
    duration = draw(rng, "duration", duration, 2.0, max(2.0, min(9.0, max_frames / FPS)))
    n = min(frames(duration), max_frames)
    style = _walk_style(speed, rng)
    if direction == "backward":
        style.hip *= 0.75
        style.cadence *= 0.85
    env = envelope(n, frames(0.6), frames(0.6))
    angles = gait_angles(_phase(env, style.cadence, backward=direction == "backward"), env, style)

    yaw = np.zeros(n)
    turn_rate = 0.0
    if direction.startswith("diagonal"):  # turn 45 degrees while setting off
        sign = 1.0 if direction == "diagonal_left" else -1.0
        yaw = sign * np.deg2rad(rng.uniform(35.0, 55.0)) * min_jerk(np.arange(n) / frames(1.0))
    if path != "straight":
        turn_rate = rng.uniform(20.0, 45.0) * (1.0 if path == "curve_left" else -1.0)  # degrees per second
        yaw = yaw + np.cumsum(np.deg2rad(turn_rate) * env / FPS)

    how = {
        "slow": ("slowly", "at a slow pace", "leisurely"),
        "normal": ("", "at a normal pace", "steadily"),
        "fast": ("quickly", "briskly", "at a fast pace"),
    }[speed]
    where = {
        "forward": ("forward", "forwards", "straight ahead"),
        "backward": ("backward", "backwards", "in reverse"),
        "diagonal_left": ("diagonally to the left", "forward and to the left", "diagonally left"),
        "diagonal_right": ("diagonally to the right", "forward and to the right", "diagonally right"),
    }[direction]
    curve = {"straight": "", "curve_left": "in a curve to the left", "curve_right": "in a curve to the right"}[path]
    verbs = ("walks", "strolls" if speed == "slow" else "walks", "moves" if speed != "fast" else "hurries")
    phrases = [" ".join(w for w in (verb, place, curve, adv) if w) for verb, place, adv in zip(verbs, where, how)]
    phrases.append(" ".join(w for w in ("takes a few steps", where[0], curve) if w))
    params = {
        "direction": direction,
        "speed": speed,
        "path": path,
        "turn_rate_deg_s": round(turn_rate, 2),
        "cadence": round(style.cadence, 3),
        "duration_s": round(n / FPS, 2),
    }
    return Segment(Plan.still(angles, yaw), phrases, params, stationary=False, continuous=True)


def run(rng, max_frames, *, speed=None, path=None, duration=None) -> Segment:
    """Run (with a flight phase between steps) straight or along a curve."""
    speed = pick(rng, "speed", speed, ("jog", "run", "sprint"))
    path = pick(rng, "path", path, ("straight", "straight", "curve_left", "curve_right"))
    longest = max(2.0, min(7.0, max_frames / FPS))
    duration = draw(rng, "duration", duration, min(3.0, longest), longest)  # at least a few strides at full speed
    n = min(frames(duration), max_frames)
    cadence, hip, knee = {"jog": (2.5, 28.0, 80.0), "run": (2.8, 35.0, 95.0), "sprint": (3.1, 42.0, 110.0)}[speed]
    j = rng.uniform(0.92, 1.08, size=3)
    style = GaitStyle(
        cadence * j[0],
        hip * j[1],
        knee * j[2],
        knee_stance=18.0,
        swing_start=0.45,
        arm=30.0,
        elbow=85.0,
        lean=8.0 + 4.0 * (speed == "sprint"),
    )
    env = envelope(n, frames(0.8), frames(0.8))
    phi = _phase(env, style.cadence)
    angles = gait_angles(phi, env, style)
    # Support while the foot is down (cos(phi) well below the swing threshold); flight when neither foot is.
    support = sum(min_jerk((-np.cos(p) - 0.35) / 0.2) for p in (phi, phi + np.pi))
    airborne = np.clip(1.0 - support, 0.0, 1.0) * (env > 0.95)
    lift = rng.uniform(0.03, 0.06) * airborne

    yaw, turn_rate = np.zeros(n), 0.0
    if path != "straight":
        turn_rate = rng.uniform(20.0, 40.0) * (1.0 if path == "curve_left" else -1.0)
        yaw = np.cumsum(np.deg2rad(turn_rate) * env / FPS)
    curve = {"straight": "forward", "curve_left": "in a curve to the left", "curve_right": "in a curve to the right"}
    where = curve[path]
    phrases = {
        "jog": [f"jogs {where}", f"runs {where} at an easy pace", f"jogs {where} lightly"],
        "run": [f"runs {where}", f"is running {where}", f"runs {where} at a steady pace"],
        "sprint": [f"sprints {where}", f"runs {where} very fast", f"dashes {where}"],
    }[speed]
    params = {
        "speed": speed,
        "path": path,
        "turn_rate_deg_s": round(turn_rate, 2),
        "cadence": round(style.cadence, 3),
        "duration_s": round(n / FPS, 2),
    }
    plan = Plan(angles, yaw, lift, airborne, np.full((n, 3), np.nan))
    return Segment(plan, phrases, params, stationary=False, continuous=True)


def side_step(rng, max_frames, *, direction=None, steps=None) -> Segment:
    """Side steps to the left or right without turning."""
    direction = pick(rng, "direction", direction, ("left", "right"))
    cadence = rng.uniform(1.2, 1.7)
    most = max(2, min(8, int((max_frames / FPS - 1.0) * cadence)))
    steps = count(rng, "steps", steps, 2, most)
    n = min(frames(steps / cadence + 1.0), max_frames)
    env = envelope(n, frames(0.5), frames(0.5))
    style = GaitStyle(cadence, 0.0, 35.0, lateral=rng.uniform(9.0, 13.0), arm=0.0, elbow=12.0, lean=2.0)
    angles = gait_angles(_phase(env, cadence), env, style)
    if direction == "left":
        angles = mirror(angles)
    sidestep = ("side steps", "sidesteps", "shuffles sideways")
    phrases = [f"{verb} to the {direction}" for verb in sidestep]
    phrases.append(f"steps sideways to the {direction} {times_phrase(steps)}")
    params = {"direction": direction, "steps": steps, "cadence": round(cadence, 3)}
    return Segment(Plan.still(angles), phrases, params, stationary=False)


def turn(rng, max_frames, *, direction=None, angle=None) -> Segment:
    """Turn in place by 90, 180 or 360 degrees, stepping around."""
    direction = pick(rng, "direction", direction, ("left", "right"))
    angle = pick(rng, "angle", angle, (90, 180, 360))
    rate = rng.uniform(90.0, 150.0)  # degrees per second
    n = min(frames(angle / rate + 0.6), max_frames)
    env = envelope(n, frames(0.3), frames(0.3))
    sign = 1.0 if direction == "left" else -1.0
    yaw = sign * np.deg2rad(angle) * min_jerk((np.arange(n) - frames(0.3)) / max(n - frames(0.6), 1))
    style = GaitStyle(rng.uniform(1.6, 2.1), 5.0, 30.0, arm=4.0, elbow=12.0, lean=1.0)
    angles = gait_angles(_phase(env, style.cadence), env, style)
    amount = {90: ("turns", "a quarter turn"), 180: ("turns around", "a half turn"), 360: ("spins", "a full turn")}
    verb, noun = amount[angle]
    phrases = [
        f"turns {_DEGREES[angle]} degrees to the {direction}",
        f"{verb} to the {direction}" if angle != 360 else f"turns all the way around to the {direction}",
        f"makes {noun} to the {direction}",
        f"turns {direction} in place",
    ]
    params = {"direction": direction, "angle": angle, "rate_deg_s": round(rate, 1)}
    return Segment(Plan.still(angles, yaw), phrases, params)
