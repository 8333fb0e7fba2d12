"""The reconstruction setting: batching by length changes nothing, seeds fix decodes, scores are right at 0; the
helpers chapter 05 shows its example and times its decoders with."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from motionlab.data.embedded.writer import build_clip, plan_families
from motionlab.flow import DisCoRDDecoder, discord_config
from motionlab.flow.reconstruction import (
    ReconstructionScores,
    decode_clips,
    joints_of,
    length_batches,
    reconstruction_scores,
    time_calls,
    timing_batch,
)
from motionlab.studies.reconstruction import ground_truth_joints, median_example, reconstructed_joints
from motionlab.tokenizers import build_tokenizer, rvq_config


@pytest.fixture(scope="module")
def raw_clips():
    """Four procedural clips (raw 263-d features) of different lengths."""
    specs = plan_families(21, seed=0)
    return [build_clip(0, i, specs[i])[0][: 40 + 7 * i] for i in range(4)]  # 40, 47, 54, 61 frames


@pytest.fixture(scope="module")
def tokenizer():
    return build_tokenizer(rvq_config("smoke")).eval()  # untrained: only its shapes and determinism matter


def normalised(clips):
    stacked = np.concatenate(clips)
    mean, std = stacked.mean(0), stacked.std(0) + 1e-3
    return [((c - mean) / std).astype(np.float32) for c in clips]


def test_length_batches_cover_every_index_once():
    lengths = [8, 4, 8, 8, 12, 4, 8]
    batches = length_batches(lengths, batch_size=2)
    flat = np.concatenate(batches)
    assert sorted(flat.tolist()) == list(range(len(lengths)))
    assert all(len(b) <= 2 and len({lengths[i] for i in b}) == 1 for b in batches)
    assert [lengths[b[0]] for b in batches] == [4, 8, 8, 12]  # by length, then cut
    with pytest.raises(ValueError, match="batch_size"):
        length_batches(lengths, 0)


def test_feed_forward_batches_equal_one_clip_at_a_time(raw_clips, tokenizer):
    clips = normalised(raw_clips + [raw_clips[1][:47]])  # two clips of 47 frames share a batch
    batched = decode_clips(clips, tokenizer)
    for clip, recon in zip(clips, batched):
        assert recon.shape == (len(clip) // 4 * 4, 263)  # cropped to whole tokens
        crop = torch.as_tensor(clip[: len(recon)])[None]
        alone = tokenizer.decode(tokenizer.encode(crop))[0].detach().numpy()
        np.testing.assert_allclose(recon, alone, atol=1e-5)


def test_pad_to_tokenises_each_clip_in_a_zero_padded_window_as_the_official_evaluation(raw_clips, tokenizer):
    clips = normalised(raw_clips)
    padded = decode_clips(clips, tokenizer, pad_to=64)
    for clip, recon in zip(clips, padded):
        n = len(clip) // 4 * 4
        window = np.zeros((64, 263), np.float32)
        window[:n] = clip[:n]  # the clip, then zeros (the normalised mean pose) to 64 frames
        alone = tokenizer.decode(tokenizer.encode(torch.as_tensor(window)[None]))[0].detach().numpy()
        assert recon.shape == (n, 263)
        np.testing.assert_allclose(recon, alone[:n], atol=1e-5)
    with pytest.raises(ValueError, match="at least the longest clip, 60"):
        decode_clips(clips, tokenizer, pad_to=56)
    with pytest.raises(ValueError, match="multiple of 4"):
        decode_clips(clips, tokenizer, pad_to=66)


def test_decode_cost_counts_one_call_times_the_calls_and_times_it_here(tokenizer):
    from motionlab.flow.reconstruction import count_flops, decode_cost
    from motionlab.studies.reconstruction import cost_table

    decoder = DisCoRDDecoder.from_tokenizer(tokenizer, "smoke").eval()
    ids = tokenizer.encode(torch.zeros(1, 32, 263))
    cost = decode_cost(tokenizer, decoder, frames=32, steps=15, solver="midpoint")
    assert cost.feed_forward_gflop == pytest.approx(count_flops(lambda: tokenizer.decode(ids)) / 1e9)
    one = count_flops(lambda: decoder.decode(ids, steps=1, solver="euler", seed=0)) / 1e9
    assert cost.discord_calls == 30 and cost.discord_gflop == pytest.approx(30 * one)
    assert cost.discord_gflop == pytest.approx(
        count_flops(lambda: decoder.decode(ids, steps=15, solver="midpoint", seed=0)) / 1e9, rel=0.05
    )
    assert cost.gflop_per_cpu_second > 0
    assert cost.total_gflop(10, 2) == pytest.approx(10 * (cost.feed_forward_gflop + 2 * cost.discord_gflop))
    table = cost_table(cost, clips=10, discord_decodes=2)
    assert table.labels == ["feed-forward decoder (one run)", "DisCoRD, 30 network calls (2 runs)"]
    assert decode_cost(tokenizer, frames=32).discord_gflop is None
    with pytest.raises(ValueError, match="multiple of 4"):
        decode_cost(tokenizer, frames=30)


def test_discord_decodes_are_fixed_by_the_seed(raw_clips, tokenizer):
    decoder = DisCoRDDecoder(discord_config("smoke", tokenizer=tokenizer)).attach(tokenizer)
    clips = normalised(raw_clips)
    first = decode_clips(clips, tokenizer, decoder, steps=2, seed=5)
    again = decode_clips(clips, tokenizer, decoder, steps=2, seed=5)
    other = decode_clips(clips, tokenizer, decoder, steps=2, seed=6)
    assert [r.shape for r in first] == [(40, 263), (44, 263), (52, 263), (60, 263)]
    assert all(np.array_equal(a, b) for a, b in zip(first, again))
    assert not any(np.array_equal(a, b) for a, b in zip(first, other))


def test_scores_of_a_perfect_and_a_noisy_reconstruction(raw_clips):
    def embed(clips):  # any fixed embedding works for FID's algebra
        return np.stack([np.concatenate([c.mean(0)[:6], c.std(0)[:6]]) for c in clips])

    many = raw_clips * 4  # 16 clips: enough for a 12-d covariance
    perfect = reconstruction_scores(many, many, embed)
    assert isinstance(perfect, ReconstructionScores)
    assert perfect.mpjpe_mm == 0.0 and perfect.sjpe == 0.0 and abs(perfect.fid) < 1e-6

    rng = np.random.default_rng(0)
    noisy = [c + rng.normal(0.0, 0.01, c.shape).astype(np.float32) for c in many]  # frame-wise jitter
    scores = reconstruction_scores(noisy, many, embed)
    assert scores.mpjpe_mm > 1.0 and scores.fid > 0.0
    assert scores.noise_sjpe > scores.static_sjpe  # jitter adds jerk
    assert np.isclose(scores.sjpe, scores.noise_sjpe + scores.static_sjpe)
    assert np.isnan(reconstruction_scores(noisy, many).fid)  # no embedding, no FID
    assert set(scores.as_dict()) == {
        "fid",
        "mpjpe_mm",
        "sjpe",
        "noise_sjpe",
        "static_sjpe",
        "sjpe_ratio",
        "noise_sjpe_ratio",
        "static_sjpe_ratio",
        "joint_jerk",
    }


def test_input_checks(raw_clips, tokenizer):
    with pytest.raises(ValueError, match="list of"):
        decode_clips(raw_clips[0], tokenizer)
    with pytest.raises(ValueError, match=r"clips\[0\]"):
        decode_clips([np.zeros((2, 263))], tokenizer)
    with pytest.raises(ValueError, match="equal"):
        reconstruction_scores(raw_clips[:2], raw_clips[:3])
    with pytest.raises(ValueError, match="shape"):
        reconstruction_scores([raw_clips[0]], [raw_clips[1]])
    with pytest.raises(ValueError, match="repeats"):
        time_calls(lambda: None, repeats=0)
    assert time_calls(lambda: None, repeats=3).shape == (3,)


def test_count_flops_counts_matrix_products_and_convolutions():
    from motionlab.flow.reconstruction import count_flops

    linear, conv = torch.nn.Linear(10, 20), torch.nn.Conv1d(8, 16, 3, padding=1)
    assert count_flops(lambda: linear(torch.zeros(3, 10))) == 2 * 3 * 10 * 20
    assert count_flops(lambda: conv(torch.zeros(2, 8, 32))) == 2 * 2 * 32 * 16 * 8 * 3
    assert count_flops(lambda: torch.zeros(5).relu()) == 0  # element-wise work is not counted
    twice = count_flops(lambda: (linear(torch.zeros(3, 10)), linear(torch.zeros(3, 10))))
    assert twice == 2 * count_flops(lambda: linear(torch.zeros(3, 10)))


def test_timing_batch_is_the_longest_clips_cropped_to_one_length(raw_clips, tokenizer):
    clips = normalised(raw_clips)  # 40, 47, 54, 61 frames
    ids = timing_batch(clips, tokenizer, size=2)  # the two longest, 54 and 61, cropped to 52 frames (13 tokens)
    assert tuple(ids.shape[:2]) == (2, 13)
    crop = torch.as_tensor(np.stack([c[:52] for c in clips[2:]]))
    assert torch.equal(ids, tokenizer.encode(crop))
    assert timing_batch(clips, tokenizer).shape[:2] == (4, 10)  # fewer clips than the batch: all of them, 40 frames
    with pytest.raises(ValueError, match="size"):
        timing_batch(clips, tokenizer, size=0)


def test_median_example_takes_the_median_gain_among_long_clips(raw_clips):
    gt = joints_of(raw_clips)  # 40, 47, 54, 61 frames
    rng = np.random.default_rng(1)
    worse = [g + rng.normal(0.0, s, g.shape) for g, s in zip(gt, (0.001, 0.002, 0.004, 0.008))]
    # b is the ground truth: the gain sJPE(a) - sJPE(b) is a's sJPE, which grows with the noise (clip by clip)
    assert median_example(worse, gt, gt, min_frames=1) == 2  # gains of 4 clips: the upper median, clip 2
    assert median_example(worse, gt, gt, min_frames=50) == 3  # clips 2 and 3 are long enough: the upper one
    assert median_example(worse, gt, gt, min_frames=1000) == 2  # none is that long: all clips count
    with pytest.raises(ValueError, match="as many clips"):
        median_example(worse[:2], gt, gt)


def test_split_joints_are_the_evaluations_ground_truth_and_decodes(tokenizer):
    from motionlab.data import load_dataset

    dataset = load_dataset(profile="smoke", seed=0)
    clips = list(dataset.split("test"))[:3]
    gt = ground_truth_joints(dataset, tokenizer, limit=3)
    assert [len(g) for g in gt] == [len(c.features) // 4 * 4 for c in clips]
    recon = decode_clips([dataset.normalizer.normalize(c.features) for c in clips], tokenizer)
    expected = joints_of([dataset.normalizer.denormalize(r) for r in recon])
    for got, want in zip(reconstructed_joints(dataset, tokenizer, limit=3), expected):
        np.testing.assert_allclose(got, want, atol=1e-5)
    one = reconstructed_joints(dataset, tokenizer, limit=3, clips=[1])
    assert len(one) == 1 and one[0].shape == expected[1].shape
    assert ground_truth_joints(dataset, tokenizer, clips=[1])[0].shape == gt[1].shape
    with pytest.raises(ValueError, match="no clips"):
        ground_truth_joints(dataset, tokenizer, clips=[])


def test_scores_reuse_the_joints_they_are_given(raw_clips):
    from motionlab.metrics import ClipJoints

    noisy = [c + 0.01 for c in raw_clips]
    given = reconstruction_scores(noisy, raw_clips, pred_joints=ClipJoints.from_features(noisy))
    assert given.as_dict() == pytest.approx(reconstruction_scores(noisy, raw_clips).as_dict(), nan_ok=True)
    with pytest.raises(ValueError, match="clip lengths differ"):
        reconstruction_scores(noisy, raw_clips, pred_joints=ClipJoints.from_features(raw_clips[::-1]))
