"""Chapter 04's projection ablation: fixed inputs pair the rows up, the errors are right at 0, and the influence of a
token on the frames is what each projection's algebra says."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from motionlab.data.embedded.writer import build_clip, plan_families
from motionlab.flow import DisCoRDDecoder, discord_config, make_condition_projection
from motionlab.flow.condition import CONDITION_PROJECTIONS, frames_reached_from_outside, token_influence
from motionlab.representation import Normalizer
from motionlab.studies.ablation import (
    ABLATION_METRICS,
    CLIP_METRICS,
    FEED_FORWARD,
    clip_errors,
    held_out_clips,
    paired_differences,
    projection_ablation,
    window_losses,
)
from motionlab.tokenizers import build_tokenizer, rvq_config


class FakeDataset:
    """What the ablation reads of a MotionDataset: ``key``, ``normalizer`` and ``normalized(split)``."""

    key = "fake-data"

    def __init__(self, raw: list[np.ndarray]):
        self.normalizer = Normalizer(np.concatenate(raw).mean(0), np.concatenate(raw).std(0) + 1e-3)
        self._clips = [self.normalizer.normalize(c).astype(np.float32) for c in raw]

    def normalized(self, split: str) -> list[np.ndarray]:
        return self._clips[:3] if split == "train" else self._clips[3:]


@pytest.fixture(scope="module")
def dataset():
    specs = plan_families(21, seed=0)
    order = [0, 1, 3, 6, 2, 7]  # clips of at least 84 frames
    return FakeDataset([build_clip(0, i, specs[i])[0][: 66 + 3 * k] for k, i in enumerate(order)])  # 66 … 81 frames


@pytest.fixture(scope="module")
def tokenizer():
    return build_tokenizer(rvq_config("smoke")).eval()  # untrained: only shapes and determinism matter


def decoder(tokenizer, projection: str, seed: int = 0) -> DisCoRDDecoder:
    torch.manual_seed(seed)  # the weights of an untrained decoder
    config = discord_config("smoke", tokenizer=tokenizer, projection=projection, sample_steps=2)
    return DisCoRDDecoder(config).attach(tokenizer).eval()


def test_held_out_clips_are_the_first_val_clips_in_whole_tokens(dataset):
    clips = held_out_clips(dataset, 2, q=4)
    assert [len(c) for c in clips] == [72, 76]  # 75 and 78 frames, floored to multiples of 4
    np.testing.assert_array_equal(clips[1], dataset.normalized("val")[1][:76])
    with pytest.raises(ValueError, match="n_clips"):
        held_out_clips(dataset, 0, q=4)


def test_window_losses_are_fixed_inputs_whatever_the_decoder(dataset, tokenizer):
    a = decoder(tokenizer, "stacked")
    losses = window_losses(a, tokenizer, dataset.normalized("train"), 5)
    assert losses.shape == (5,) and np.isfinite(losses).all() and (losses > 0).all()
    np.testing.assert_array_equal(losses, window_losses(a, tokenizer, dataset.normalized("train"), 5))
    # more draws per window average out more of the (x0, t) noise: a different number, same windows
    assert not np.allclose(losses, window_losses(a, tokenizer, dataset.normalized("train"), 5, draws=1))
    # another seed draws other windows and noise
    assert not np.allclose(losses, window_losses(a, tokenizer, dataset.normalized("train"), 5, seed=3))
    with pytest.raises(ValueError, match="n_windows"):
        window_losses(a, tokenizer, dataset.normalized("train"), 0)


def test_clip_errors_are_zero_for_a_perfect_decode_and_the_offset_squared_for_a_shifted_one(dataset):
    clips = held_out_clips(dataset, 3, q=4)
    perfect = clip_errors(clips, clips, dataset.normalizer)
    assert set(perfect) == set(CLIP_METRICS)
    assert (perfect["heldout_mse"] == 0).all() and np.allclose(perfect["heldout_mpjpe"], 0, atol=1e-6)
    shifted = clip_errors([c + 0.5 for c in clips], clips, dataset.normalizer)
    np.testing.assert_allclose(shifted["heldout_mse"], 0.25, rtol=1e-5)
    assert (shifted["heldout_mpjpe"] > 0).all()
    with pytest.raises(ValueError, match="clip 0"):
        clip_errors([c[:-4] for c in clips], clips, dataset.normalizer)


def test_the_ablation_table_pairs_rows_measured_on_the_same_inputs(dataset, tokenizer):
    stacked = decoder(tokenizer, "stacked")
    twin = decoder(tokenizer, "stacked")  # the same weights under another name: every sample must agree
    repeat = decoder(tokenizer, "repeat", seed=1)
    table = projection_ablation(
        {"stacked": stacked, "twin": twin, "repeat": repeat}, tokenizer, dataset, windows=4, clips=2
    )
    assert list(table.rows) == ["stacked", "twin", "repeat", FEED_FORWARD]
    assert table.metrics == ABLATION_METRICS
    assert set(table.rows[FEED_FORWARD]) == set(CLIP_METRICS)  # the feed-forward decoder has no flow loss
    assert [len(table.samples["repeat"][m]) for m in ABLATION_METRICS] == [4, 4, 2, 2]
    for metric in ABLATION_METRICS:
        assert table.samples["twin"][metric] == table.samples["stacked"][metric]
        same = table.paired("stacked", "twin", metric)
        assert same.mean == 0 and same.half_width == 0
        values = np.asarray(table.samples["repeat"][metric])
        assert table.estimate("repeat", metric).mean == pytest.approx(values.mean())
    assert table.estimate("stacked", "heldout_mpjpe").unit == "mm"
    # the table's samples are the library functions' own numbers
    np.testing.assert_array_equal(
        table.samples["repeat"]["heldout_fm"], window_losses(repeat, tokenizer, dataset.normalized("val"), 4)
    )
    differences = paired_differences(table, "stacked", ["repeat"], ["heldout_fm", "heldout_mse"])
    assert list(differences.rows) == ["stacked − repeat"]
    assert differences.estimate("stacked − repeat", "heldout_mse") == table.paired("stacked", "repeat", "heldout_mse")
    assert "stacked − repeat" in differences.to_markdown()


def test_the_ablation_refuses_decoders_that_cannot_share_inputs(dataset, tokenizer):
    other = DisCoRDDecoder(discord_config("smoke", tokenizer=tokenizer, window=32)).attach(tokenizer)
    with pytest.raises(ValueError, match="share one window"):
        projection_ablation({"a": decoder(tokenizer, "stacked"), "b": other}, tokenizer, dataset, windows=2, clips=1)
    with pytest.raises(ValueError, match="empty"):
        projection_ablation({}, tokenizer, dataset, windows=2, clips=1)


@pytest.mark.parametrize("kind", CONDITION_PROJECTIONS)
def test_token_influence_follows_each_projections_algebra(kind):
    q, n = 4, 6
    torch.manual_seed(0)
    influence = token_influence(make_condition_projection(kind, 8, 5, q=q), n_tokens=n, seed=1)
    assert influence.shape == (n, q * n) and influence.dtype == torch.bool
    own = torch.zeros(n, q * n, dtype=torch.bool)
    for token in range(n):
        own[token, q * token : q * (token + 1)] = True
    outside = frames_reached_from_outside(influence, q)
    if kind == "transposed":
        # kernel 8, stride 4, padding 2: frames qn, qn+1 also see token n-1 and frames qn+2, qn+3 token n+1,
        # except at the two ends of the sequence
        expected = torch.ones(q * n, dtype=torch.bool)
        expected[[0, 1, q * n - 2, q * n - 1]] = False
        assert torch.equal(outside, expected)
        assert (influence & own).sum() == q * n  # it still reaches its own frames
    else:
        assert torch.equal(influence, own) and not outside.any()


def test_token_influence_checks_its_inputs():
    with pytest.raises(ValueError, match="make_condition_projection"):
        token_influence(torch.nn.Linear(4, 4))
    with pytest.raises(ValueError, match="shape"):
        frames_reached_from_outside(torch.zeros(3, 10, dtype=torch.bool), 4)
