"""Whole-body families in place: kick, squat and bow.

Squats keep the feet flat by giving the ankle the opposite of the shin's pitch: with hip flexion ``h`` and
knee flexion ``k`` the shin leans ``k - h`` forward, so the foot gets ``-(k - h)``; the rig's stance-foot
rule then moves the pelvis back over the heels by itself.
"""

from __future__ import annotations

from .body import FPS, count, draw, frames, keyframes, pick, pose, times_phrase, to_side
from .rig import Plan, Segment


def kick(rng, max_frames, *, side=None, reps=None, height=None) -> Segment:
    """Fast front kicks: chamber the knee, snap the leg straight, pull it back and put it down."""
    side = pick(rng, "side", side, ("right", "left"))
    height = pick(rng, "height", height, ("low", "high"))
    chamber_s, snap_s, back_s = rng.uniform(0.25, 0.4), rng.uniform(0.1, 0.16), rng.uniform(0.15, 0.25)
    period = chamber_s + snap_s + back_s + rng.uniform(0.35, 0.7)
    most = max(1, min(4, int((max_frames / FPS - 0.6) / period)))
    reps = count(rng, "reps", reps, 1, most)
    n = min(frames(reps * period + 0.6), max_frames)
    hip = 55.0 if height == "low" else 85.0
    hip *= rng.uniform(0.9, 1.1)
    base = pose(
        knee_l=(8, 0, 0),
        hip_l=(-4, 0, 0),
        ankle_l=(-4, 0, 0),
        shoulder_r=(-20, 0, 10),
        shoulder_l=(-20, 0, -10),
        elbow_r=(-80, 0, 0),
        elbow_l=(-80, 0, 0),
    )
    chamber = base + pose(hip_r=(-hip, 0, 0), knee_r=(100, 0, 0), ankle_r=(10, 0, 0), spine_low=(-5, 0, 0))
    snap = base + pose(hip_r=(-hip, 0, 0), knee_r=(5, 0, 0), ankle_r=(25, 0, 0), spine_low=(-12, 0, 0))
    times, keys = [0.0, 0.3], [pose(), base]
    for k in range(reps):
        t0 = 0.3 + k * period
        times += [t0 + chamber_s, t0 + chamber_s + snap_s, t0 + chamber_s + snap_s + back_s, t0 + period]
        keys += [chamber, snap, chamber, base]
    times.append(times[-1] + 0.3)
    keys.append(pose())
    angles = to_side(keyframes(n, times, keys), side)
    kick_word = "high kick" if height == "high" else "low kick"
    again = "" if reps == 1 else f" {times_phrase(reps)}"
    phrases = [
        f"kicks with the {side} leg{again}",
        f"kicks the {side} foot forward{again}",
        f"does a {kick_word} with the {side} leg",
        f"raises the {side} knee and kicks",
    ]
    params = {"side": side, "reps": reps, "height": height, "hip_deg": round(hip, 1), "snap_s": round(snap_s, 3)}
    return Segment(Plan.still(angles), phrases, params)


def squat(rng, max_frames, *, reps=None, depth=None) -> Segment:
    """Squat down and stand back up, arms forward for balance."""
    depth = draw(rng, "depth", depth, 0.5, 1.0)
    down_s, up_s = rng.uniform(0.7, 1.3), rng.uniform(0.6, 1.1)
    pause = rng.uniform(0.1, 0.5)
    period = down_s + up_s + pause
    most = max(1, min(5, int((max_frames / FPS - 0.3) / period)))
    reps = count(rng, "reps", reps, 1, most)
    n = min(frames(reps * period + 0.3), max_frames)
    h, k = 95.0 * depth, 120.0 * depth
    low = pose(
        hip_r=(-h, 0, -8),
        hip_l=(-h, 0, 8),
        knee_r=(k, 0, 0),
        knee_l=(k, 0, 0),
        ankle_r=(h - k, 0, 0),
        ankle_l=(h - k, 0, 0),
        spine_low=(30 * depth, 0, 0),
        spine_mid=(10 * depth, 0, 0),
        neck=(-20 * depth, 0, 0),
        shoulder_r=(-85 * depth, 0, 0),
        shoulder_l=(-85 * depth, 0, 0),
    )
    times, keys = [0.0], [pose()]
    for r in range(reps):
        t0 = 0.15 + r * period
        times += [t0 + down_s, t0 + down_s + pause, t0 + period]
        keys += [low, low, pose()]
    angles = keyframes(n, times, keys)
    deep = "deep " if depth > 0.8 else ""
    phrases = [
        f"squats {times_phrase(reps)}",
        f"does {deep}squats" if reps > 1 else f"does a {deep}squat",
        "bends the knees and squats down",
        f"crouches down and stands back up {times_phrase(reps)}",
    ]
    params = {"reps": reps, "depth": round(depth, 3), "down_s": round(down_s, 3), "up_s": round(up_s, 3)}
    return Segment(Plan.still(angles), phrases, params, stationary=False)


def bow(rng, max_frames, *, depth=None, reps=None) -> Segment:
    """Bow from the hips: the pelvis tilts, the spine follows, the arms keep hanging down."""
    depth = draw(rng, "depth", depth, 25.0, 75.0)
    move, hold = rng.uniform(0.6, 1.2), rng.uniform(0.3, 1.2)
    period = 2 * move + hold
    most = max(1, min(3, int((max_frames / FPS - 0.4) / period)))
    reps = count(rng, "reps", reps, 1, most)
    n = min(frames(reps * period + 0.4), max_frames)
    tilt = 0.5 * depth  # pelvis tilt; the thighs flex by as much so the legs stay vertical
    down = pose(
        pelvis=(tilt, 0, 0),
        hip_r=(-tilt, 0, 0),
        hip_l=(-tilt, 0, 0),
        spine_low=(0.25 * depth, 0, 0),
        spine_mid=(0.15 * depth, 0, 0),
        spine_up=(0.1 * depth, 0, 0),
        neck=(10, 0, 0),
        shoulder_r=(-0.9 * depth, 0, 0),
        shoulder_l=(-0.9 * depth, 0, 0),
    )
    times, keys = [0.0], [pose()]
    for r in range(reps):
        t0 = 0.2 + r * period
        times += [t0 + move, t0 + move + hold, t0 + period]
        keys += [down, down, pose()]
    angles = keyframes(n, times, keys)
    deep = "deeply " if depth > 55 else ""
    again = "" if reps == 1 else f" {times_phrase(reps)}"
    bows = " ".join(w for w in ("bows", deep.strip(), again.strip()) if w)
    phrases = [
        bows,
        f"bows forward{again}",
        "takes a bow" if reps == 1 else "takes bows",
        "bends forward at the waist and straightens up",
    ]
    params = {"depth_deg": round(depth, 1), "reps": reps, "hold_s": round(hold, 3)}
    return Segment(Plan.still(angles), phrases, params)
