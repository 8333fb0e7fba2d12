"""One clip of the embedded dataset: pick an action (or two), author it, vary it, pose it, caption it.

Every clip is a pure function of its family name(s), its overrides and the random generator it is given:
the dataset writer hands each clip its own ``np.random.Generator`` (seeded by ``(seed, index)``), so clips
can be built in any order or in parallel and the bytes on disk stay the same.

The dataset's clips are *windows of takes*, as real HumanML3D clips are windows of longer AMASS takes
(:func:`make_take`): most begin and end while the body moves, in the middle of a stride or of a move from or
to another posture, instead of standing still before and after the action.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from . import arms, jumps, locomotion, whole_body
from .body import FPS, N_JOINTS, frames, min_jerk, smooth_noise
from .captions import make_captions
from .rig import Plan, Segment, realise

VERSION = 3  # bump whenever the generated data changes, so cached datasets are regenerated
MIN_FRAMES, MAX_FRAMES = 41, 197  # poses per clip: 40..196 feature rows, HumanML3D's evaluation range

FamilyFn = Callable[..., Segment]
FAMILIES: dict[str, FamilyFn] = {
    "walk": locomotion.walk,
    "run": locomotion.run,
    "side_step": locomotion.side_step,
    "turn": locomotion.turn,
    "jump": jumps.jump,
    "jumping_jacks": jumps.jumping_jacks,
    "wave": arms.wave,
    "circle_arm": arms.circle_arm,
    "raise_arms": arms.raise_arms,
    "clap": arms.clap,
    "punch": arms.punch,
    "kick": whole_body.kick,
    "squat": whole_body.squat,
    "bow": whole_body.bow,
}

# How much smooth, low-pass wobble (degrees) each bone gets on top of the authored motion.
_WOBBLE = np.full(N_JOINTS, 1.0)
_WOBBLE[[0, 4, 5, 7, 8, 10, 11]] = 0.6  # pelvis and legs: small, so feet stay convincing
_WOBBLE[[3, 6, 9, 12, 15]] = 1.5  # spine, neck, head
_WOBBLE[[13, 14, 16, 17]] = 1.0
_WOBBLE[[18, 19, 20, 21]] = 2.5  # arms

# Fine structure: the small, fast movement real capture has (physiological tremor, postural corrections,
# soft-tissue and marker motion), as near-white per-bone angle noise. Without it the sJPE joints' jerk has
# median 18 m/s³ and 10th percentile 0.7, against 70 and 12 pooled over real HumanML3D and CMU clips, so any
# decoder wiggle counts as "noise". 0.07° over a 0.7-frame blur, scaled per clip by a log-normal factor
# (σ = 0.5: takes differ) and within a clip by a slow log-normal envelope (σ = 0.6 over ~0.5 s: it waxes and
# wanes) gives median 76 and 10th percentile 15 (90th: 517, set by the authored punches and kicks, not by this).
FINE_DEGREES, FINE_SIGMA_FRAMES, FINE_SPREAD, FINE_ENVELOPE = 0.07, 0.7, 0.5, 0.6
_FINE = np.full(N_JOINTS, 1.0)
_FINE[[4, 5, 7, 8, 10, 11]] = 2.0  # legs: real feet keep jerking while they stand
_FINE[[0, 3, 6, 9, 12, 15]] = 0.6  # pelvis and spine: every joint above them inherits it
_FINE[[13, 14, 16, 17, 18, 19, 20, 21]] = 0.6  # arms: long chains accumulate it at the wrists

# Cuts: real clips are windows of longer takes, so most begin and end while the body moves (of the two HumanML3D
# clips in ../shared/data all four ends move; the three CMU takes, whole "start, walk, stop" recordings, mostly
# start and stop at rest). Each end of a clip is cut with probability CUT_SHARE, independently. A walk or a run
# is cut into: the clip leaves out a share GAIT_CUT of its movement at that end, so it starts or stops mid-stride.
# Any other action is counted or has a goal ("waves three times", "turns ninety degrees"), so it is kept whole;
# instead the take holds a move from (or to) a posture of some other action before (or after) it, MOVE_SECONDS
# long, of which the clip shows the last (or first) share MOVE_SHOWN, so it starts or stops mid-move.
CUT_SHARE = 0.7
GAIT_CUT = (0.02, 0.25)
MOVE_SECONDS, MOVE_SHOWN = (0.5, 1.2), (0.3, 0.8)


@dataclass
class EmbeddedClip:
    """A generated clip: joint positions (T, 22, 3) in metres at 20 fps and its captions."""

    joints: np.ndarray  # (T, 22, 3) float64
    captions: list[str]
    family: str  # the (first) action's family
    params: dict
    families: tuple[str, ...] = field(default=())  # every action in order; one entry for single actions

    @property
    def single_action(self) -> bool:
        return len(self.families) <= 1


def parse_family(family: str) -> tuple[str, ...]:
    """``"walk"`` -> ("walk",); ``"walk+wave"`` -> ("walk", "wave"); unknown names raise ``ValueError``."""
    names = tuple(part.strip() for part in str(family).split("+"))
    unknown = [n for n in names if n not in FAMILIES]
    if unknown or not 1 <= len(names) <= 2:
        raise ValueError(f"family must be one of {sorted(FAMILIES)} or two joined by '+', got {family!r}")
    return names


def _call_family(name: str, rng: np.random.Generator, budget: int, overrides: dict) -> Segment:
    fn = FAMILIES[name]
    accepted = set(inspect.signature(fn).parameters) - {"rng", "max_frames"}
    mine = {k: v for k, v in overrides.items() if k in accepted}
    return fn(rng, budget, **mine)


def _vary(rng: np.random.Generator, angles: np.ndarray, fine_rng: np.random.Generator | None) -> np.ndarray:
    """Add low-pass per-bone wobble, a slow postural sway and (from ``fine_rng``, unless None) the fine structure
    of real capture."""
    n = len(angles)
    wobble = smooth_noise(rng, (n, N_JOINTS, 3), sigma_frames=6.0, scale=1.0) * np.deg2rad(_WOBBLE)[:, None]
    sway = smooth_noise(rng, (n, 3), sigma_frames=20.0, scale=np.deg2rad(1.2))
    out = angles + wobble
    out[:, 3] += sway  # lower spine sways
    out[:, 12] -= 0.5 * sway  # the neck half-compensates so the head stays level
    return out if fine_rng is None else out + fine_structure(fine_rng, n)


def fine_structure(child: np.random.Generator, n_frames: int) -> np.ndarray:
    """Near-white per-bone angle noise ``(n_frames, 22, 3)`` in radians, the fine motion real capture has.

    ``child`` is a generator spawned off the clip's own: spawning does not advance the clip's generator, so every
    other draw of a clip (its action, parameters and captions) is the same with or without it.
    """
    level = FINE_DEGREES * np.exp(FINE_SPREAD * child.standard_normal())
    waxing = np.exp(FINE_ENVELOPE * smooth_noise(child, (n_frames, 1, 1), sigma_frames=10.0, scale=1.0))  # (T, 1, 1)
    noise = smooth_noise(child, (n_frames, N_JOINTS, 3), sigma_frames=FINE_SIGMA_FRAMES, scale=1.0)
    return noise * waxing * np.deg2rad(level * _FINE)[:, None]


def movement(plan: Plan) -> np.ndarray:
    """Cumulative authored movement ``(T,)`` of a plan in radians: the change of every bone's angles, summed over
    the bones, plus the change of heading, from the first frame up to each frame."""
    step = np.abs(np.diff(plan.angles, axis=0)).sum(axis=(1, 2)) + np.abs(np.diff(plan.yaw))
    return np.concatenate([[0.0], np.cumsum(step)])


def _elsewhere(rng: np.random.Generator) -> np.ndarray:
    """Angles ``(22, 3)`` of some action in full swing (a grounded frame of the middle 60 % of its movement,
    not its rest pose at either end): a posture a performer comes from or goes on to."""
    plan = FAMILIES[list(FAMILIES)[int(rng.integers(len(FAMILIES)))]](rng, MAX_FRAMES).plan
    moved = movement(plan)
    middle = (moved >= 0.2 * moved[-1]) & (moved <= 0.8 * moved[-1])
    candidates = np.flatnonzero(middle & (plan.airborne == 0) & (plan.lift == 0))
    return plan.angles[int(rng.choice(candidates))]


def _move(start: np.ndarray, end: np.ndarray, n: int, *, arriving: bool) -> np.ndarray:
    """``n`` frames ``(n, 22, 3)`` of a minimum-jerk move from pose ``start`` to ``end``: without the last pose
    (``arriving``: the action starts there) or without the first (it is the action's last)."""
    s = min_jerk((np.arange(n) + (0 if arriving else 1)) / n)[:, None, None]
    return start + s * (end - start)


@dataclass
class Take:
    """A clip as a window of a longer take: ``plan[start:stop]``, and what each end of the window shows:
    ``"rest"`` (standing still before or after the whole action), ``"gait"`` (mid-stride in a walk or run)
    or ``"move"`` (mid-way through a move from or to another posture)."""

    plan: Plan
    start: int
    stop: int
    actions: tuple[int, int]  # where the actions lie in the take: plan[actions[0]:actions[1]]
    ends: tuple[str, str]

    @property
    def idle(self) -> tuple[int, int]:
        """Frames the window holds still before the actions begin and after they end."""
        before = self.actions[0] - self.start if self.ends[0] == "rest" else 0
        after = self.stop - max(self.actions[1], self.start) if self.ends[1] == "rest" else 0
        return max(0, before), max(0, after)

    @property
    def window(self) -> Plan:
        p, w = self.plan, slice(self.start, self.stop)
        return Plan(p.angles[w], p.yaw[w], p.lift[w], p.airborne[w], p.coast[w])


def make_take(
    rng: np.random.Generator | None,
    segments: list[Segment],
    actions: Plan,
    idle: tuple[int, int],
    length: tuple[int, int],
) -> Take:
    """The take around ``actions`` (the segments' plans, chained) and the window a clip shows of it.

    Each end is cut with probability :data:`CUT_SHARE` (see there for how); an end that is not cut, and every
    end when ``rng`` is None, holds still for ``idle`` frames (before, after) around the whole action. The
    window's length is then brought into ``length`` (low, high): showing less of what follows the actions and
    then of what precedes them, or stopping early; or showing more of what follows, then holding still.
    """
    cut = rng.random(2) < CUT_SHARE if rng is not None else (False, False)
    ends = ["rest", "rest"]
    if not cut[0]:
        take, start = actions.pad(idle[0], 0), 0
    elif segments[0].continuous:
        moved = movement(segments[0].plan)
        take, start, ends[0] = actions, int(np.searchsorted(moved, rng.uniform(*GAIT_CUT) * moved[-1])), "gait"
    else:
        n = frames(rng.uniform(*MOVE_SECONDS))
        move = Plan.still(_move(_elsewhere(rng), actions.angles[0], n, arriving=True), np.full(n, actions.yaw[0]))
        take, start, ends[0] = move.then(actions), n - max(1, round(rng.uniform(*MOVE_SHOWN) * n)), "move"
    first, last = len(take) - len(actions), len(take)  # where the actions lie in the take
    if not cut[1]:
        take, stop = take.pad(0, idle[1]), last + idle[1]
    elif segments[-1].continuous:
        moved = movement(segments[-1].plan)
        left_out = int(np.searchsorted(moved[-1] - moved[::-1], rng.uniform(*GAIT_CUT) * moved[-1]))
        stop, ends[1] = last - left_out, "gait"
    else:
        n = frames(rng.uniform(*MOVE_SECONDS))
        move = Plan.still(_move(actions.angles[-1], _elsewhere(rng), n, arriving=False), np.full(n, actions.yaw[-1]))
        take, stop, ends[1] = take.then(move), last + max(1, round(rng.uniform(*MOVE_SHOWN) * n)), "move"

    low, high = length
    excess = stop - start - high
    if excess > 0:  # too long: show less of what follows the actions, then of what precedes them, then stop early
        trim = min(excess, max(0, stop - last))
        stop, excess = stop - trim, excess - trim
        trim = min(excess, max(0, first - start))
        start, stop = start + trim, stop - (excess - trim)
    if stop - start < low:  # too short: show more of what follows (every take ends at rest), then hold still
        take = take.pad(0, max(0, start + low - len(take)))
        stop = start + low
    return Take(take, start, stop, (first, last), (ends[0], ends[1]))


def generate_clip(
    family: str, rng: np.random.Generator, *, fine: bool = True, cuts: bool = False, **overrides
) -> EmbeddedClip:
    """Generate one clip of ``family`` (a name from :data:`FAMILIES`, or two joined by ``"+"``).

    ``overrides`` fix parameters instead of drawing them: any keyword of the family functions (e.g.
    ``direction="backward"``, ``side="left"``, ``reps=3``) plus ``n_frames`` (total poses, 41..197).
    By default the clip shows the whole action, from rest to rest; ``cuts=True`` makes it a window of a longer
    take (:func:`make_take`), as the dataset's clips are since version 3. ``fine=False`` leaves out the
    :func:`fine_structure`. Every other draw stays the same either way, so without ``n_frames`` the default gives
    the clips of version 2, and ``fine=False`` those of version 1, for comparison.
    """
    names = parse_family(family)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    overrides = dict(overrides)
    n_frames = overrides.pop("n_frames", None)
    if n_frames is not None and (int(n_frames) != n_frames or not MIN_FRAMES <= n_frames <= MAX_FRAMES):
        raise ValueError(f"n_frames must be an integer in [{MIN_FRAMES}, {MAX_FRAMES}], got {n_frames!r}")
    known = set().union(*(set(inspect.signature(FAMILIES[n]).parameters) for n in names)) - {"rng", "max_frames"}
    if set(overrides) - known:
        raise ValueError(f"unknown parameters {sorted(set(overrides) - known)} for {family!r}; known: {sorted(known)}")

    total = MAX_FRAMES if n_frames is None else int(n_frames)
    lead_in, lead_out = frames(rng.uniform(0.1, 0.9)), frames(rng.uniform(0.1, 0.7))
    gap = frames(rng.uniform(0.0, 0.4)) if len(names) == 2 else 0
    budget = max(total - lead_in - lead_out - gap, MIN_FRAMES // 2)
    segments = [_call_family(name, rng, budget // len(names), overrides) for name in names]

    plan: Plan = segments[0].plan
    if len(segments) == 2:
        plan = plan.pad(0, gap).then(segments[1].plan)
    # Spawned children do not advance rng; the fine structure's is the first, as in version 2.
    fine_rng, cut_rng = rng.spawn(2)
    low, high = (MIN_FRAMES, MAX_FRAMES) if n_frames is None else (total, total)
    take = make_take(cut_rng if cuts else None, segments, plan, (lead_in, lead_out), (low, high))
    # Only the window is varied and realised: the rig places the feet, the floor and the root frame by frame, so
    # the frames of the take outside it would change next to nothing (and cost time).
    window = take.window
    window = Plan(
        _vary(rng, window.angles, fine_rng if fine else None), window.yaw, window.lift, window.airborne, window.coast
    )
    joints = realise(window)
    lead_in, lead_out = take.idle
    stationary = all(s.stationary for s in segments)
    captions = make_captions(rng, [s.phrases for s in segments], stationary, lead_in / FPS, int(rng.integers(3, 6)))
    if len(segments) == 1:
        params = dict(segments[0].params)
    else:
        params = {"actions": [{"family": n, **s.params} for n, s in zip(names, segments)]}
    params.update(
        lead_in_s=round(lead_in / FPS, 2), lead_out_s=round(lead_out / FPS, 2), starts=take.ends[0], ends=take.ends[1]
    )
    return EmbeddedClip(joints, captions, names[0], params, names)
