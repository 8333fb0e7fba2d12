"""The text-in front end on a duck-typed pipeline: every method's lengths and boundaries, T_s = T identity."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import torch

from motionlab.data import Caption, MotionClip
from motionlab.multimotion import (
    METHODS,
    METRICS,
    MultiActionInstance,
    MultiMotionGenerator,
    build_reference,
    concatenate_segments,
    evaluate_methods,
)
from motionlab.text import WordTextEncoder

K, D_TEXT, T = 12, 8, 10  # as in conftest.py
TEXTS = ["a person walks forward", "a person waves", "a person jumps up"]


class TableDecoder:
    """Each code -> 4 fixed feature rows (small random values): decode(ids (B, L) padded with -1)."""

    def __init__(self):
        self.table = np.random.default_rng(0).normal(0, 0.02, (K, 4, 263)).astype(np.float32)
        self.calls: list[tuple[int, ...]] = []

    def decode(self, ids, decoder=None):
        self.calls.append(tuple(ids.shape))
        return [self.table[row[row >= 0].numpy()].reshape(-1, 263) for row in ids]


@pytest.fixture(scope="module")
def pipe(tiny):
    model, transitions = tiny
    encoder = WordTextEncoder.from_captions(TEXTS, dim=D_TEXT, n_layers=1, n_heads=2)
    decoder = TableDecoder()
    return SimpleNamespace(
        model=model, transitions=transitions, text_encoder=encoder, decode=decoder.decode, decoder=decoder
    )


@pytest.mark.parametrize("method", METHODS)
def test_every_method_returns_the_requested_layout(pipe, method):
    gen = MultiMotionGenerator.from_pipeline(pipe)
    lengths = [48, 40, 56]
    out = gen.generate(TEXTS, lengths, method=method, seed=1, num_steps=5, transition=16)
    assert len(out) == 1
    motion = out[0]
    assert motion.features.shape == (sum(lengths), 263) and motion.method == method
    assert motion.boundaries == [48, 88] and motion.segment_lengths == lengths and motion.texts == TEXTS


def test_batches_of_instances(pipe):
    gen = MultiMotionGenerator.from_pipeline(pipe)
    out = gen.generate([TEXTS, TEXTS[:2]], [[16, 24, 8], [12, 20]], method="tps", T_s=5, seed=0)
    assert [m.boundaries for m in out] == [[16, 40], [12]]
    assert [len(m.features) for m in out] == [48, 32]


def test_independent_is_tps_at_T_s_equal_T_and_separate_decodes_each_action(pipe):
    gen = MultiMotionGenerator.from_pipeline(pipe)
    a = gen.generate(TEXTS, [16, 24, 8], method="tps", T_s=T, seed=3, guidance_scale=2.0)[0]
    b = gen.generate(TEXTS, [16, 24, 8], method="independent", seed=3, guidance_scale=2.0)[0]
    np.testing.assert_array_equal(a.features, b.features)
    pipe.decoder.calls.clear()
    c = gen.generate(TEXTS, [16, 24, 8], method="separate", seed=3, guidance_scale=2.0)[0]
    assert pipe.decoder.calls == [(3, 6)]  # one row per action, not one concatenated sequence
    tokens = gen.sample_tokens(TEXTS, [16, 24, 8], method="separate", seed=3, guidance_scale=2.0)
    parts = pipe.decode(tokens.ids)
    np.testing.assert_array_equal(c.features, concatenate_segments(parts)[0])


def test_bad_inputs(pipe):
    gen = MultiMotionGenerator.from_pipeline(pipe)
    with pytest.raises(ValueError, match="method"):
        gen.generate(TEXTS, [16, 16, 16], method="magic")
    with pytest.raises(ValueError, match="match"):
        gen.generate(TEXTS, [16, 16])
    with pytest.raises(ValueError, match="non-empty"):
        gen.generate([], [])
    with pytest.raises(ValueError, match="multiples of 4"):
        gen.generate(TEXTS, [16, 18, 16])
    with pytest.raises(ValueError, match="T_s"):
        gen.generate(TEXTS, [16, 16, 16], T_s=T + 1)
    with pytest.raises(ValueError, match="too short"):
        gen.generate(TEXTS, [16, 16, 16], method="slerp", transition=40)
    with pytest.raises(ValueError, match="text_encoder"):
        MultiMotionGenerator.from_pipeline(SimpleNamespace(model=None, transitions=None, decode=None))
    assert torch.is_grad_enabled()  # generation never leaves autograd switched off


class MeanStdEvaluator:
    """Motions -> mean and std over time of 6 feature dims; captions -> a fixed vector per word count."""

    def embed_motions(self, motions):
        return np.stack([np.concatenate([m[:, 4:10].mean(0), m[:, 4:10].std(0)]) for m in motions])

    def embed_texts(self, captions):
        return np.stack([np.full(12, 0.01 * len(c.text)) for c in captions])


def test_evaluate_methods_builds_table_rows(pipe):
    gen = MultiMotionGenerator.from_pipeline(pipe)
    rng = np.random.default_rng(0)
    clips = [
        MotionClip(f"E{i}", rng.normal(0, 0.05, (60, 263)).astype(np.float32), [Caption(t, ("x/VERB",))])
        for i, t in enumerate(TEXTS)
    ]
    instances = [
        MultiActionInstance(
            tuple(clips[j] for j in order), tuple(clips[j].captions[0] for j in order), ("a", "b", "c"), (48, 48, 48)
        )
        for order in ([0, 1, 2], [2, 0, 1], [1, 2, 0], [0, 2, 1])
    ]
    evaluator = MeanStdEvaluator()
    reference = build_reference(evaluator, [c.features for c in clips], rng=0, n_windows=20)
    methods = {"T_s = 5": {"method": "tps", "T_s": 5}, "SLERP": {"method": "slerp", "transition": 16}}
    rows = evaluate_methods(gen, instances, evaluator, reference, methods=methods, repeats=2, num_steps=3)
    assert list(rows) == ["Ground Truth (Single)", "Ground Truth (Concat)", "T_s = 5", "SLERP"]
    assert list(rows["Ground Truth (Concat)"]) == ["jerk"]
    for name in ("Ground Truth (Single)", "T_s = 5", "SLERP"):
        assert set(rows[name]) == set(METRICS)
        assert all(np.isfinite(m) and hw >= 0 for m, hw in rows[name].values())
    plain = evaluate_methods(gen, instances, evaluator, reference, methods=["independent"], repeats=1, num_steps=3)
    assert list(plain)[-1] == "independent" and set(plain["independent"]) == set(METRICS)
    with pytest.raises(ValueError, match="repeats"):
        evaluate_methods(gen, instances, evaluator, reference, repeats=0)
    with pytest.raises(ValueError, match="'method'"):
        evaluate_methods(gen, instances, evaluator, reference, methods={"x": {"T_s": 5}})


def test_generator_passes_joint_text_and_multi_motion_settings_are_the_papers(pipe, monkeypatch):
    import motionlab.multimotion.generate as generate
    from motionlab.multimotion import MULTI_MOTION_ETA, MULTI_MOTION_GUIDANCE

    seen = []
    real = generate.two_phase_sample
    monkeypatch.setattr(generate, "two_phase_sample", lambda *a, **kw: seen.append(kw) or real(*a, **kw))
    gen = MultiMotionGenerator(pipe.model, pipe.transitions, pipe.text_encoder, pipe.decode)
    motions = gen.generate(TEXTS, [16, 20, 12], method="tps", T_s=3, seed=0, num_steps=5, joint_text="all")
    assert seen[0]["joint_text"] == "all" and seen[0]["guidance_scale"] == MULTI_MOTION_GUIDANCE
    assert len(motions[0].features) == 48 and motions[0].boundaries == [16, 36]
    assert (MULTI_MOTION_ETA, MULTI_MOTION_GUIDANCE) == (0.25, 2.0)  # M2D2M appendix A.1


def test_a_token_cache_reuses_each_draw_and_changes_no_number(pipe, monkeypatch):
    lengths = [16, 24, 8]
    plain = MultiMotionGenerator.from_pipeline(pipe)
    cached = MultiMotionGenerator.from_pipeline(pipe, token_cache={})
    draws = []
    real = cached._sample
    monkeypatch.setattr(cached, "_sample", lambda *a: draws.append(a[2]) or real(*a))
    for method in ("tps", "independent", "separate", "tps"):
        ours = cached.generate(TEXTS, lengths, method=method, seed=3, num_steps=5)[0]
        theirs = plain.generate(TEXTS, lengths, method=method, seed=3, num_steps=5)[0]
        np.testing.assert_array_equal(ours.features, theirs.features)
    assert draws == ["tps", "independent"]  # separate decodes independent's tokens; the second tps is the first
    one = cached.sample_tokens(TEXTS, lengths, method="separate", seed=3, num_steps=5)
    assert one is cached.sample_tokens(TEXTS, lengths, method="independent", seed=3, num_steps=5)
    # another seed, sampler option, T_s or transition is another draw
    cached.sample_tokens(TEXTS, lengths, method="tps", seed=4, num_steps=5)
    cached.sample_tokens(TEXTS, lengths, method="tps", seed=3, num_steps=4)
    cached.sample_tokens(TEXTS, lengths, method="tps", seed=3, num_steps=5, T_s=2)
    cached.sample_tokens(TEXTS, lengths, method="handshake", seed=3, num_steps=5, transition=16)
    cached.sample_tokens(TEXTS, lengths, method="handshake", seed=3, num_steps=5, transition=8)
    assert len(draws) == 7 and len(cached.token_cache) == 7


def test_token_keys(pipe):
    from motionlab.multimotion.generate import token_key

    texts, lengths = [TEXTS], [[16, 24, 8]]
    key = token_key("tps", texts, lengths, 0, 9, 40, {"num_steps": 5, "timesteps": [10, 5, 1]})
    assert key == token_key("tps", texts, [np.array([16, 24, 8])], 0, 9, 8, {"timesteps": (10, 5, 1), "num_steps": 5})
    independent = token_key("independent", texts, lengths, 0, None, 8, {})
    assert independent == token_key("separate", texts, lengths, 0, 9, 40, {})  # T_s and transition do not count
    assert token_key("tps", texts, lengths, 0, 9, 40, {"timesteps": torch.arange(3)}) is None  # not a plain value
    with pytest.raises(ValueError, match="token_cache must be a dict"):
        MultiMotionGenerator.from_pipeline(pipe, token_cache=[])
