"""The test-set interval of a comparison: a paired bootstrap over clips, and the per-clip values behind it."""

import numpy as np
import pytest

from motionlab.estimate import Estimate, paired_bootstrap
from motionlab.evaluation import EvaluationTable, ReconstructionConfig, reconstruction_clip_cells
from motionlab.metrics import ClipJoints, mpjpe, mpjpe_per_clip


def test_the_difference_is_the_difference_of_the_means_and_the_interval_covers_it():
    rng = np.random.default_rng(0)
    b = rng.normal(1.0, 0.5, 400)
    a = b - 0.1 + rng.normal(0.0, 0.05, 400)
    d = paired_bootstrap(a, b)
    assert d.mean == pytest.approx(a.mean() - b.mean()) and d.n == 400
    assert d.half_width == pytest.approx(1.96 * np.std(a - b, ddof=1) / np.sqrt(400), rel=0.15)  # the CLT's width
    assert d.excludes(0.0)


def test_pairing_cancels_what_the_two_sides_share():
    rng = np.random.default_rng(1)
    clip_difficulty = rng.normal(0.0, 1.0, 200)  # an easy or a hard clip, for both decoders
    a, b = clip_difficulty + 0.05, clip_difficulty.copy()
    a += rng.normal(0.0, 0.02, 200)
    paired = paired_bootstrap(a, b)
    shuffled = paired_bootstrap(a, rng.permutation(b))  # the same values, pairs broken
    assert paired.half_width < shuffled.half_width / 10
    assert paired.excludes(0.0) and not shuffled.excludes(0.0)


def test_weights_make_a_pooled_mean_and_a_seed_fixes_the_draws():
    a, b = np.array([1.0, 2.0, 4.0]), np.array([0.0, 1.0, 1.0])
    frames = np.array([10.0, 10.0, 20.0])
    d = paired_bootstrap(a, b, frames)
    assert d.mean == pytest.approx((10 * 1 + 10 * 1 + 20 * 3) / 40)
    x, y = np.random.default_rng(5).normal(size=(2, 50))
    assert paired_bootstrap(x, y, seed=3) == paired_bootstrap(x, y, seed=3)
    assert paired_bootstrap(x, y, seed=3).half_width != paired_bootstrap(x, y, seed=4).half_width
    assert paired_bootstrap(a, a).half_width == 0.0  # equal sides: every resample says 0


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="one pair per unit"):
        paired_bootstrap([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="at least 2 units"):
        paired_bootstrap([1.0], [0.0])
    with pytest.raises(ValueError, match="finite"):
        paired_bootstrap([1.0, np.nan], [0.0, 0.0])
    with pytest.raises(ValueError, match="weights"):
        paired_bootstrap([1.0, 2.0], [0.0, 0.0], [1.0, -1.0])
    with pytest.raises(ValueError, match="resamples"):
        paired_bootstrap([1.0, 2.0], [0.0, 0.0], resamples=10)


def test_mpjpe_per_clip_weighted_by_frames_is_the_pooled_mpjpe():
    rng = np.random.default_rng(2)
    lengths = [5, 9, 14]
    gt = ClipJoints.from_joints([rng.normal(size=(n, 22, 3)) for n in lengths])
    pred = ClipJoints.from_joints([c + rng.normal(0.0, 0.1, c.shape) for c in gt.clips()])
    per_clip = mpjpe_per_clip(pred, gt)
    assert per_clip.shape == (3,)
    assert np.average(per_clip, weights=lengths) == pytest.approx(mpjpe(pred, gt), rel=1e-12)
    assert per_clip[1] == pytest.approx(mpjpe(pred.clips()[1], gt.clips()[1]), rel=1e-12)
    with pytest.raises(ValueError, match="ClipJoints"):
        mpjpe_per_clip(pred.clips(), gt.clips())
    with pytest.raises(ValueError, match="same clips"):
        mpjpe_per_clip(pred, ClipJoints.from_joints(gt.clips()[:2] + [gt.clips()[2][:-1]]))


def _table(clip_values, weights=None) -> EvaluationTable:
    cell = {m: Estimate(float(np.mean(v))) for m, v in clip_values["DisCoRD"].items()}
    rows = {row: dict(cell) for row in clip_values}
    return EvaluationTable(
        "reconstruction", "smoke", "d", "test", 1, 0, {}, {"clips": 4}, tuple(cell), rows,
        clip_values=clip_values, clip_weights=weights or {},
    )  # fmt: skip


def test_a_table_pairs_two_rows_clip_by_clip():
    values = {
        "RVQ-VAE": {"sjpe": [1.0, 2.0, 3.0, 4.0], "mpjpe_mm": [10.0, 20.0, 30.0, 40.0]},
        "DisCoRD": {"sjpe": [0.9, 1.8, 2.9, 3.7], "mpjpe_mm": [11.0, 21.0, 31.0, 42.0]},
    }
    table = _table(values, {"mpjpe_mm": [1.0, 1.0, 1.0, 5.0]})
    sjpe = table.paired_clips("DisCoRD", "RVQ-VAE", "sjpe")
    assert sjpe.mean == pytest.approx(-0.175) and sjpe.n == 4 and sjpe.excludes(0.0)
    assert table.paired_clips("DisCoRD", "RVQ-VAE", "mpjpe_mm").mean == pytest.approx((1 + 1 + 1 + 5 * 2) / 8)
    with pytest.raises(KeyError, match="per-clip"):
        table.paired_clips("DisCoRD", "RVQ-VAE", "fid")
    joined = table.joined(table, prefix="again: ")  # the per-clip values travel with joined rows
    assert joined.paired_clips("again: DisCoRD", "RVQ-VAE", "sjpe") == sjpe


def test_clip_cells_pair_the_claims_rows_that_have_per_clip_values():
    config = ReconstructionConfig(grid=(("midpoint", 1), ("midpoint", 15)))
    two, sixteen = config.grid_row("midpoint", 1), config.grid_row("midpoint", 15)
    per_clip = {"sjpe": [1.0, 2.0], "noise_sjpe": [0.5, 1.0], "static_sjpe": [0.5, 1.0], "mpjpe_mm": [1.0, 2.0]}
    values = {"RVQ-VAE": per_clip, "DisCoRD": per_clip, two: {"sjpe": [1.0, 2.0]}, sixteen: {"sjpe": [1.0, 2.0]}}
    table = _table(values)
    table.rows["RVQ-VAE"]["fid"] = table.rows["DisCoRD"]["fid"] = Estimate(0.1)
    cells = reconstruction_clip_cells(table, config)
    assert cells["sjpe_rf_minus_ff"] == ("DisCoRD", "RVQ-VAE", "sjpe")
    assert cells["mpjpe_rf_minus_ff"] == ("DisCoRD", "RVQ-VAE", "mpjpe_mm")
    assert cells["sjpe_steps2_minus_steps16"] == (two, sixteen, "sjpe")
    assert "fid_rf_minus_ff" not in cells  # FID is not a mean over clips
    assert "sjpe_steps2_minus_steps16" not in reconstruction_clip_cells(table, ReconstructionConfig())
