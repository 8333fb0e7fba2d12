"""Tokenizer analysis helpers: codebook usage, clip reconstruction, codebook PCA, the 2-D quantizer trace."""

import numpy as np
import pytest
import torch

from motionlab.metrics import mpjpe
from motionlab.representation import Normalizer, recover_from_ric
from motionlab.tokenizers import QuantizerEMAReset, build_tokenizer, perplexity_of, rvq_config, vq_config
from motionlab.tokenizers.analysis import (
    codebook_pca,
    codebook_usage,
    gaussian_ring,
    reconstruct_clips,
    track_codebook,
)


def gen(seed=0):
    return torch.Generator().manual_seed(seed)


# -- codebook usage ------------------------------------------------------------------------------


def test_usage_and_perplexity_of_known_histograms():
    ids = torch.tensor([[0, 0, 1, 1], [2, 2, 3, 3]])  # 4 of 8 codes, equally often
    u = codebook_usage(ids, 8)
    assert u.counts.shape == (1, 8) and u.counts.sum() == 8
    assert np.allclose(u.usage, [0.5]) and np.allclose(u.perplexity, [4.0])
    assert np.allclose(codebook_usage(torch.zeros(3, 5, dtype=torch.long), 8).perplexity, [1.0])
    # the library's per-batch perplexity agrees on any histogram
    rand = torch.randint(16, (4, 50), generator=gen())
    assert np.isclose(codebook_usage(rand, 16).perplexity[0], float(perplexity_of(rand, 16)), rtol=1e-5)


def test_residual_ids_are_counted_per_layer_and_minus_one_is_skipped():
    ids = torch.tensor([[[0, 1], [0, -1], [2, -1]]])  # (B=1, N=3, R=2); layer 1 dropped on two tokens
    u = codebook_usage(ids, 4)
    assert u.num_layers == 2 and u.codebook_size == 4
    assert u.counts.tolist() == [[2, 0, 1, 0], [0, 1, 0, 0]]
    assert np.allclose(u.usage, [0.5, 0.25])


def test_a_list_of_clips_equals_the_concatenated_batch():
    clips = [torch.randint(8, (n, 3), generator=gen(n)) for n in (2, 5, 4)]
    together = codebook_usage(torch.cat(clips)[None], 8)
    assert np.array_equal(codebook_usage(clips, 8).counts, together.counts)
    flat = [c[:, 0] for c in clips]  # VQ clips (N_i,)
    assert np.array_equal(codebook_usage(flat, 8).counts, together.counts[:1])


BAD_IDS = [torch.tensor([[0, 8]]), torch.tensor([[0.0, 1.0]]), torch.tensor([[[0, -2]]])]


@pytest.mark.parametrize("bad", BAD_IDS)
def test_usage_rejects_bad_ids(bad):
    with pytest.raises(ValueError, match="ids"):
        codebook_usage(bad, 8)
    with pytest.raises(ValueError, match="codebook_size"):
        codebook_usage(torch.zeros(1, 2, dtype=torch.long), 1)


# -- reconstruction ------------------------------------------------------------------------------


@pytest.fixture
def tiny_data(smooth_motion):
    raw = smooth_motion(3, 22, seed=1).numpy() * 0.1  # (3, 22, 263): lengths not multiples of 4
    normalizer = Normalizer.fit(list(raw))
    clips = [normalizer.normalize(c) for c in raw]
    return raw, normalizer, [clips[0], clips[1][:17], clips[2][:12]]


def test_reconstruction_matches_a_manual_round_trip(tiny_data):
    raw, normalizer, clips = tiny_data
    model = build_tokenizer(vq_config("smoke")).eval()
    rec = reconstruct_clips(model, clips, normalizer)
    assert [len(j) for j in rec.joints] == [20, 16, 12]  # cropped to multiples of 4
    assert [tuple(i.shape) for i in rec.ids] == [(5,), (4,), (3,)]
    x = torch.from_numpy(clips[1][:16])[None]
    recon = model.decode(model.encode(x))[0].detach().numpy()
    joints = recover_from_ric(normalizer.denormalize(recon), 22)
    gt = recover_from_ric(raw[1][:16], 22)
    assert np.allclose(rec.joints[1], joints, atol=1e-5)
    assert np.allclose(rec.gt_joints[1], gt, atol=1e-4)
    assert np.isclose(rec.mpjpe_mm[1], 1000 * mpjpe(joints, gt), rtol=1e-4)
    assert np.isclose(rec.feature_mse[1], np.mean((recon - clips[1][:16]) ** 2), rtol=1e-5)
    assert (rec.mpjpe_mm > 0).all()


def test_rvq_decodes_with_its_first_layers_only(tiny_data):
    _, normalizer, clips = tiny_data
    model = build_tokenizer(rvq_config("smoke", num_layers=3)).eval()
    one = reconstruct_clips(model, clips, normalizer, num_layers=1)
    assert all(torch.all(i[:, 1:] == -1) for i in one.ids)  # later layers carry no code
    full = reconstruct_clips(model, clips, normalizer)
    assert all(torch.all(i >= 0) for i in full.ids)
    assert all(torch.equal(a[:, 0], b[:, 0]) for a, b in zip(one.ids, full.ids))  # layer 0 is the same
    assert not np.allclose(one.features[0], full.features[0])
    with pytest.raises(ValueError, match="num_layers"):
        reconstruct_clips(build_tokenizer(vq_config("smoke")), clips, normalizer, num_layers=1)
    with pytest.raises(ValueError, match=r"clips\[0\]"):
        reconstruct_clips(model, [np.zeros((8, 5), np.float32)], normalizer)


# -- codebook PCA --------------------------------------------------------------------------------


def test_pca_finds_the_dominant_axis_and_is_sign_stable():
    g = np.random.default_rng(0)
    axis = np.array([3.0, 4.0, 0.0, 0.0]) / 5.0
    codes = g.normal(size=(200, 1)) * 10 * axis + g.normal(size=(200, 4)) * 0.1  # (200, 4)
    coords, explained = codebook_pca(codes, 2)
    assert coords.shape == (200, 2) and explained.shape == (2,)
    assert explained[0] > 0.99 and explained[0] >= explained[1]
    assert np.allclose(coords[:, 0], (codes - codes.mean(0)) @ axis, atol=0.5)  # the +axis, not -axis
    flipped, _ = codebook_pca(torch.from_numpy(-codes), 2)
    np.testing.assert_allclose(flipped, -coords, atol=1e-5)  # same axes (largest loading positive): mirrored
    with pytest.raises(ValueError, match="n_components"):
        codebook_pca(codes, 5)


# -- a quantizer on 2-D points -------------------------------------------------------------------


def test_gaussian_ring_has_its_modes_on_the_circle():
    x = gaussian_ring(4000, modes=4, radius=2.0, std=0.05, generator=gen())
    assert x.shape == (4000, 2)
    assert torch.allclose(x.norm(dim=1).mean(), torch.tensor(2.0), atol=0.01)
    angles = torch.atan2(x[:, 1], x[:, 0]) / (torch.pi / 2)  # modes at multiples of 90°
    assert (angles - angles.round()).abs().max() < 0.15


def test_reset_revives_codes_that_a_drifting_encoder_left_behind():
    """A growing point cloud strands codes near the origin; only the reset brings them back onto the data."""

    def drifting(step, g):  # an "encoder" whose outputs spread out as it trains
        return min(1.0, 0.05 + step / 40) * gaussian_ring(128, generator=g)

    probe = gaussian_ring(2000, generator=gen(1))
    used = {}
    for threshold in (1.0, 0.0):  # threshold 0: nothing is ever dead, i.e. no reset
        q = QuantizerEMAReset(16, 2, decay=0.9, reset_threshold=threshold)
        trace = track_codebook(q, drifting, 120, gen(), every=40)
        assert trace.steps.tolist() == [0, 40, 80, 120] and trace.codebooks.shape == (4, 16, 2)
        assert trace.perplexity.shape == (120,) and np.isfinite(trace.distortion).all()
        assert not q.training
        used[threshold] = codebook_usage(q.quantize(probe)[None], 16).usage[0]
    assert used[1.0] > 0.9 and used[0.0] <= 0.5
    with pytest.raises(ValueError, match="batch_fn"):
        track_codebook(QuantizerEMAReset(4, 2), lambda s, g: torch.zeros(5, 3), 1, gen())
