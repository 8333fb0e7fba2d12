"""Training the text-motion evaluator on a dataset, exact batching, the protocol numbers, and perturbations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from motionlab.data import Caption, MotionClip
from motionlab.metrics import EvaluatorConfig, TextMotionEvaluator, finite_difference_jerk, r_precision
from motionlab.metrics.evaluator_training import (
    EvaluatorNetworks,
    EvaluatorTrainingConfig,
    encode_motion_exact,
    evaluator_config,
    load_or_train_evaluator,
    pick_captions,
    protocol_scores,
    train_evaluator,
)
from motionlab.metrics.perturbations import add_frame_noise, smooth_in_time
from motionlab.representation import Normalizer

D = 263
TINY_NETS = EvaluatorConfig(
    dim_word=16, dim_text_hidden=16, dim_motion_hidden=24, dim_coemb=16, dim_movement_hidden=24, dim_movement_latent=24
)
TINY = EvaluatorTrainingConfig(TINY_NETS, steps=150, batch_size=16, lr=3e-3, grad_clip=1.0, max_frames=48)

# Four toy "families": each moves its own block of feature dims at its own frequency, and its captions
# name it with a family word among shared filler words.
FAMILIES = {
    "wave": (0.05, slice(67, 100)),
    "kick": (0.12, slice(100, 140)),
    "spin": (0.2, slice(140, 190)),
    "squat": (0.3, slice(190, 259)),
}
SUBJECTS = ("a/DET person/NOUN", "the/DET man/NOUN", "someone/PRON", "a/DET woman/NOUN")


def toy_clip(name: str, family: str, rng: np.random.Generator) -> MotionClip:
    freq, dims = FAMILIES[family]
    t = np.arange(int(rng.integers(40, 72)))[:, None]
    x = 0.05 * rng.standard_normal((len(t), D))
    x[:, dims] += np.sin(2 * np.pi * freq * t + rng.uniform(0, 6.3)) * rng.uniform(0.8, 1.2)
    caps = []
    for subject in rng.permutation(SUBJECTS)[:3]:
        tokens = (*subject.split(), f"{family}/VERB", *rng.choice(["slowly/ADV", "again/ADV", "here/ADV"], 1))
        caps.append(Caption(" ".join(t.split("/")[0] for t in tokens), tuple(tokens)))
    return MotionClip(name, x.astype(np.float32), caps)


class ToyDataset:
    """What the trainer reads from a ``MotionDataset``: ``split()``, ``normalizer`` and ``key``."""

    key = "toy-v1"

    def __init__(self, seed: int = 0):
        rng = np.random.default_rng(seed)
        fams = list(FAMILIES)
        self.splits = {
            s: [toy_clip(f"{s}{i}", fams[i % 4], rng) for i in range(n)]
            for s, n in (("train", 64), ("val", 16), ("test", 32))
        }
        self.normalizer = Normalizer.fit([c.features for c in self.splits["train"]])

    def split(self, name: str):
        return self.splits[name]


@pytest.fixture(scope="module")
def toy() -> ToyDataset:
    return ToyDataset()


@pytest.fixture(scope="module")
def trained(toy):
    return train_evaluator(toy, config=TINY)


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))


def tiny_evaluator(seed: int = 0) -> TextMotionEvaluator:
    return TextMotionEvaluator(TINY_NETS, generator=torch.Generator().manual_seed(seed)).eval()


# -- exact batching -------------------------------------------------------------------------------------


def test_padding_does_not_leak_into_an_embedding():
    ev = tiny_evaluator()
    g = torch.Generator().manual_seed(1)
    short, long = torch.randn(1, 20, D, generator=g), torch.randn(1, 44, D, generator=g)
    batch = torch.zeros(2, 44, D)
    batch[0, :20], batch[1] = short[0], long[0]
    with torch.no_grad():
        alone = encode_motion_exact(ev, short, torch.tensor([20]))
        together = encode_motion_exact(ev, batch, torch.tensor([20, 44]))
        plain = ev.encode_motion(batch, torch.tensor([20, 44]))  # the official batching, for contrast
    torch.testing.assert_close(together[0], alone[0], atol=1e-5, rtol=1e-5)
    assert (plain[0] - alone[0]).abs().max() > 1e-4, "the plain padded batch should see the padding"


def test_exact_encoding_rejects_lengths_that_are_not_multiples_of_four():
    with pytest.raises(ValueError, match="multiples"):
        encode_motion_exact(tiny_evaluator(), torch.zeros(1, 12, D), torch.tensor([10]))
    with pytest.raises(ValueError, match="shape"):
        encode_motion_exact(tiny_evaluator(), torch.zeros(1, 12, D - 1), torch.tensor([12]))


# -- the trained evaluator ----------------------------------------------------------------------------------


def test_training_reduces_the_loss_and_retrieves_held_out_pairs(trained, toy):
    losses = [r["loss"] for r in trained.history if "loss" in r]
    assert np.mean(losses[-3:]) < 0.6 * np.mean(losses[:3])
    test = toy.split("test")
    top = r_precision(
        trained.embed_texts([c.captions[0] for c in test]),
        trained.embed_motions([c.features for c in test]),
        batch_size=32,
    )
    # chance for top-3 in batches of 32 is 3/32; clips of one family are interchangeable here, so the
    # ceiling is about 3/8 (8 clips per family in a batch)
    assert top[2] > 0.25 and top[0] <= top[1] <= top[2]


@pytest.mark.cpu_only("exact batch invariance is a property of the CPU's kernels; cuDNN's vary with the batch")
def test_embeddings_do_not_depend_on_order_batching_or_the_cropped_tail(trained, toy):
    clips = [c.features for c in toy.split("test")[:10]]
    emb = trained.embed_motions(clips)
    assert emb.shape == (10, TINY_NETS.dim_coemb) and emb.dtype == np.float32
    order = np.random.default_rng(0).permutation(10)
    np.testing.assert_allclose(trained.embed_motions([clips[i] for i in order]), emb[order], atol=1e-5)
    small = dataclasses.replace(trained, batch_size=3)
    np.testing.assert_allclose(small.embed_motions(clips), emb, atol=1e-5)
    cropped = [c[: len(c) // 4 * 4] for c in clips]
    np.testing.assert_allclose(trained.embed_motions(cropped), emb, atol=1e-6)


def test_text_embeddings_accept_captions_or_token_lists(trained, toy):
    caps = [c.captions[0] for c in toy.split("val")[:5]]
    np.testing.assert_allclose(trained.embed_texts(caps), trained.embed_texts([list(c.tokens) for c in caps]))
    unseen = trained.embed_texts([["a/DET", "zebra/NOUN", "moonwalk/VERB"]])  # unknown words -> unk
    assert unseen.shape == (1, TINY_NETS.dim_coemb) and np.isfinite(unseen).all()
    for bad in ("a person walks", ["a person walks"], [[]]):
        with pytest.raises(ValueError):
            trained.embed_texts(bad)


def test_embed_motions_validates_its_input(trained):
    with pytest.raises(ValueError, match="list"):
        trained.embed_motions(np.zeros((40, D)))
    with pytest.raises(ValueError, match="shape"):
        trained.embed_motions([np.zeros((40, D - 4))])
    with pytest.raises(ValueError, match="NaN"):
        trained.embed_motions([np.full((40, D), np.nan)])


def test_evaluate_generation_scores_ground_truth_and_noise(trained, toy):
    test = toy.split("test")
    caps = pick_captions(test, np.random.default_rng(0))
    gt = trained.evaluate_generation(test, [c.features for c in test], caps, rng=0)
    assert set(gt) == {"fid", "top1", "top2", "top3", "mm_dist", "diversity"}
    assert abs(gt["fid"]) < 1e-6 and gt["top1"] <= gt["top2"] <= gt["top3"] and gt["diversity"] > 0
    noisy = [c.features + 1.0 * np.random.default_rng(i).standard_normal(c.features.shape) for i, c in enumerate(test)]
    bad = trained.evaluate_generation(test, noisy, caps, rng=0)
    assert bad["fid"] > 0.1 and bad["mm_dist"] > gt["mm_dist"]
    with pytest.raises(ValueError, match="captions"):
        trained.evaluate_generation(test, noisy, caps[:-1], rng=0)
    emb = trained.embed_motions([c.features for c in test])
    again = protocol_scores(emb, trained.embed_motions(noisy), trained.embed_texts(caps), rng=0)
    assert again == pytest.approx(bad, rel=1e-5)


def test_load_or_train_trains_once_then_loads(toy, monkeypatch):
    config = dataclasses.replace(TINY, steps=4, val_every=0)
    first = load_or_train_evaluator(toy, "smoke", config, progress=False)
    import motionlab.metrics.evaluator_training as module

    monkeypatch.setattr(module, "Trainer", lambda *a, **k: pytest.fail("trained again instead of loading"))
    second = load_or_train_evaluator(toy, "smoke", config, progress=False)
    clips = [c.features for c in toy.split("test")[:4]]
    np.testing.assert_allclose(second.embed_motions(clips), first.embed_motions(clips), atol=1e-6)
    assert second.history and second.history[-1]["step"] == 4


def test_profiles_scale_up_to_the_official_sizes():
    smoke, laptop, full = (evaluator_config(p) for p in ("smoke", "laptop", "full"))
    assert full.evaluator == EvaluatorConfig.official("t2m")
    assert smoke.evaluator.dim_motion_hidden < laptop.evaluator.dim_motion_hidden <= full.evaluator.dim_motion_hidden
    assert smoke.steps < laptop.steps < full.steps
    nets = EvaluatorNetworks(smoke.evaluator, vocab_size=10)
    assert nets.words.embedding.weight.shape == (10, smoke.evaluator.dim_word)
    with pytest.raises(ValueError):
        EvaluatorTrainingConfig(TINY_NETS, steps=0)


# -- perturbations --------------------------------------------------------------------------------------


def test_frame_noise_is_sigma_times_the_feature_spread():
    norm = Normalizer(np.zeros(D), np.linspace(0.1, 2.0, D))
    clip = np.ones((4000, D))
    assert np.array_equal(add_frame_noise([clip], 0.0, norm, np.random.default_rng(0))[0], clip)
    noisy = add_frame_noise([clip], 0.5, norm, np.random.default_rng(0))[0]
    np.testing.assert_allclose((noisy - clip).std(axis=0) / norm.std, 0.5, rtol=0.08)
    with pytest.raises(ValueError, match="sigma"):
        add_frame_noise([clip], -1.0, norm, np.random.default_rng(0))
    with pytest.raises(ValueError, match="list"):
        add_frame_noise(clip, 0.1, norm, np.random.default_rng(0))


def test_smoothing_removes_jerk_and_keeps_constants():
    rng = np.random.default_rng(0)
    clip = np.cumsum(rng.standard_normal((80, 3)), axis=0)
    smooth = smooth_in_time([clip], 2.0)[0]
    jerk = lambda x: np.abs(finite_difference_jerk(x, 20.0, axis=0)).mean()  # noqa: E731
    assert jerk(smooth) < 0.2 * jerk(clip)
    np.testing.assert_allclose(smooth_in_time([np.full((30, 5), 3.0)], 4.0)[0], 3.0)
    assert np.array_equal(smooth_in_time([clip], 0.0)[0], clip)
