"""Upper-body families done while standing: wave, arm circles, raising the arms, clapping and punching.

Each is authored for the right arm and retargeted with :func:`body.to_side` (the left arm is the mirror
image; "both" adds the mirrored arm). A light knee and trunk sway keeps the legs from looking frozen.
"""

from __future__ import annotations

import numpy as np

from .body import (
    FPS,
    LEFT_ARM,
    N_JOINTS,
    RIGHT_ARM,
    RIGHT_ELBOW,
    RIGHT_SHOULDER,
    SIDES,
    count,
    envelope,
    frames,
    keyframes,
    pick,
    pose,
    seconds,
    times_phrase,
    to_side,
)
from .rig import Plan, Segment

_ARMS = RIGHT_ARM  # the bones a right-sided movement drives


def _hand(side: str) -> str:
    return "both hands" if side == "both" else f"the {side} hand"


def _arm(side: str) -> str:
    return "both arms" if side == "both" else f"the {side} arm"


def wave(rng, max_frames, *, side=None, reps=None, height=None) -> Segment:
    """Raise a hand and wave it from side to side."""
    side = pick(rng, "side", side, ("right", "right", "left", "both"))
    height = pick(rng, "height", height, ("shoulder", "overhead"))
    freq = rng.uniform(1.5, 3.0)  # waves per second
    most = max(2, min(8, int((max_frames / FPS - 1.4) * freq)))
    reps = count(rng, "reps", reps, 2, most)
    n = min(frames(reps / freq + 1.4), max_frames)
    abduct = rng.uniform(85.0, 110.0) if height == "shoulder" else rng.uniform(140.0, 160.0)
    raised = pose(shoulder_r=(-15, 0, -abduct), elbow_r=(0, 0, -(180.0 - abduct)))
    angles = keyframes(n, [0.0, 0.6, n / FPS - 0.7, n / FPS - 0.05], [pose(), raised, raised, pose()])
    t = seconds(n) - 0.6
    swing = np.deg2rad(rng.uniform(18.0, 30.0)) * np.sin(2 * np.pi * freq * t) * envelope(n, frames(0.7), frames(0.8))
    angles[:, RIGHT_ELBOW, 2] += swing
    angles = to_side(angles, side, _ARMS)
    hand, arm = _hand(side), _arm(side)
    up = "above the head" if height == "overhead" else "at shoulder height"
    phrases = [
        f"waves {hand}",
        f"waves with {hand} {times_phrase(reps)}",
        f"raises {arm} and waves",
        f"waves hello with {hand} {up}",
    ]
    params = {"side": side, "reps": reps, "height": height, "freq_hz": round(freq, 3)}
    return Segment(Plan.still(angles), phrases, params)


def circle_arm(rng, max_frames, *, side=None, direction=None, size=None, reps=None) -> Segment:
    """Swing an arm in big windmill circles, or hold it out and draw small circles."""
    side = pick(rng, "side", side, SIDES)
    direction = pick(rng, "direction", direction, ("forward", "backward"))
    size = pick(rng, "size", size, ("big", "small"))
    freq = rng.uniform(0.6, 1.0) if size == "big" else rng.uniform(1.2, 2.0)  # circles per second
    most = max(2, min(6, int((max_frames / FPS - 1.2) * freq)))
    reps = count(rng, "reps", reps, 2, most)
    n = min(frames(reps / freq + 1.2), max_frames)
    env = envelope(n, frames(0.6), frames(0.6))
    # The phase runs exactly reps turns: a normalised cumulative envelope keeps the speed ramp smooth.
    theta = 2 * np.pi * reps * np.cumsum(env) / env.sum()
    sign = -1.0 if direction == "forward" else 1.0  # forward circles swing the arm up in front first
    angles = np.zeros((n, N_JOINTS, 3))
    if size == "big":
        angles[:, RIGHT_SHOULDER, 0] = sign * theta
        angles[:, RIGHT_SHOULDER, 2] = -np.deg2rad(15.0) * env
    else:
        radius = np.deg2rad(rng.uniform(12.0, 20.0))
        angles[:, RIGHT_SHOULDER, 0] = sign * radius * np.sin(theta) * env
        angles[:, RIGHT_SHOULDER, 2] = -np.deg2rad(90.0) * env + radius * (np.cos(theta) - 1.0) * env
    angles[:, RIGHT_ELBOW, 0] = -np.deg2rad(8.0) * env
    angles = to_side(angles, side, _ARMS)
    arm = _arm(side)
    kind = "big circles" if size == "big" else "small circles"
    phrases = [
        f"moves {arm} in {kind}",
        f"rotates {arm} {direction} {times_phrase(reps)}",
        f"makes {kind} with {arm}",
        f"swings {arm} around in {direction} circles",
    ]
    params = {"side": side, "direction": direction, "size": size, "reps": reps, "freq_hz": round(freq, 3)}
    return Segment(Plan.still(angles), phrases, params)


def raise_arms(rng, max_frames, *, side=None, direction=None, reps=None) -> Segment:
    """Raise one or both arms forward, sideways or overhead, hold, and lower them again."""
    side = pick(rng, "side", side, ("both", "both", "left", "right"))
    direction = pick(rng, "direction", direction, ("forward", "sideways", "overhead"))
    hold = rng.uniform(0.3, 1.5)
    move = rng.uniform(0.6, 1.2)
    period = 2 * move + hold + rng.uniform(0.1, 0.4)
    most = max(1, min(3, int((max_frames / FPS - 0.2) / period)))
    reps = count(rng, "reps", reps, 1, most)
    n = min(frames(reps * period + 0.2), max_frames)
    up = {
        "forward": pose(shoulder_r=(-90, 0, 5), elbow_r=(-5, 0, 0)),
        "sideways": pose(shoulder_r=(0, 0, -90), elbow_r=(-5, 0, 0)),
        "overhead": pose(shoulder_r=(-170, 0, 5), elbow_r=(-5, 0, 0)),
    }[direction]
    up = up * rng.uniform(0.9, 1.05)
    times, keys = [0.0], [pose()]
    for k in range(reps):
        t0 = 0.1 + k * period
        times += [t0 + move, t0 + move + hold, t0 + 2 * move + hold]
        keys += [up, up, pose()]
    angles = to_side(keyframes(n, times, keys), side, _ARMS)
    arm = _arm(side)
    where = {"forward": "forward", "sideways": "out to the side", "overhead": "above the head"}[direction]
    again = "" if reps == 1 else f" {times_phrase(reps)}"
    phrases = [
        f"raises {arm} {where}{again}",
        f"lifts {arm} {where} and lowers {'them' if side == 'both' else 'it'}",
        f"holds {arm} {where} for a moment",
        f"puts {arm} up {where}{again}",
    ]
    params = {"side": side, "direction": direction, "reps": reps, "hold_s": round(hold, 3), "move_s": round(move, 3)}
    return Segment(Plan.still(angles), phrases, params)


def clap(rng, max_frames, *, reps=None, speed=None) -> Segment:
    """Clap the hands in front of the chest."""
    speed = pick(rng, "speed", speed, ("slow", "fast"))
    freq = rng.uniform(1.2, 1.8) if speed == "slow" else rng.uniform(2.5, 3.5)  # claps per second
    most = max(2, min(10, int((max_frames / FPS - 1.2) * freq)))
    reps = count(rng, "reps", reps, 2, most)
    n = min(frames(reps / freq + 1.2), max_frames)
    ready = pose(shoulder_r=(-55, 0, -20), elbow_r=(-75, 0, 0))
    angles = keyframes(n, [0.0, 0.55, n / FPS - 0.6, n / FPS - 0.05], [pose(), ready, ready, pose()])
    t = np.clip(seconds(n) - 0.55, 0.0, reps / freq)
    # |sin| has a sharp corner at each clap: the hands stop abruptly when they meet, as in a real clap.
    closing = (1.0 - np.abs(np.sin(np.pi * freq * t))) * (t > 0) * (t < reps / freq)
    angles[:, RIGHT_SHOULDER, 2] += np.deg2rad(32.0) * closing * envelope(n, frames(0.5), frames(0.6))
    angles = to_side(angles, "both", _ARMS)
    how = "quickly" if speed == "fast" else "slowly"
    phrases = [
        f"claps {times_phrase(reps)}",
        f"claps the hands {how}",
        "claps the hands in front of the chest",
        f"applauds {how}",
    ]
    params = {"reps": reps, "speed": speed, "freq_hz": round(freq, 3)}
    return Segment(Plan.still(angles), phrases, params)


def punch(rng, max_frames, *, side=None, reps=None) -> Segment:
    """Fast punches from a boxing guard: one fist, or alternating fists."""
    side = pick(rng, "side", side, ("right", "left", "alternating"))
    strike, back = rng.uniform(0.1, 0.18), rng.uniform(0.18, 0.3)
    gap = rng.uniform(0.15, 0.5)
    period = strike + back + gap
    most = max(1, min(8, int((max_frames / FPS - 1.4) / period)))
    reps = count(rng, "reps", reps, 1, most)
    n = min(frames(reps * period + 1.4), max_frames)
    guard_r = pose(shoulder_r=(-25, 0, 12), elbow_r=(-130, 0, 0))
    guard = to_side(guard_r[None], "both", _ARMS)[0] + pose(
        knee_r=(10, 0, 0), knee_l=(10, 0, 0), hip_r=(-6, 0, 0), hip_l=(-6, 0, 0), ankle_r=(-4, 0, 0), ankle_l=(-4, 0, 0)
    )
    hit_r = pose(shoulder_r=(-85, 0, 8), elbow_r=(-5, 0, 0), spine_up=(0, 18, 0), spine_mid=(0, 8, 0))
    times, keys = [0.0, 0.6], [pose(), guard]
    for k in range(reps):
        t0 = 0.6 + gap + k * period
        use_left = side == "left" or (side == "alternating" and k % 2 == 1)
        strike_pose = guard.copy()
        hit = to_side(hit_r[None], "left" if use_left else "right")[0]
        arm = LEFT_ARM if use_left else RIGHT_ARM
        strike_pose[list(arm)] = hit[list(arm)]
        strike_pose[[6, 9]] = hit[[6, 9]]
        times += [t0 + strike, t0 + strike + back]
        keys += [strike_pose, guard]
    times += [times[-1] + 0.6]
    keys += [pose()]
    angles = keyframes(n, times, keys)
    fists = "both fists" if side == "alternating" else f"the {side} fist"
    phrases = [
        f"punches with {fists} {times_phrase(reps)}",
        f"throws punches with {fists}",
        f"jabs forward with {fists}",
        f"boxes, punching with {fists}",
    ]
    if side == "alternating":
        phrases.append("punches alternating the left and right hands")
    params = {"side": side, "reps": reps, "strike_s": round(strike, 3), "retract_s": round(back, 3)}
    return Segment(Plan.still(angles), phrases, params)
