"""Chapter 06's sensitivity study of sJPE: how it, FID and the joint shift answer to frame noise and to temporal
smoothing of real clips, each level a row of estimates.

The metrics are :mod:`motionlab.metrics`'s (:func:`~motionlab.metrics.sjpe_dataset`, :func:`~motionlab.metrics.fid`)
and the perturbations :mod:`motionlab.metrics.perturbations`'; this module sweeps them over levels and lays the result
out as a :class:`MeasurementTable`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from motionlab.comparison import trend
from motionlab.estimate import Estimate
from motionlab.metrics.distribution import fid
from motionlab.metrics.perturbations import add_frame_noise, smooth_in_time
from motionlab.metrics.sjpe import sjpe_dataset, sjpe_from_features, sjpe_setting
from motionlab.representation import recover_from_ric
from motionlab.viz.tables import Table

# Column headers of the tables below; other keys print as themselves.
MEASUREMENT_LABELS = {
    "disp_mm": "joint RMS shift (mm)",
    "noise": "Noise sJPE",
    "static": "Static sJPE",
    "fid": "FID",
    "top1": "top-1",
    "top2": "top-2",
    "top3": "top-3",
    "mm_dist": "MM-Dist",
    "diversity": "Diversity",
}


class MeasurementTable(Table):
    """A :class:`~motionlab.viz.tables.Table` of :class:`~motionlab.estimate.Estimate` cells over a sweep's levels:
    each cell prints as the estimate does (two significant digits of its half-width, the value alone where it has
    none), so a column can span orders of magnitude (an FID of 1e-4 beside one of 3), unlike
    :class:`~motionlab.evaluation.EvaluationTable`'s fixed decimals. Levels print with ``:g``; columns by
    :data:`MEASUREMENT_LABELS`.
    """

    @property
    def levels(self) -> list:
        """The row labels (a sweep's levels), in order."""
        return self.labels

    def estimate(self, row: Any, column: str) -> Estimate:
        """The cell ``rows[row][column]``; a missing row or column is named with what the table has."""
        return self.cell(row, column)

    def trend(self, column: str, name: str = "", quantity: str | None = None):
        """The column as a :func:`motionlab.comparison.trend` over the rows, each step judged by the one rule; a row is
        named ``name`` + its label (e.g. ``name="σ = "``)."""

        names = [f"{name}{_label(row)}" for row, cells in self.rows.items() if column in cells]
        return trend(self.column(column), names, quantity=quantity or self.header(column))

    def header(self, column: str) -> str:
        return MEASUREMENT_LABELS.get(column, column)

    def row_label(self, label: Any) -> str:
        return _label(label)


def _label(row: Any) -> str:
    return f"{row:g}" if isinstance(row, (float, int, np.floating, np.integer)) else str(row)


def _features(features: Sequence, name: str) -> list[np.ndarray]:
    if isinstance(features, np.ndarray) or len(features) == 0:
        raise ValueError(f"{name} must be a non-empty list of raw (T, D) clips")
    return [np.asarray(f) for f in features]


def _check_noise_sweep_inputs(sigmas: Sequence[float], repeats: int) -> None:
    """Reject a non-positive ``repeats`` and an empty ``sigmas``."""
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be a positive int, got {repeats!r}")
    if len(sigmas) == 0:
        raise ValueError("sigmas is empty")


def noise_sweep(
    gt_features: Sequence[np.ndarray],
    sigmas: Sequence[float],
    normalizer: Any,
    embed: Any,
    *,
    repeats: int,
    seed: int = 0,
    skeleton: str = "t2m",
) -> MeasurementTable:
    """DisCoRD Fig. 4 on real clips: frame-wise Gaussian noise of each ``σ`` (normalised units,
    :func:`~motionlab.metrics.perturbations.add_frame_noise`), ``repeats`` draws per σ (draw ``r`` of level ``i``:
    ``default_rng([seed, i, r])``), each scored as the evaluation scores a decode.

    Columns: ``disp_mm``, the RMS displacement (mm) of the sJPE joints, to give σ a physical scale; ``noise`` and
    ``static``, the sJPE halves against the clean clips; ``fid``, between the embeddings (``embed``: raw clips ->
    ``(N, d)``, e.g. an evaluator's ``embed_motions``) of the clean and the noisy clips. ± is over the draws.
    """

    _check_noise_sweep_inputs(sigmas, repeats)
    clean = _features(gt_features, "gt_features")
    setting = sjpe_setting(skeleton)
    gt_joints = [recover_from_ric(f, setting.n_joints) for f in clean]
    gt_emb = embed(clean)
    selected = list(setting.joints)
    rows = {}
    for i, sigma in enumerate(sigmas):
        runs: dict[str, list[float]] = {"disp_mm": [], "noise": [], "static": [], "fid": []}
        for r in range(repeats):
            noisy = add_frame_noise(clean, sigma, normalizer, np.random.default_rng([seed, i, r]))
            noisy_joints = [recover_from_ric(n, setting.n_joints) for n in noisy]  # once, for sJPE and the shift
            score = sjpe_dataset(noisy_joints, gt_joints, skeleton)
            shift = np.concatenate(
                [
                    np.linalg.norm(n[:, selected] - g[:, selected], axis=-1).ravel()
                    for n, g in zip(noisy_joints, gt_joints)
                ]
            )
            runs["disp_mm"].append(1000 * setting.to_metres * np.sqrt(np.mean(shift**2)))
            runs["noise"].append(score.noise)
            runs["static"].append(score.static)
            runs["fid"].append(fid(gt_emb, embed(noisy)))
        rows[float(sigma)] = {k: Estimate.from_values(v) for k, v in runs.items()}
    note = f"± = 95% interval over {repeats} noise draws per σ (Student's t)."
    return MeasurementTable("σ (normalised)", rows, notes=(note,))


def smoothing_sweep(
    gt_features: Sequence[np.ndarray], sigmas_frames: Sequence[float], embed: Any, *, skeleton: str = "t2m"
) -> MeasurementTable:
    """The mirror image of :func:`noise_sweep`: each clip blurred in time by a Gaussian of ``σ_t`` frames
    (:func:`~motionlab.metrics.perturbations.smooth_in_time`). Deterministic, so the sJPE intervals are over clips;
    ``fid`` is one number per level."""

    if len(sigmas_frames) == 0:
        raise ValueError("sigmas_frames is empty")
    clean = _features(gt_features, "gt_features")
    gt_emb = embed(clean)
    rows = {}
    for s in sigmas_frames:
        smoothed = smooth_in_time(clean, s)
        score = sjpe_from_features(smoothed, clean, skeleton=skeleton)
        rows[float(s)] = {
            "noise": Estimate.from_values(score.noise_per_clip),
            "static": Estimate.from_values(score.static_per_clip),
            "fid": Estimate(fid(gt_emb, embed(smoothed))),
        }
    note = f"± = 95% interval over {len(clean)} clips (Student's t); FID is one number per level."
    return MeasurementTable("σ_t (frames)", rows, notes=(note,))
