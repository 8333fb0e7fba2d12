"""Scoring multi-motions as M2D2M Tables 1 and 4–6 do: the individual actions and the transitions.

* **Individual motion**: each generated motion is cut at its boundaries and every action is scored against
  its own caption like a single motion: R-Top3, FID (against the real single-action clips), MM-Dist and
  Diversity, all in the evaluator's embedding (any object with ``embed_motions(list of (T, D) raw
  features)`` and ``embed_texts(captions)``, e.g. ``motionlab.metrics.evaluator_training``'s evaluator).
* **Transition**: the ``window`` frames (40) around each boundary
  (:func:`motionlab.metrics.transition_windows`: 20 before, 20 from the boundary on, shifted inside the
  sequence near its ends): FID against *real windows of the same length* cut from single-action clips,
  Diversity, and Jerk (Eq. 10, :func:`motionlab.metrics.transition_log_jerk`, time in frames, on the joints
  recovered from the whole motion).
* **References**: "ground truth (single)" scores the real clips of the test set as if generated and real
  windows as transitions; "ground truth (concat)" is the Jerk of the real clips played back to back
  (the only number the paper reports for it). :func:`ground_truth_jerks` gives both Jerks as samples, for intervals.

One evaluation gives a dict of floats (:data:`METRICS`); :func:`evaluate_methods` repeats it (new seeds) and gives
mean ± 95 % half-width per metric (:class:`~motionlab.estimate.Estimate`). The table a chapter or ``motionlab
evaluate multi`` prints is :func:`motionlab.evaluation.evaluate_multi`'s, built on :func:`evaluate_methods`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from motionlab.estimate import Estimate
from motionlab.metrics import diversity, fid, log_jerk_batch, mean_ci, retrieval_metrics, transition_log_jerk
from motionlab.metrics import transition_windows as _windows
from motionlab.multimotion.stitch import split_segments
from motionlab.representation import recover_from_ric

METRICS = ("r_top3", "fid", "mm_dist", "diversity", "transition_fid", "transition_diversity", "jerk")
DEFAULT_WINDOW = 40
GROUND_TRUTH_SINGLE, GROUND_TRUTH_CONCAT = "Ground Truth (Single)", "Ground Truth (Concat)"  # the two reference rows


def motion_parts(motion) -> tuple[np.ndarray, list[int]]:
    """A MultiMotion-like object (``.features``, ``.boundaries``) or a ``(features, boundaries)`` pair."""
    if hasattr(motion, "features") and hasattr(motion, "boundaries"):
        return np.asarray(motion.features), list(motion.boundaries)
    features, boundaries = motion
    return np.asarray(features), list(boundaries)


def _rng(rng) -> np.random.Generator:
    if isinstance(rng, (int, np.integer)):
        return np.random.default_rng(int(rng))
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy Generator or an int seed, got {type(rng).__name__}")
    return rng


# ---------------------------------------------------------------------------------------------- windows


def transition_feature_windows(features: np.ndarray, boundaries: Sequence[int], window: int = DEFAULT_WINDOW):
    """The feature rows of each transition window (``transition_windows`` ranges) -> list of (window, D)."""
    return [features[a:b] for a, b in _windows(len(features), boundaries, window)]


def transition_jerk(features: np.ndarray, boundaries: Sequence[int], window: int = DEFAULT_WINDOW) -> np.ndarray:
    """Eq. 10 (frames) around every boundary of one motion, on joints recovered from all its features."""
    return transition_log_jerk(recover_from_ric(np.asarray(features, np.float32)), boundaries, window)


def real_windows(clips: Sequence[np.ndarray], window: int, rng, n: int | None = None) -> list[np.ndarray]:
    """``n`` windows of ``window`` frames at random starts in random real clips (one per clip by default).

    Clips shorter than ``window`` are skipped.
    """
    rng = _rng(rng)
    long_enough = [np.asarray(c) for c in clips if len(c) >= window]
    if not long_enough:
        raise ValueError(f"no clip has the {window} frames a window needs")
    which = np.arange(len(long_enough)) if n is None else rng.integers(len(long_enough), size=n)
    out = []
    for i in which:
        start = int(rng.integers(len(long_enough[i]) - window + 1))
        out.append(long_enough[i][start : start + window])
    return out


def transition_profile(motions: Sequence, window: int = DEFAULT_WINDOW) -> dict[str, np.ndarray]:
    """Mean joint speed and jerk magnitude per frame around the boundaries (M2D2M Fig. 5), time in frames.

    Only boundaries with ``window / 2`` frames on both sides count. Returns ``frames`` (the offset of each
    speed sample from the boundary), ``speed`` (window − 1,) and ``jerk`` (window − 3,), means over joints
    and transitions, and ``n`` (the number of transitions).
    """
    half, speeds, jerks = window // 2, [], []
    for motion in motions:
        features, boundaries = motion_parts(motion)
        joints = recover_from_ric(np.asarray(features, np.float32))  # (T, J, 3)
        for b in boundaries:
            if b - half >= 0 and b + half <= len(joints):
                w = joints[b - half : b + half]
                speeds.append(np.linalg.norm(np.diff(w, axis=0), axis=-1).mean(-1))
                jerks.append(np.linalg.norm(np.diff(w, n=3, axis=0), axis=-1).mean(-1))
    if not speeds:
        raise ValueError(f"no boundary has {half} frames on both sides")
    return {
        "frames": np.arange(-half, half - 1),
        "speed": np.mean(speeds, 0),
        "jerk": np.mean(jerks, 0),
        "n": np.array(len(speeds)),
    }


# ---------------------------------------------------------------------------------------------- evaluation


@dataclass
class MultiMotionReference:
    """Real embeddings the FIDs compare against: single-action clips and windows cut from them."""

    segment_embeddings: np.ndarray  # (N, d)
    window_embeddings: np.ndarray  # (N_w, d)
    window: int


def build_reference(
    evaluator, real_clips: Sequence[np.ndarray], *, rng, window: int = DEFAULT_WINDOW, n_windows: int | None = None
) -> MultiMotionReference:
    """Embed the real single-action clips (raw features) and ``n_windows`` random real windows of them."""
    clips = [np.asarray(getattr(c, "features", c)) for c in real_clips]
    if len(clips) < 2:
        raise ValueError(f"need at least 2 real clips, got {len(clips)}")
    windows = real_windows(clips, window, rng, n_windows)
    return MultiMotionReference(evaluator.embed_motions(clips), evaluator.embed_motions(windows), window)


def _individual(evaluator, segments, captions, reference, rng, batch_size, diversity_pairs) -> dict[str, float]:
    if len(segments) != len(captions):
        raise ValueError(f"{len(segments)} action segments but {len(captions)} captions")
    if len(segments) < 3:
        raise ValueError(f"need at least 3 action segments for R-Top3, got {len(segments)}")
    motion = evaluator.embed_motions(segments)
    text = evaluator.embed_texts(list(captions))
    scores = retrieval_metrics(text, motion, batch_size=min(batch_size, len(segments)), top_k=3, rng=rng)
    return {
        "r_top3": float(scores.r_precision[2]),
        "fid": fid(reference.segment_embeddings, motion),
        "mm_dist": scores.mm_dist,
        "diversity": diversity(motion, rng, n_pairs=diversity_pairs),
    }


def _transitions(evaluator, windows, jerks, reference, rng, diversity_pairs) -> dict[str, float]:
    if len(windows) < 2:
        raise ValueError(f"need at least 2 transitions, got {len(windows)}")
    emb = evaluator.embed_motions(windows)
    jerks = np.asarray(jerks, dtype=np.float64)
    return {
        "transition_fid": fid(reference.window_embeddings, emb),
        "transition_diversity": diversity(emb, rng, n_pairs=diversity_pairs),
        "jerk": float(np.nanmean(jerks)) if np.isfinite(jerks).any() else float("nan"),
    }


def evaluate_multimotion(
    evaluator,
    motions: Sequence,
    captions: Sequence[Sequence],
    reference: MultiMotionReference,
    *,
    rng,
    batch_size: int = 32,
    diversity_pairs: int = 300,
) -> dict[str, float]:
    """One evaluation of generated multi-motions -> {metric: value} over :data:`METRICS`.

    ``motions[i]`` (``.features``/``.boundaries`` or a pair) was generated for ``captions[i]`` (one caption
    per action; ``Caption`` objects or what the evaluator's ``embed_texts`` takes).
    """
    return _score(evaluator, motions, captions, reference, rng, batch_size, diversity_pairs)[0]


def _score(evaluator, motions, captions, reference, rng, batch_size=32, diversity_pairs=300):
    """:func:`evaluate_multimotion`'s scores and the Eq. 10 Jerk at every boundary, in motion and boundary order
    (so that two methods generated for the same instances pair up boundary by boundary)."""
    rng = _rng(rng)
    if len(motions) == 0 or len(motions) != len(captions):
        raise ValueError(f"motions and captions must be non-empty and match, got {len(motions)} and {len(captions)}")
    segments, flat_captions, windows, jerks = [], [], [], []
    for i, (motion, caps) in enumerate(zip(motions, captions, strict=True)):
        features, boundaries = motion_parts(motion)
        if len(boundaries) + 1 != len(caps):
            raise ValueError(f"motion {i} has {len(boundaries) + 1} actions but {len(caps)} captions")
        segments += split_segments(features, boundaries)
        flat_captions += list(caps)
        if boundaries:
            windows += transition_feature_windows(features, boundaries, reference.window)
            jerks += transition_jerk(features, boundaries, reference.window).tolist()
    out = _individual(evaluator, segments, flat_captions, reference, rng, batch_size, diversity_pairs)
    return {**out, **_transitions(evaluator, windows, jerks, reference, rng, diversity_pairs)}, jerks


def evaluate_ground_truth_single(
    evaluator,
    instances: Sequence,
    reference: MultiMotionReference,
    *,
    rng,
    batch_size: int = 32,
    diversity_pairs: int = 300,
) -> dict[str, float]:
    """The "ground truth (single)" row: the test set's real clips as the actions and fresh real windows as the
    transitions (as many as the instances have boundaries), scored like :func:`evaluate_multimotion`."""
    rng = _rng(rng)
    segments = [s for inst in instances for s in inst.real_segments]
    captions = [c for inst in instances for c in inst.captions]
    out = _individual(evaluator, segments, captions, reference, rng, batch_size, diversity_pairs)
    n = sum(len(inst.lengths) - 1 for inst in instances)
    windows = real_windows(segments, reference.window, rng, n=max(n, 2))
    jerks = log_jerk_batch(recover_from_ric(np.stack(windows).astype(np.float32)))
    return {**out, **_transitions(evaluator, windows, jerks, reference, rng, diversity_pairs)}


def ground_truth_concat_jerk(instances: Sequence, window: int = DEFAULT_WINDOW) -> float:
    """The "ground truth (concat)" Jerk: at the boundaries of each instance's real clips played back to back."""
    values = [transition_jerk(*inst.real_concat(), window) for inst in instances if len(inst.lengths) > 1]
    if not values:
        raise ValueError("no instance has a boundary (all have one action)")
    return float(np.nanmean(np.concatenate(values)))


class GroundTruthJerks(NamedTuple):
    """Samples of M2D2M Table 1's two ground-truth Jerks, and the cut judged against the clips it joins."""

    single: np.ndarray  # (n_windows,): random windows inside the real segments
    concat: np.ndarray  # (n_boundaries,): at each cut between real clips played back to back
    cut_minus_inside: np.ndarray  # (n_boundaries,): each cut − the mean inside-window Jerk of its two clips


def ground_truth_jerks(
    instances: Sequence, window: int = DEFAULT_WINDOW, *, rng, windows_per_segment: int = 8
) -> GroundTruthJerks:
    """The two ground-truth Jerks of M2D2M Table 1 as samples, for intervals (see :class:`GroundTruthJerks`).

    ``single``: Eq. 10 on ``windows_per_segment`` random windows inside every real action segment of the instances
    (segments shorter than ``window`` are skipped). ``concat``: Eq. 10 at every boundary of each instance's real
    clips played back to back. ``cut_minus_inside`` pairs each cut with the clips on its two sides (NaN where one
    is too short), so clip-to-clip differences in roughness cancel. Real data costs nothing to score: pass every
    instance of the test set, and the means carry intervals over hundreds of samples.
    """
    if isinstance(windows_per_segment, bool) or not isinstance(windows_per_segment, int) or windows_per_segment < 1:
        raise ValueError(f"windows_per_segment must be a positive int, got {windows_per_segment!r}")
    rng = _rng(rng)
    single, concat, paired = [], [], []
    for inst in instances:
        inside = []  # per segment: Eq. 10 of its windows, (windows_per_segment,), or None when too short
        for segment in inst.real_segments:
            segment = np.asarray(segment)
            if len(segment) < window:
                inside.append(None)
                continue
            windows = real_windows([segment] * windows_per_segment, window, rng)
            inside.append(log_jerk_batch(recover_from_ric(np.stack(windows).astype(np.float32))))
            single.append(inside[-1])
        if len(inst.lengths) > 1:
            cuts = transition_jerk(*inst.real_concat(), window)  # (n_actions - 1,)
            concat.append(cuts)
            paired += [
                cut - (np.nanmean(a) + np.nanmean(b)) / 2 if a is not None and b is not None else np.nan
                for cut, a, b in zip(cuts, inside[:-1], inside[1:], strict=True)
            ]
    if not single:
        raise ValueError(f"no real segment has the {window} frames a window needs")
    if not concat:
        raise ValueError("no instance has a boundary (all have one action)")
    return GroundTruthJerks(np.concatenate(single), np.concatenate(concat), np.asarray(paired, dtype=np.float64))


def segment_jerk(motions: Sequence, window: int = DEFAULT_WINDOW, *, rng) -> np.ndarray:
    """Eq. 10 Jerk *away from* the transitions: one random ``window``-frame window inside each action segment.

    The window never crosses a boundary (segments shorter than ``window`` are skipped), and the joints are
    recovered from the whole motion, as for :func:`transition_jerk`. This is how smooth a method's motion is
    in itself: the generated counterpart of the "ground truth (single)" Jerk, and the level a transition
    Jerk should be read against when the generator is rougher (or smoother) than real data everywhere.
    Returns one value per window, (n_windows,).
    """
    rng = _rng(rng)
    values = []
    for motion in motions:
        features, boundaries = motion_parts(motion)
        joints = recover_from_ric(np.asarray(features, np.float32))  # (T, J, 3)
        edges = [0, *boundaries, len(joints)]
        windows = []
        for a, b in zip(edges, edges[1:], strict=False):
            if b - a >= window:
                start = a + int(rng.integers(b - a - window + 1))
                windows.append(joints[start : start + window])
        if windows:
            values.append(log_jerk_batch(np.stack(windows)))
    if not values:
        raise ValueError(f"no action segment has the {window} frames a window needs")
    return np.concatenate(values)


def _finite_estimate(values) -> Estimate:
    """Mean ± 95 % half-width of the finite ``values`` (a static window or a too-short clip has no Eq. 10 value);
    NaN with ``n = 0`` when none is finite."""
    values = np.asarray(values, dtype=np.float64).reshape(-1)
    values = values[np.isfinite(values)]
    return mean_ci(values) if values.size else Estimate(float("nan"), float("nan"), 0)


def _summary(runs: Sequence[Mapping[str, float]]) -> dict[str, Estimate]:
    """Repeated evaluations -> {metric: Estimate} over the repeats (a repeat with a NaN metric is left out of it)."""
    return {key: _finite_estimate([run[key] for run in runs]) for key in runs[0]}


def evaluate_methods(
    generator,
    instances: Sequence,
    evaluator,
    reference: MultiMotionReference,
    *,
    methods: Sequence[str] | Mapping[str, Mapping] = ("tps", "independent"),
    repeats: int = 3,
    seed: int = 0,
    generated: dict | None = None,
    ground_truth: GroundTruthJerks | None = None,
    with_segment_jerk: bool = False,
    samples: dict | None = None,
    **sampling,
) -> dict[str, dict[str, Estimate]]:
    """Table rows: the two ground truths, then every method generated ``repeats`` times (seeds ``seed + r``)
    for all ``instances`` and scored with :func:`evaluate_multimotion` -> {row: {metric: Estimate}}.

    ``generator`` has ``generate(texts, lengths, method=, seed=, **kw)`` (a :class:`MultiMotionGenerator`).
    ``methods``: method names, or {row label: options} with a ``"method"`` entry and per-row options, e.g.
    ``{"T_s = 90": {"method": "tps", "T_s": 90}, "SLERP": {"method": "slerp"}}``; ``sampling`` is shared.

    The ground-truth rows' Jerks come from ``ground_truth`` (:func:`ground_truth_jerks`, e.g. of every instance of
    the test set: real data costs nothing to score), by default from ``instances`` with ``rng=seed``; their other
    metrics from :func:`evaluate_ground_truth_single` with ``rng=seed + r``. ``with_segment_jerk`` adds the column
    ``segment_jerk``: :func:`segment_jerk` (``rng=seed + r``) averaged per repeat, the real clips' own Jerk for the
    ground truth.

    ``generated``: a dict to receive the motions, ``{row label: [motions of repeat 0, 1, ...]}``, for plots.
    ``samples``: a dict to receive, per row and metric, the values behind each estimate, in an order shared across
    rows: per repeat, except ``"jerk"`` of a method (every boundary, repeat by repeat, instance by instance, so two
    methods pair up boundary by boundary), of Ground Truth (Single) (every window) and of Ground Truth (Concat)
    (every cut; with ``"cut_minus_inside"``, each cut − the Jerk inside the two clips it joins).
    """
    if not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be a positive int, got {repeats!r}")
    for name, value in (("generated", generated), ("samples", samples)):
        if value is not None and not isinstance(value, dict):
            raise ValueError(f"{name} must be a dict (filled by the evaluation) or None, got {type(value).__name__}")
    rows_spec = dict(methods) if isinstance(methods, Mapping) else {m: {"method": m} for m in methods}
    if any("method" not in spec for spec in rows_spec.values()):
        raise ValueError("every entry of a methods mapping needs a 'method' option")
    texts = [inst.texts for inst in instances]
    lengths = [list(inst.lengths) for inst in instances]
    captions = [inst.captions for inst in instances]
    gt = ground_truth_jerks(instances, reference.window, rng=seed) if ground_truth is None else ground_truth
    single = [evaluate_ground_truth_single(evaluator, instances, reference, rng=seed + r) for r in range(repeats)]
    rows = {GROUND_TRUTH_SINGLE: _summary(single), GROUND_TRUTH_CONCAT: {"jerk": _finite_estimate(gt.concat)}}
    rows[GROUND_TRUTH_SINGLE]["jerk"] = _finite_estimate(gt.single)  # windows inside the real clips, not per repeat
    found = {
        GROUND_TRUTH_SINGLE: {**{k: [run[k] for run in single] for k in single[0]}, "jerk": gt.single.tolist()},
        GROUND_TRUTH_CONCAT: {"jerk": gt.concat.tolist(), "cut_minus_inside": gt.cut_minus_inside.tolist()},
    }
    if with_segment_jerk:  # inside real clips, the Jerk is the Ground Truth (Single) Jerk itself
        rows[GROUND_TRUTH_SINGLE]["segment_jerk"] = rows[GROUND_TRUTH_SINGLE]["jerk"]
        found[GROUND_TRUTH_SINGLE]["segment_jerk"] = found[GROUND_TRUTH_SINGLE]["jerk"]
    for label, spec in rows_spec.items():
        kw = {**sampling, **spec}
        runs, boundary_jerks = [], []
        for r in range(repeats):
            motions = generator.generate(texts, lengths, seed=seed + r, **kw)
            scores, jerks = _score(evaluator, motions, captions, reference, seed + r)
            if with_segment_jerk:
                scores["segment_jerk"] = float(np.nanmean(segment_jerk(motions, reference.window, rng=seed + r)))
            runs.append(scores)
            boundary_jerks += jerks
            if generated is not None:
                generated.setdefault(label, []).append(motions)
        rows[label] = _summary(runs)
        found[label] = {**{k: [run[k] for run in runs] for k in runs[0]}, "jerk": [float(j) for j in boundary_jerks]}
    if samples is not None:
        samples.update(found)
    return rows
