"""Chapter 02's library side: error estimates, the tables it renders, the 2-D toy runs and a tokenizer with its log."""

import numpy as np
import pytest
import torch

from motionlab.estimate import Estimate, mean_ci
from motionlab.metrics import sjpe_dataset
from motionlab.representation import Normalizer
from motionlab.studies.tokenizer_analysis import config_table, error_table, jerk_table, load_with_history, usage_table
from motionlab.tokenizers import QuantizerEMAReset, build_tokenizer, rvq_config, vq_config
from motionlab.tokenizers.analysis import (
    CodebookUsage,
    codebook_usage,
    drifting_ring,
    gaussian_ring,
    reconstruct_clips,
    track_codebook,
    train_toy_quantizer,
)


@pytest.fixture
def reconstructions(smooth_motion):
    raw = smooth_motion(4, 24, seed=2).numpy() * 0.1  # (4, 24, 263)
    normalizer = Normalizer.fit(list(raw))
    clips = [normalizer.normalize(c) for c in raw]
    vq = build_tokenizer(vq_config("smoke")).eval()
    rvq = build_tokenizer(rvq_config("smoke", num_layers=3)).eval()
    return {
        "VQ": reconstruct_clips(vq, clips, normalizer),
        "RVQ": reconstruct_clips(rvq, clips, normalizer),
        "RVQ r=2": reconstruct_clips(rvq, clips, normalizer, num_layers=2),
    }


# -- error estimates and tables ---------------------------------------------------------------


def test_errors_are_the_interval_over_clips_and_the_table_shows_them(reconstructions):
    rec = reconstructions["VQ"]
    e = rec.errors()
    assert e["mpjpe_mm"] == mean_ci(rec.mpjpe_mm, unit="mm") and e["mpjpe_mm"].n == 4
    assert e["feature_mse"] == mean_ci(rec.feature_mse) and e["feature_mse"].unit is None
    assert [r.tokens_per_step for r in reconstructions.values()] == [1, 3, 2]

    table = error_table(reconstructions)
    assert table.labels == ["VQ", "RVQ", "RVQ r=2"]
    assert table.cell("RVQ", "MPJPE") == reconstructions["RVQ"].errors()["mpjpe_mm"]
    assert table.cell("RVQ r=2", "tokens per 4 frames") == 2
    text = table.to_markdown()
    assert text.splitlines()[0] == "| tokenizer | tokens per 4 frames | MPJPE | feature MSE |"
    assert f"| VQ | 1 | {e['mpjpe_mm']} | {e['feature_mse']} |" in text
    assert "4 clips" in text and table._repr_markdown_() == text
    c = table.compare("RVQ", "VQ", "MPJPE")
    assert c.quantity == "MPJPE" and c.a == table.cell("RVQ", "MPJPE") and c.b == e["mpjpe_mm"]


def test_error_table_needs_the_same_clips(reconstructions, smooth_motion):
    raw = smooth_motion(2, 16, seed=3).numpy() * 0.1
    normalizer = Normalizer.fit(list(raw))
    other = reconstruct_clips(
        build_tokenizer(vq_config("smoke")).eval(), [normalizer.normalize(c) for c in raw], normalizer
    )
    with pytest.raises(ValueError, match="different numbers of clips"):
        error_table({"VQ": reconstructions["VQ"], "other": other})
    with pytest.raises(ValueError, match="empty"):
        error_table({})


def test_jerk_table_holds_sjpe_and_its_halves_per_decoder(reconstructions):
    scores = {name: sjpe_dataset(r.joints, r.gt_joints) for name, r in reconstructions.items() if name != "RVQ r=2"}
    table = jerk_table(scores)
    assert table.labels == ["VQ feed-forward", "RVQ feed-forward"]
    s = scores["RVQ"]
    assert table.cell("RVQ feed-forward", "Static") == mean_ci(s.static_per_clip)
    assert table.cell("RVQ feed-forward", "sJPE") == mean_ci(s.sjpe_per_clip)
    assert np.isclose(table.cell("VQ feed-forward", "mean jerk (m/s³)"), scores["VQ"].jerk_pred_per_clip.mean())
    row = next(line for line in table.to_markdown().splitlines() if line.startswith("| VQ feed-forward"))
    assert row.endswith(
        f"| {scores['VQ'].jerk_pred_per_clip.mean():.1f} | {scores['VQ'].jerk_gt_per_clip.mean():.1f} |"
    )


def test_usage_table_has_a_row_per_layer():
    usage = {
        "VQ": CodebookUsage(np.array([[3, 1, 0, 0]])),
        "RVQ": CodebookUsage(np.array([[1, 1, 1, 1], [4, 0, 0, 0]])),
    }
    table = usage_table(usage)
    assert table.labels == ["VQ", "RVQ layer 0", "RVQ layer 1"]
    lines = table.to_markdown().splitlines()
    assert lines[1] == "|---|---:|---:|---:|"
    assert lines[2] == f"| VQ | 50% | {usage['VQ'].perplexity[0]:.1f} | 4 |"
    assert lines[3] == "| RVQ layer 0 | 100% | 4.0 | 4 |" and lines[4] == "| RVQ layer 1 | 25% | 1.0 | 4 |"


def test_config_table_lists_each_profile():
    table = config_table({"smoke": vq_config("smoke"), "full": vq_config("full")})
    full = vq_config("full")
    assert table.cell("full", "codebook_size") == full.codebook_size and table.cell("full", "steps") == full.train.steps
    assert f"| full | {full.width} | {full.depth} |" in table.to_markdown()
    assert f"| {full.train.steps:,} | {full.train.lr:g} |" in table.to_markdown()


# -- the 2-D toy --------------------------------------------------------------------------------


def test_drifting_ring_spreads_out_over_the_first_steps():
    def radius(step):
        return drifting_ring(step, torch.Generator().manual_seed(0)).norm(dim=1).mean()

    base = gaussian_ring(256, generator=torch.Generator().manual_seed(0))
    assert torch.allclose(drifting_ring(0, torch.Generator().manual_seed(0)), 0.05 * base)
    assert torch.allclose(drifting_ring(500, torch.Generator().manual_seed(0)), base)  # full size from step 95 on
    assert radius(10) < radius(50) < radius(100)
    assert drifting_ring(3, torch.Generator(), n=17).shape == (17, 2)
    with pytest.raises(ValueError, match="spread_steps"):
        drifting_ring(0, torch.Generator(), spread_steps=0)


def test_train_toy_quantizer_is_the_seeded_track_of_a_fresh_quantizer():
    q, trace = train_toy_quantizer(decay=0.9, reset=False, codebook_size=8, steps=30, seed=3, every=10)
    manual = QuantizerEMAReset(8, 2, decay=0.9, reset_threshold=0.0, seed=3)
    expected = track_codebook(manual, drifting_ring, 30, torch.Generator().manual_seed(3), every=10)
    assert np.array_equal(trace.codebooks, expected.codebooks) and trace.steps.tolist() == [0, 10, 20, 30]
    assert torch.equal(q.codebook, manual.codebook) and not q.training
    history = trace.history()
    assert len(history) == 30 and history[0]["step"] == 0 and history[-1]["step"] == 29
    assert [row["perplexity"] for row in history] == trace.perplexity.tolist()
    assert [row["usage"] for row in history] == trace.usage.tolist()


def test_reset_changes_the_toy_outcome():
    probe = gaussian_ring(2000, generator=torch.Generator().manual_seed(1))
    used = {}
    for reset in (True, False):
        q, _ = train_toy_quantizer(reset=reset, codebook_size=16, steps=200, seed=0)
        used[reset] = codebook_usage(q.quantize(probe)[None], 16).usage[0]
    assert used[True] > used[False]


# -- a tokenizer with its training log ---------------------------------------------------------


def test_load_with_history_trains_once_then_loads(tmp_path):
    from motionlab.data import MotionDataset
    from motionlab.data.embedded import write_embedded_dataset

    ds = MotionDataset(write_embedded_dataset(tmp_path / "data", n_clips=42, seed=0, progress=False))
    first = load_with_history("vq", ds, "smoke")
    assert first.seconds is not None and first.seconds > 0 and f"trained in {first.seconds:.0f} s" in str(first)
    assert len(first.losses) > 1 and np.isfinite(first.losses).all() and np.isfinite(first.val_mse)
    again = load_with_history("vq", ds, "smoke")
    assert again.seconds is None and "loaded from the cache" in str(again) and again.history == first.history
    for a, b in zip(first.model.state_dict().values(), again.model.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    with pytest.raises(ValueError, match="kind must be one of"):
        load_with_history("vqgan", ds, "smoke")


def test_estimates_carry_no_interval_for_one_clip(smooth_motion):
    raw = smooth_motion(1, 16, seed=4).numpy() * 0.1
    normalizer = Normalizer.fit(list(raw))
    rec = reconstruct_clips(build_tokenizer(vq_config("smoke")).eval(), [normalizer.normalize(raw[0])], normalizer)
    e = rec.errors()["mpjpe_mm"]
    assert isinstance(e, Estimate) and e.half_width == 0 and e.n == 1
