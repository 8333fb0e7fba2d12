"""One clip of the embedded dataset: pick an action (or two), author it, vary it, pose it, caption it.

Every clip is a pure function of its family name(s), its overrides and the random generator it is given:
the dataset writer hands each clip its own ``np.random.Generator`` (seeded by ``(seed, index)``), so clips
can be built in any order or in parallel and the bytes on disk stay the same.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from . import arms, jumps, locomotion, whole_body
from .body import FPS, N_JOINTS, frames, smooth_noise
from .captions import make_captions
from .rig import Plan, Segment, realise

VERSION = 2  # bump whenever the generated data changes, so cached datasets are regenerated
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


def _vary(rng: np.random.Generator, angles: np.ndarray, fine: bool = True) -> np.ndarray:
    """Add low-pass per-bone wobble, a slow postural sway and (if ``fine``) the fine structure of real capture."""
    n = len(angles)
    wobble = smooth_noise(rng, (n, N_JOINTS, 3), sigma_frames=6.0, scale=1.0) * np.deg2rad(_WOBBLE)[:, None]
    sway = smooth_noise(rng, (n, 3), sigma_frames=20.0, scale=np.deg2rad(1.2))
    out = angles + wobble
    out[:, 3] += sway  # lower spine sways
    out[:, 12] -= 0.5 * sway  # the neck half-compensates so the head stays level
    return out + fine_structure(rng, n) if fine else out


def fine_structure(rng: np.random.Generator, n_frames: int) -> np.ndarray:
    """Near-white per-bone angle noise ``(n_frames, 22, 3)`` in radians, the fine motion real capture has.

    Drawn from a generator spawned off ``rng``: spawning does not advance ``rng``, so every other draw of a
    clip (its action, parameters and captions) is the same with or without it.
    """
    child = rng.spawn(1)[0]
    level = FINE_DEGREES * np.exp(FINE_SPREAD * child.standard_normal())
    waxing = np.exp(FINE_ENVELOPE * smooth_noise(child, (n_frames, 1, 1), sigma_frames=10.0, scale=1.0))  # (T, 1, 1)
    noise = smooth_noise(child, (n_frames, N_JOINTS, 3), sigma_frames=FINE_SIGMA_FRAMES, scale=1.0)
    return noise * waxing * np.deg2rad(level * _FINE)[:, None]


def generate_clip(family: str, rng: np.random.Generator, *, fine: bool = True, **overrides) -> EmbeddedClip:
    """Generate one clip of ``family`` (a name from :data:`FAMILIES`, or two joined by ``"+"``).

    ``overrides`` fix parameters instead of drawing them: any keyword of the family functions (e.g.
    ``direction="backward"``, ``side="left"``, ``reps=3``) plus ``n_frames`` (total poses, 41..197).
    ``fine=False`` leaves out the :func:`fine_structure` (every other draw stays the same): the data as it was
    before version 2, for comparison.
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
    body = len(plan)
    target = max(MIN_FRAMES, body + lead_in + lead_out) if n_frames is None else total
    if body + lead_in > target:  # the actions fill the requested length: shorten the idle lead-in
        lead_in = max(0, target - body)
    plan = plan.pad(lead_in, max(0, target - body - lead_in))
    plan = Plan(_vary(rng, plan.angles, fine), plan.yaw, plan.lift, plan.airborne, plan.coast)
    joints = realise(plan)[:target]

    stationary = all(s.stationary for s in segments)
    captions = make_captions(rng, [s.phrases for s in segments], stationary, lead_in / FPS, int(rng.integers(3, 6)))
    if len(segments) == 1:
        params = dict(segments[0].params)
    else:
        params = {"actions": [{"family": n, **s.params} for n, s in zip(names, segments)]}
    params.update(lead_in_s=round(lead_in / FPS, 2), lead_out_s=round((target - body - lead_in) / FPS, 2))
    return EmbeddedClip(joints, captions, names[0], params, names)
