"""Multi-motion evaluation: segment/caption alignment, transition windows at the edges, Jerk, references, CIs."""

from __future__ import annotations

import numpy as np
import pytest

from motionlab.data import Caption, MotionClip
from motionlab.data.embedded import generate_clip
from motionlab.metrics import log_jerk_batch, mean_ci, transition_log_jerk
from motionlab.multimotion import (
    GROUND_TRUTH_CONCAT,
    GROUND_TRUTH_SINGLE,
    METRICS,
    MultiActionInstance,
    build_reference,
    evaluate_ground_truth_single,
    evaluate_methods,
    evaluate_multimotion,
    ground_truth_concat_jerk,
    ground_truth_jerks,
    segment_jerk,
    transition_feature_windows,
    transition_jerk,
    transition_profile,
)
from motionlab.multimotion.evaluation import _summary
from motionlab.representation import joints_to_features, recover_from_ric

FAMILIES = ("walk", "run", "wave", "jump", "squat", "bow")


class TableEvaluator:
    """Motions -> mean and std over time of 8 feature dims; a caption -> the embedding of the clip it was
    written for (so a real clip and its own caption coincide, and R-Top3 checks the bookkeeping)."""

    def __init__(self):
        self.texts: dict[str, np.ndarray] = {}

    def embed_motions(self, motions):
        return np.stack([np.concatenate([m[:, 1:9].mean(0), m[:, 1:9].std(0)]) for m in motions])

    def embed_texts(self, captions):
        return np.stack([self.texts[c.text] for c in captions])


@pytest.fixture(scope="module")
def setup():
    clips = []
    for i, family in enumerate(FAMILIES):
        joints = generate_clip(family, np.random.default_rng(i)).joints
        features = joints_to_features(joints, "t2m", retarget_to_target=False).astype(np.float32)
        clips.append(MotionClip(f"E{i:06d}", features, [Caption(f"a person does {family}", (f"{family}/VERB",))]))
    instances = []
    for order in ([0, 1, 2], [3, 4, 5], [5, 0, 3], [2, 4, 1]):
        chosen = [clips[i] for i in order]
        lengths = tuple(min(c.length, 60) // 4 * 4 for c in chosen)
        instances.append(
            MultiActionInstance(
                tuple(chosen), tuple(c.captions[0] for c in chosen), tuple(FAMILIES[i] for i in order), lengths
            )
        )
    evaluator = TableEvaluator()
    for inst in instances:
        for cap, seg in zip(inst.captions, inst.real_segments, strict=True):
            evaluator.texts[cap.text] = evaluator.embed_motions([seg])[0]  # every clip is cut to the same length
    reference = build_reference(evaluator, [c.features for c in clips], rng=0, window=40, n_windows=30)
    return clips, instances, evaluator, reference


def test_real_concatenations_score_perfect_retrieval_and_the_direct_jerk(setup):
    _, instances, evaluator, reference = setup
    motions = [inst.real_concat() for inst in instances]
    captions = [inst.captions for inst in instances]
    out = evaluate_multimotion(evaluator, motions, captions, reference, rng=0)
    assert set(out) == set(METRICS) and all(np.isfinite(v) for v in out.values())
    assert out["r_top3"] == 1.0 and out["mm_dist"] == pytest.approx(0.0, abs=1e-5)
    direct = np.concatenate([transition_log_jerk(recover_from_ric(f), b, 40) for f, b in motions])
    assert out["jerk"] == pytest.approx(float(np.nanmean(direct)))
    assert ground_truth_concat_jerk(instances) == pytest.approx(out["jerk"])
    shuffled = [caps[1:] + caps[:1] for caps in captions]  # every action paired with another's caption
    assert evaluate_multimotion(evaluator, motions, shuffled, reference, rng=0)["mm_dist"] > 0.1


def test_noisy_transitions_score_worse_than_real_ones(setup):
    _, instances, evaluator, reference = setup
    motions = [inst.real_concat() for inst in instances]
    captions = [inst.captions for inst in instances]
    rng = np.random.default_rng(0)
    noisy = []
    for features, bounds in motions:
        f = features.copy()
        for b in bounds:
            f[b - 20 : b + 20, 1:9] += rng.normal(0, 0.5, (40, 8)).astype(np.float32)
        noisy.append((f, bounds))
    clean = evaluate_multimotion(evaluator, motions, captions, reference, rng=1)
    worse = evaluate_multimotion(evaluator, noisy, captions, reference, rng=1)
    assert worse["transition_fid"] > clean["transition_fid"] + 1.0


def test_ground_truth_single_row(setup):
    _, instances, evaluator, reference = setup
    out = evaluate_ground_truth_single(evaluator, instances, reference, rng=0)
    assert set(out) == set(METRICS) and out["r_top3"] == 1.0
    assert all(np.isfinite(v) for v in out.values())


def test_transition_windows_at_the_sequence_edges():
    features = np.arange(50 * 3, dtype=np.float32).reshape(50, 3)
    near = transition_feature_windows(features, [5, 45], window=40)
    np.testing.assert_array_equal(near[0], features[0:40])  # shifted inside, never cut
    np.testing.assert_array_equal(near[1], features[10:50])
    middle = transition_feature_windows(np.zeros((100, 3)), [50], window=40)[0]
    assert middle.shape == (40, 3)
    short = transition_feature_windows(features[:30], [10], window=40)[0]
    np.testing.assert_array_equal(short, features[:30])  # shorter than a window: all of it


def test_transition_jerk_and_profile(setup):
    _, instances, _, _ = setup
    features, bounds = instances[0].real_concat()
    jerk = transition_jerk(features, bounds)
    assert jerk.shape == (2,) and np.isfinite(jerk).all()
    profile = transition_profile([(features, bounds)], window=40)
    assert profile["speed"].shape == (39,) and profile["jerk"].shape == (37,) and int(profile["n"]) == 2
    assert profile["frames"][0] == -20 and (profile["speed"] >= 0).all()
    with pytest.raises(ValueError, match="both sides"):
        transition_profile([(features[:30], [10])], window=40)


def test_bad_inputs(setup):
    _, instances, evaluator, reference = setup
    motions = [inst.real_concat() for inst in instances]
    captions = [inst.captions for inst in instances]
    with pytest.raises(ValueError, match="match"):
        evaluate_multimotion(evaluator, motions, captions[:2], reference, rng=0)
    with pytest.raises(ValueError, match="actions but"):
        evaluate_multimotion(evaluator, motions, [c[:2] for c in captions], reference, rng=0)
    with pytest.raises(ValueError, match="rng"):
        evaluate_multimotion(evaluator, motions, captions, reference, rng="zero")


def test_repeats_become_estimates_without_their_nan_runs():
    runs = [{"fid": 1.0, "jerk": 1.2}, {"fid": 2.0, "jerk": float("nan")}, {"fid": 3.0, "jerk": 1.4}]
    s = _summary(runs)
    assert s["fid"] == mean_ci([1.0, 2.0, 3.0]) and s["jerk"] == mean_ci([1.2, 1.4])  # the NaN run is left out
    lost = _summary([{"jerk": float("nan")}])["jerk"]
    assert np.isnan(lost.mean) and lost.n == 0


def test_evaluate_methods_rows_and_the_samples_behind_them(setup, noisy_concat):
    _, instances, evaluator, reference = setup
    gt = ground_truth_jerks(instances, rng=5)
    samples, generated = {}, {}
    methods = {"a": {"method": "tps"}, "b": {"method": "independent"}}
    kw = dict(methods=methods, repeats=2, seed=3)
    rows = evaluate_methods(
        noisy_concat(instances, by_method=True),
        instances,
        evaluator,
        reference,
        **kw,
        ground_truth=gt,
        with_segment_jerk=True,
        samples=samples,
        generated=generated,
    )
    assert list(rows) == [GROUND_TRUTH_SINGLE, GROUND_TRUTH_CONCAT, "a", "b"]
    # the ground-truth Jerks are those of ground_truth_jerks, with intervals over windows and cuts
    single, concat = rows[GROUND_TRUTH_SINGLE], rows[GROUND_TRUTH_CONCAT]
    assert single["jerk"] == mean_ci(gt.single[np.isfinite(gt.single)]) and single["jerk"].n == gt.single.size
    assert concat == {"jerk": mean_ci(gt.concat)} and single["segment_jerk"] == single["jerk"]
    assert samples[GROUND_TRUTH_CONCAT] == {
        "jerk": gt.concat.tolist(),
        "cut_minus_inside": gt.cut_minus_inside.tolist(),
    }
    # the other ground-truth metrics: evaluate_ground_truth_single per repeat, rng = seed + r
    truth = [evaluate_ground_truth_single(evaluator, instances, reference, rng=3 + r) for r in range(2)]
    assert single["fid"] == mean_ci([t["fid"] for t in truth]) and samples[GROUND_TRUTH_SINGLE]["fid"] == [
        t["fid"] for t in truth
    ]
    captions = [inst.captions for inst in instances]
    for label in methods:
        runs = generated[label]
        assert len(runs) == 2 and all(len(motions) == len(instances) for motions in runs)
        scores = [evaluate_multimotion(evaluator, runs[r], captions, reference, rng=3 + r) for r in range(2)]
        inside = [float(np.nanmean(segment_jerk(runs[r], rng=3 + r))) for r in range(2)]
        assert rows[label] == {**{k: mean_ci([s[k] for s in scores]) for k in METRICS}, "segment_jerk": mean_ci(inside)}
        # Jerk per boundary: repeat by repeat, instance by instance, boundary by boundary
        per_boundary = np.concatenate([transition_jerk(m.features, m.boundaries) for motions in runs for m in motions])
        np.testing.assert_allclose(samples[label]["jerk"], per_boundary)
        assert samples[label]["fid"] == [s["fid"] for s in scores]
        assert samples[label]["segment_jerk"] == inside
    assert len(samples["a"]["jerk"]) == len(samples["b"]["jerk"]) == 2 * sum(len(i.lengths) - 1 for i in instances)
    # without ground_truth: measured on the instances themselves, rng = seed
    plain = evaluate_methods(noisy_concat(instances, by_method=True), instances, evaluator, reference, **kw)
    assert plain[GROUND_TRUTH_SINGLE]["jerk"] == mean_ci(ground_truth_jerks(instances, rng=3).single)
    assert "segment_jerk" not in plain["a"] and plain["a"] == {k: v for k, v in rows["a"].items() if k in METRICS}
    with pytest.raises(ValueError, match="samples must be a dict"):
        evaluate_methods(noisy_concat(instances, by_method=True), instances, evaluator, reference, **kw, samples=[])


def test_ground_truth_jerks_are_samples_of_the_two_table_rows(setup):
    _, instances, _, _ = setup
    single, concat, paired = ground_truth_jerks(instances, rng=0, windows_per_segment=3)
    segments = [s for inst in instances for s in inst.real_segments]
    assert single.shape == (3 * sum(len(s) >= 40 for s in segments),)
    assert concat.shape == paired.shape == (sum(len(inst.lengths) - 1 for inst in instances),)
    assert np.nanmean(concat) == pytest.approx(ground_truth_concat_jerk(instances))
    np.testing.assert_array_equal(single, ground_truth_jerks(instances, rng=0, windows_per_segment=3).single)  # seeded
    # the first sample is Eq. 10 of a window drawn from the first segment with the same generator
    rng = np.random.default_rng(0)
    first = next(s for s in segments if len(s) >= 40)
    start = int(rng.integers(len(first) - 40 + 1))
    window = recover_from_ric(np.asarray(first[start : start + 40], np.float32))
    assert single[0] == pytest.approx(float(log_jerk_batch(window[None])[0]))
    # each cut is paired with the mean inside-window Jerk of the two clips it joins
    inside = single.reshape(-1, 3).mean(1)  # every segment here is long enough: one row per segment, in order
    n = len(instances[0].lengths)
    assert paired[0] == pytest.approx(concat[0] - (inside[0] + inside[1]) / 2)
    assert paired[n - 1] == pytest.approx(concat[n - 1] - (inside[n] + inside[n + 1]) / 2)  # second instance
    with pytest.raises(ValueError, match="windows_per_segment"):
        ground_truth_jerks(instances, rng=0, windows_per_segment=0)
    with pytest.raises(ValueError, match="frames a window needs"):
        ground_truth_jerks(instances, 10_000, rng=0)
