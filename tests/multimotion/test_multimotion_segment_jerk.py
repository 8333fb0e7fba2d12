"""Jerk away from the transitions (``segment_jerk``) and the motions ``evaluate_methods`` hands back."""

from __future__ import annotations

import numpy as np
import pytest

from motionlab.data import Caption, MotionClip
from motionlab.data.embedded import generate_clip
from motionlab.metrics import log_jerk_batch, mean_ci
from motionlab.multimotion import (
    MultiActionInstance,
    MultiMotion,
    build_reference,
    evaluate_methods,
    evaluate_multimotion,
    segment_jerk,
)
from motionlab.representation import joints_to_features, recover_from_ric

FAMILIES = ("walk", "wave", "jump", "squat")


@pytest.fixture(scope="module")
def clips():
    out = []
    for i, family in enumerate(FAMILIES):
        joints = generate_clip(family, np.random.default_rng(10 + i)).joints
        features = joints_to_features(joints, "t2m", retarget_to_target=False).astype(np.float32)
        out.append(MotionClip(f"S{i:06d}", features, [Caption(f"a person does {family}", (f"{family}/VERB",))]))
    return out


def _instance(clips, order, length=56):
    chosen = tuple(clips[i] for i in order)
    return MultiActionInstance(
        chosen,
        tuple(c.captions[0] for c in chosen),
        tuple(FAMILIES[i] for i in order),
        tuple(min(c.length, length) // 4 * 4 for c in chosen),
    )


def test_windows_stay_inside_one_segment(clips):
    features, bounds = _instance(clips, [0, 1, 2, 3]).real_concat()
    values = segment_jerk([(features, bounds)], window=40, rng=0)
    assert values.shape == (4,) and np.isfinite(values).all()
    # Jerk is invariant to the rigid offset between recovering a segment alone and inside the whole motion, so
    # each value must be the Jerk of some 40-frame window of its own segment (never one across a boundary).
    edges = [0, *bounds, len(features)]
    for value, a, b in zip(values, edges[:-1], edges[1:], strict=True):
        joints = recover_from_ric(features[a:b])
        candidates = log_jerk_batch(np.stack([joints[s : s + 40] for s in range(b - a - 40 + 1)]))
        assert np.min(np.abs(candidates - value)) < 1e-3
    again = segment_jerk([(features, bounds)], window=40, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(values, again)  # seeded


def test_short_segments_are_skipped(clips):
    features, bounds = _instance(clips, [0, 1, 2]).real_concat()
    assert segment_jerk([MultiMotion(features, bounds, ["a", "b", "c"], "x")], window=48, rng=1).shape == (3,)
    mixed = np.concatenate([features[:20], features[:60]])  # one 20-frame and one 60-frame segment
    assert segment_jerk([(mixed, [20])], window=40, rng=1).shape == (1,)
    with pytest.raises(ValueError, match="frames a window needs"):
        segment_jerk([(features[:60], [30])], window=40, rng=0)
    with pytest.raises(ValueError, match="rng"):
        segment_jerk([(features, bounds)], rng="zero")


class MeanStd:
    def embed_motions(self, motions):
        return np.stack([np.concatenate([m[:, 1:9].mean(0), m[:, 1:9].std(0)]) for m in motions])

    def embed_texts(self, captions):
        return np.stack([np.full(16, float(len(c.text))) for c in captions])


def test_evaluate_methods_hands_back_the_scored_motions(clips, noisy_concat):
    instances = [_instance(clips, order) for order in ([0, 1, 2], [3, 2, 1], [1, 3, 0], [2, 0, 3])]
    evaluator = MeanStd()
    reference = build_reference(evaluator, [c.features for c in clips], rng=0, n_windows=12)
    generated: dict = {}
    rows = evaluate_methods(
        noisy_concat(instances),
        instances,
        evaluator,
        reference,
        methods=["tps", "slerp"],
        repeats=2,
        seed=3,
        generated=generated,
    )
    assert list(generated) == ["tps", "slerp"] and all(len(runs) == 2 for runs in generated.values())
    assert all(len(motions) == len(instances) for motions in generated["tps"])
    captions = [inst.captions for inst in instances]
    rescored = [evaluate_multimotion(evaluator, generated["tps"][r], captions, reference, rng=3 + r) for r in range(2)]
    assert rows["tps"] == {k: mean_ci([run[k] for run in rescored]) for k in rescored[0]}
    with pytest.raises(ValueError, match="generated"):
        evaluate_methods(noisy_concat(instances), instances, evaluator, reference, generated=[])
