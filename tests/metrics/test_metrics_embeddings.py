"""Embedding metrics: FID, R-precision, MM-Dist, Diversity, MultiModality, and the mean +- CI protocol."""

import numpy as np
import pytest

from motionlab.metrics import (
    Estimate,
    diversity,
    fid,
    frechet_distance,
    gaussian_stats,
    mean_ci,
    mm_dist,
    multimodality,
    r_precision,
    retrieval_metrics,
    summarize_runs,
)

# --- FID ------------------------------------------------------------------------------------------------------


def test_fid_of_identical_sets_is_zero():
    x = np.random.default_rng(0).normal(size=(500, 16))
    assert fid(x, x.copy()) == pytest.approx(0.0, abs=1e-6)


def test_fid_of_shifted_gaussians_is_the_squared_shift():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(4000, 8))
    shift = np.array([1.0, -2.0, 0.5, 0, 0, 0, 0, 3.0])
    assert fid(x, x + shift) == pytest.approx(shift @ shift, abs=1e-6)  # same covariance exactly
    y = rng.normal(size=(4000, 8)) + shift  # fresh samples: only sampling noise on top
    assert fid(x, y) == pytest.approx(shift @ shift, rel=0.03)


def test_frechet_distance_closed_form_for_diagonal_covariances():
    # 1-D per axis: (mu1-mu2)^2 + (s1 - s2)^2 with standard deviations s
    s1, s2 = np.array([1.0, 2.0, 3.0]), np.array([2.0, 2.0, 1.0])
    d = frechet_distance(np.zeros(3), np.diag(s1**2), np.ones(3), np.diag(s2**2))
    assert d == pytest.approx(3 + np.sum((s1 - s2) ** 2))


def test_frechet_distance_survives_singular_covariances():
    rank1 = np.outer([1.0, 2.0, 0.0], [1.0, 2.0, 0.0])
    d = frechet_distance(np.zeros(3), rank1, np.zeros(3), np.zeros((3, 3)))
    assert np.isfinite(d) and d == pytest.approx(np.trace(rank1), abs=1e-3)


def test_frechet_distance_matches_the_sqrtm_route_for_non_commuting_covariances():
    from scipy import linalg

    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(40, 6)), rng.normal(size=(50, 6)) @ rng.normal(size=(6, 6))
    (mu1, s1), (mu2, s2) = gaussian_stats(a), gaussian_stats(b)
    reference = (mu1 - mu2) @ (mu1 - mu2) + np.trace(s1 + s2 - 2.0 * linalg.sqrtm(s1 @ s2).real)
    assert frechet_distance(mu1, s1, mu2, s2) == pytest.approx(reference, rel=1e-9)


def test_frechet_distance_rejects_matrices_that_are_not_covariances():
    with pytest.raises(ValueError, match="symmetric"):
        frechet_distance(np.zeros(2), np.array([[1.0, 0.5], [0.0, 1.0]]), np.zeros(2), np.eye(2))
    with pytest.raises(ValueError, match="positive semi-definite"):
        frechet_distance(np.zeros(2), np.eye(2), np.zeros(2), np.diag([1.0, -1.0]))
    with pytest.raises(ValueError, match="finite"):
        frechet_distance(np.zeros(2), np.eye(2), np.array([np.nan, 0.0]), np.eye(2))


def test_fid_rejects_bad_input():
    with pytest.raises(ValueError, match=r"\(N, d\)"):
        fid(np.zeros(10), np.zeros(10))
    with pytest.raises(ValueError, match="NaN"):
        fid(np.full((5, 2), np.nan), np.zeros((5, 2)))
    with pytest.raises(ValueError, match="shapes"):
        fid(np.zeros((5, 2)), np.zeros((5, 3)))


# --- R-precision and MM-Dist --------------------------------------------------------------------------------


def test_perfect_embeddings_retrieve_perfectly():
    x = np.random.default_rng(2).normal(size=(96, 32))
    scores = retrieval_metrics(x, x.copy())
    np.testing.assert_array_equal(scores.r_precision, [1.0, 1.0, 1.0])
    assert scores.mm_dist == 0.0 and scores.n_samples == 96


def test_random_embeddings_are_at_chance_level():
    rng = np.random.default_rng(3)
    n = 32 * 300
    top = r_precision(rng.normal(size=(n, 8)), rng.normal(size=(n, 8)), rng=rng)
    np.testing.assert_allclose(top, np.arange(1, 4) / 32, atol=0.01)
    assert top[0] <= top[1] <= top[2]


def test_hand_computed_batch():
    # Batch of 3 on a line: text 0 nearest its own motion, text 1 nearest motion 2, text 2 nearest 0.
    text = np.array([[0.0], [10.0], [20.0]])
    motion = np.array([[1.0], [13.0], [12.0]])
    # distances: row0 [1, 13, 12] rank 0; row1 [9, 3, 2] rank 1; row2 [19, 7, 8] rank 1
    scores = retrieval_metrics(text, motion, batch_size=3, top_k=3)
    np.testing.assert_allclose(scores.r_precision, [1 / 3, 1.0, 1.0])
    assert scores.mm_dist == pytest.approx((1 + 3 + 8) / 3)
    assert mm_dist(text, motion, batch_size=3) == pytest.approx(4.0)


def test_incomplete_last_batch_is_dropped_and_shuffle_is_seeded():
    rng = np.random.default_rng(4)
    t, m = rng.normal(size=(70, 4)), rng.normal(size=(70, 4))
    assert retrieval_metrics(t, m).n_samples == 64
    a = retrieval_metrics(t, m, rng=np.random.default_rng(9))
    b = retrieval_metrics(t, m, rng=9)
    np.testing.assert_array_equal(a.r_precision, b.r_precision)


def test_retrieval_rejects_bad_input():
    with pytest.raises(ValueError, match="same shape"):
        retrieval_metrics(np.zeros((32, 4)), np.zeros((32, 5)))
    with pytest.raises(ValueError, match="at least batch_size"):
        retrieval_metrics(np.zeros((10, 4)), np.zeros((10, 4)))


# --- Diversity and MultiModality ------------------------------------------------------------------------------


def test_diversity_of_two_points_and_of_gaussians():
    pts = np.array([[0.0, 0.0], [3.0, 4.0]])  # pairs are (i, i) or (i, j): distance 0 or 5
    d = diversity(pts, rng=0)
    assert d in (0.0, 2.5, 5.0)
    x = np.random.default_rng(5).normal(size=(2000, 64))
    # E||a - b|| for independent N(0, I_64) is about sqrt(2 * 64)
    assert diversity(x, rng=np.random.default_rng(1)) == pytest.approx(np.sqrt(128), rel=0.02)
    assert diversity(x, rng=3) == diversity(x, rng=3)


def test_multimodality_identical_repeats_is_zero_and_scales():
    base = np.random.default_rng(6).normal(size=(5, 1, 16))
    assert multimodality(np.repeat(base, 30, axis=1), rng=0) == 0.0
    x = np.random.default_rng(7).normal(size=(20, 30, 16))
    assert multimodality(2 * x, rng=1) == pytest.approx(2 * multimodality(x, rng=1))
    with pytest.raises(ValueError, match="repeats"):
        multimodality(x[:, :5], rng=0)
    with pytest.raises(ValueError, match="rng"):
        multimodality(x, rng=None)


# --- protocol -------------------------------------------------------------------------------------------------


def test_mean_ci_and_estimate():
    vals = [1.0, 2.0, 3.0, 4.0]
    mean, hw = mean_ci(vals, method="normal")  # the papers' formula
    assert mean == 2.5 and hw == pytest.approx(1.96 * np.std(vals) / 2)
    est = Estimate.from_values([0.1225, 0.1235], method="normal")  # std 0.0005 -> 1.96 * 0.0005 / sqrt(2)
    assert str(est) == "0.12300 ± 0.00069" and est.n == 2  # two significant digits of the half-width
    assert f"{est:.3f}" == "0.123 ± 0.001" and f"{Estimate(0.5, 0.0, 3):.2f}" == "0.50 ± 0.00"  # fixed: tables
    assert str(Estimate(0.123, 0.004)) == "0.1230 ± 0.0040" and str(Estimate(0.2161)) == "0.216"
    assert tuple(est) == (est.mean, est.half_width) and est.minus(est).half_width == pytest.approx(
        0.00069 * 2**0.5, 0.01
    )
    runs = summarize_runs([{"fid": 0.1, "top1": 0.5}, {"fid": 0.3, "top1": 0.5}])
    assert runs["fid"].mean == pytest.approx(0.2) and runs["top1"].half_width == 0.0
    with pytest.raises(ValueError, match="empty"):
        mean_ci([])


@pytest.mark.parametrize("n", [2, 3, 5, 20])
def test_mean_ci_uses_students_t_by_default(n):
    from scipy import stats

    vals = np.random.default_rng(n).normal(1.0, 0.3, n)
    mean, hw = mean_ci(vals)
    low, high = stats.t.interval(0.95, n - 1, loc=vals.mean(), scale=stats.sem(vals))
    assert mean == pytest.approx(vals.mean()) and hw == pytest.approx((high - low) / 2, rel=1e-12)
    assert hw > mean_ci(vals, method="normal")[1]  # the papers' formula is narrower at every n
    assert tuple(mean_ci([0.7])) == (0.7, 0.0)
    est = Estimate.from_values(vals)
    assert est.excludes(mean + 1.01 * hw) and not est.excludes(mean + 0.99 * hw)
    with pytest.raises(ValueError, match="method"):
        mean_ci(vals, method="bootstrap")
