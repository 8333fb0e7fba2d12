"""Jumping families: jumps (in place or forward) and jumping jacks.

A jump is keyframed (crouch, explosive extension, tuck in the air, absorbing landing); the rig lifts the
root along a ballistic parabola ``h(t) = v0 t - g t^2 / 2`` with ``v0 = g T_f / 2`` during the flight time
``T_f = 2 sqrt(2 H / g)`` of a jump of height ``H``, and marks those frames airborne so the feet leave the
floor and the root coasts (forward jumps coast with ``distance / T_f``).
"""

from __future__ import annotations

import numpy as np

from .body import FPS, count, draw, frames, keyframes, min_jerk, pick, pose, seconds, times_phrase
from .rig import Plan, Segment

GRAVITY = 9.81


def flight_time(height: float) -> float:
    """Seconds in the air of a ballistic jump reaching ``height`` metres: ``2 sqrt(2 H / g)``."""
    return 2.0 * np.sqrt(2.0 * height / GRAVITY)


def ballistic(n: int, takeoffs: list[float], height: float) -> tuple[np.ndarray, np.ndarray]:
    """Lift ``(n,)`` in metres and an airborne mask ``(n,)`` for jumps of ``height`` taking off at ``takeoffs`` (s)."""
    t = seconds(n)
    tf = flight_time(height)
    v0 = GRAVITY * tf / 2.0
    lift, air = np.zeros(n), np.zeros(n)
    for start in takeoffs:
        tau = t - start
        inside = (tau > 0) & (tau < tf)
        lift[inside] = v0 * tau[inside] - 0.5 * GRAVITY * tau[inside] ** 2
        # Soft edges (a frame wide) so the root's horizontal velocity blends into and out of the coast.
        air = np.maximum(air, min_jerk((tau + 0.5 / FPS) * FPS) * min_jerk((tf - tau + 0.5 / FPS) * FPS))
    return lift, air


def _jump_keys(t0: float, tf: float, rng: np.random.Generator, forward: bool):
    """Key times and poses of one jump whose take-off is at ``t0``."""
    crouch = rng.uniform(0.8, 1.2)
    lean = 15.0 if forward else 0.0
    stand = pose()
    down = pose(
        hip_r=(-50 * crouch - lean, 0, 0),
        hip_l=(-50 * crouch - lean, 0, 0),
        knee_r=(85 * crouch, 0, 0),
        knee_l=(85 * crouch, 0, 0),
        ankle_r=(-35 * crouch + lean, 0, 0),
        ankle_l=(-35 * crouch + lean, 0, 0),
        spine_low=(20 + lean, 0, 0),
        spine_mid=(10, 0, 0),
        shoulder_r=(40, 0, 0),
        shoulder_l=(40, 0, 0),
        elbow_r=(-20, 0, 0),
        elbow_l=(-20, 0, 0),
    )
    push = pose(
        ankle_r=(30, 0, 0),
        ankle_l=(30, 0, 0),
        shoulder_r=(-120, 0, 0),
        shoulder_l=(-120, 0, 0),
        spine_low=(lean / 2, 0, 0),
        elbow_r=(-10, 0, 0),
        elbow_l=(-10, 0, 0),
    )
    tuck = pose(
        hip_r=(-35, 0, 0),
        hip_l=(-35, 0, 0),
        knee_r=(50, 0, 0),
        knee_l=(50, 0, 0),
        ankle_r=(10, 0, 0),
        ankle_l=(10, 0, 0),
        shoulder_r=(-90, 0, 0),
        shoulder_l=(-90, 0, 0),
        spine_low=(10, 0, 0),
    )
    land = pose(
        hip_r=(-15, 0, 0),
        hip_l=(-15, 0, 0),
        knee_r=(20, 0, 0),
        knee_l=(20, 0, 0),
        ankle_r=(5, 0, 0),
        ankle_l=(5, 0, 0),
        shoulder_r=(-60, 0, 0),
        shoulder_l=(-60, 0, 0),
    )
    absorb = 0.8 * down + 0.2 * pose(shoulder_r=(-40, 0, 0), shoulder_l=(-40, 0, 0))
    times = [t0 - 0.65, t0 - 0.2, t0, t0 + tf / 2, t0 + tf, t0 + tf + 0.25, t0 + tf + 0.75]
    return times, [stand, down, push, tuck, land, absorb, stand]


def jump(rng, max_frames, *, mode=None, reps=None, height=None, distance=None) -> Segment:
    """Jump in place or forward, one to four times."""
    mode = pick(rng, "mode", mode, ("in_place", "forward"))
    height = draw(rng, "height", height, 0.12, 0.35)
    tf = flight_time(height)
    period = tf + 1.15 + rng.uniform(0.0, 0.3)
    most = max(1, min(4, int((max_frames / FPS - 0.8) / period)))
    reps = count(rng, "reps", reps, 1, most)
    n = min(frames(reps * period + 0.8), max_frames)
    takeoffs = [0.75 + k * period for k in range(reps)]
    times, keys = [], []
    for t0 in takeoffs:
        kt, kp = _jump_keys(t0, tf, rng, mode == "forward")
        times += kt
        keys += kp
    order = np.argsort(times, kind="stable")
    angles = keyframes(n, np.asarray(times)[order], np.asarray(keys)[order])
    lift, air = ballistic(n, takeoffs, height)
    coast = np.full((n, 3), np.nan)
    if mode == "forward":
        distance = draw(rng, "distance", distance, 0.4, 1.1)
        coast[:] = (0.0, 0.0, distance / tf)
    else:
        distance = 0.0
        coast[:] = 0.0
    coast[air == 0] = np.nan  # grounded frames follow the feet
    times_txt = times_phrase(reps)
    if mode == "forward":
        phrases = [
            f"jumps forward {times_txt}",
            f"leaps forward {times_txt}",
            f"hops forward {times_txt}",
            "jumps ahead" if reps == 1 else f"jumps ahead {times_txt}",
        ]
    else:
        phrases = [f"jumps up and down {times_txt}", f"jumps in place {times_txt}", f"jumps straight up {times_txt}"]
    params = {"mode": mode, "reps": reps, "height_m": round(height, 3), "distance_m": round(distance, 3)}
    return Segment(Plan(angles, np.zeros(n), lift, air, coast), phrases, params, stationary=False)


def jumping_jacks(rng, max_frames, *, reps=None) -> Segment:
    """Jumping jacks: hop the feet apart while raising the arms overhead, then hop back."""
    hop = draw(rng, "hop height", None, 0.04, 0.08)
    tf = flight_time(hop)
    period = rng.uniform(0.9, 1.3)  # one rep = out and in
    most = max(2, min(10, int((max_frames / FPS - 0.6) / period)))
    reps = count(rng, "reps", reps, 2, most)
    n = min(frames(reps * period + 0.6), max_frames)
    spread = rng.uniform(10.0, 15.0)
    closed = pose()
    open_ = pose(
        hip_r=(0, 0, -spread),
        hip_l=(0, 0, spread),
        ankle_r=(5, 0, 0),
        ankle_l=(5, 0, 0),
        shoulder_r=(0, 0, -160),
        shoulder_l=(0, 0, 160),
        elbow_r=(-15, 0, 0),
        elbow_l=(-15, 0, 0),
    )
    dip = pose(
        hip_r=(-12, 0, 0),
        hip_l=(-12, 0, 0),
        knee_r=(22, 0, 0),
        knee_l=(22, 0, 0),
        ankle_r=(-10, 0, 0),
        ankle_l=(-10, 0, 0),
    )
    takeoffs, times, keys = [], [0.0], [closed]
    for k in range(2 * reps):
        t0 = 0.3 + k * period / 2
        takeoffs.append(t0)
        target = open_ if k % 2 == 0 else closed
        times += [t0 + tf, t0 + tf + 0.12]
        keys += [target, target + dip]  # land, then bend the knees to absorb
    times.append(times[-1] + 0.3)
    keys.append(closed)
    angles = keyframes(n, times, keys)
    lift, air = ballistic(n, takeoffs, hop)
    coast = np.where(air[:, None] > 0, 0.0, np.nan) * np.ones((n, 3))
    phrases = [
        f"does {_NUMBERS[reps]} jumping jacks",
        "does jumping jacks",
        f"performs jumping jacks {times_phrase(reps)}",
        "jumps while spreading the legs and raising the arms above the head",
    ]
    params = {"reps": reps, "hop_m": round(hop, 3), "period_s": round(period, 3), "spread_deg": round(spread, 1)}
    return Segment(Plan(angles, np.zeros(n), lift, air, coast), phrases, params, stationary=False)


_NUMBERS = {2: "two", 3: "three", 4: "four", 5: "five", 6: "six", 7: "seven", 8: "eight", 9: "nine", 10: "ten"}
