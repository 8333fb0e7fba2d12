"""Chapter 02's look at its tokenizers: configs, codebook usage, reconstruction error and jerk as tables, and a
book tokenizer loaded with its training log.

The measurements are the tokenizer package's (:func:`motionlab.tokenizers.analysis.codebook_usage`,
:class:`~motionlab.tokenizers.analysis.Reconstruction`, :func:`motionlab.metrics.sjpe_dataset`); this module lays
them out as :class:`~motionlab.viz.tables.Table` objects that render as Markdown.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from motionlab import models
from motionlab.estimate import mean_ci
from motionlab.profiles import get_profile
from motionlab.tokenizers.analysis import CodebookUsage, Reconstruction
from motionlab.train import is_trained, load_result
from motionlab.viz.tables import Table

# ----------------------------------------------------------------------------------------------
# Tables for reading (chapter 02)

CONFIG_FIELDS = ("width", "depth", "code_dim", "codebook_size", "window", "batch_size")


def config_table(configs: Mapping[str, Any]) -> Table:
    """Tokenizer configs side by side (e.g. one per profile): architecture, batch, training steps and lr."""
    if not configs:
        raise ValueError("configs is empty")
    rows = {
        name: {**{f: getattr(c, f) for f in CONFIG_FIELDS}, "steps": int(c.train.steps), "lr": float(c.train.lr)}
        for name, c in configs.items()
    }
    return Table("profile", rows, formats={"lr": "g"})


def usage_table(usage: Mapping[str, CodebookUsage]) -> Table:
    """One row per tokenizer and layer: the share of codes used, the perplexity and the codebook size K."""
    if not usage:
        raise ValueError("usage is empty")
    rows = {}
    for name, u in usage.items():
        for layer in range(u.num_layers):
            label = name if u.num_layers == 1 else f"{name} layer {layer}"
            rows[label] = {
                "codes used": float(u.usage[layer]),
                "perplexity": float(u.perplexity[layer]),
                "K": u.codebook_size,
            }
    return Table("tokenizer", rows, formats={"codes used": ".0%", "perplexity": ".1f"})


def error_table(reconstructions: Mapping[str, Reconstruction]) -> Table:
    """Per tokenizer: codes per 4 frames, MPJPE and feature MSE (mean ± 95% interval over the same clips).

    Its columns are ``"tokens per 4 frames"``, ``"MPJPE"`` and ``"feature MSE"``; :meth:`Table.compare` judges two
    rows by the one rule, e.g. ``error_table(rec).compare("RVQ", "VQ", "MPJPE")``.
    """
    if not reconstructions:
        raise ValueError("reconstructions is empty")
    counts = {len(r.mpjpe_mm) for r in reconstructions.values()}
    if len(counts) != 1:
        raise ValueError(f"the reconstructions cover different numbers of clips: {sorted(counts)}")
    rows = {}
    for name, r in reconstructions.items():
        e = r.errors()
        rows[name] = {"tokens per 4 frames": r.tokens_per_step, "MPJPE": e["mpjpe_mm"], "feature MSE": e["feature_mse"]}
    note = f"{counts.pop()} clips; ± = 95% interval over clips (Student's t); feature MSE on normalised features."
    return Table("tokenizer", rows, notes=(note,))


JERK_COLUMNS = ("sJPE", "Noise", "Static")


def jerk_table(scores: Mapping[str, Any]) -> Table:
    """Per decoder: sJPE, its Noise and Static halves (mean ± 95% interval over clips) and the mean jerk of the
    reconstructions (at the sJPE joints, averaged over clips) beside the ground truth's. ``scores`` maps a name to
    :func:`motionlab.metrics.sjpe_dataset`'s result; the rows are named ``"<name> feed-forward"``."""
    if not scores:
        raise ValueError("scores is empty")
    rows = {}
    for name, s in scores.items():
        parts = (s.sjpe_per_clip, s.noise_per_clip, s.static_per_clip)
        rows[f"{name} feed-forward"] = {
            **{column: mean_ci(values) for column, values in zip(JERK_COLUMNS, parts, strict=True)},
            "mean jerk (m/s³)": float(s.jerk_pred_per_clip.mean()),
            "ground truth's (m/s³)": float(s.jerk_gt_per_clip.mean()),
        }
    formats = {"mean jerk (m/s³)": ".1f", "ground truth's (m/s³)": ".1f"}
    return Table("decoder", rows, notes=("± = 95% interval over clips (Student's t).",), formats=formats)


# ----------------------------------------------------------------------------------------------
# A tokenizer and its training log


@dataclass(frozen=True)
class TrainedTokenizer:
    """The book's tokenizer of a dataset, with the history its training logged."""

    kind: str
    model: Any  # VQVAE | RVQVAE
    history: list[dict[str, float]]
    seconds: float | None  # wall clock of training in this call; None when it came from the cache

    @property
    def losses(self) -> list[float]:
        """The training loss at each logged step."""
        return [row["loss"] for row in self.history if "loss" in row]

    @property
    def val_mse(self) -> float:
        """The last validation feature MSE."""
        values = [row["val_mse"] for row in self.history if "val_mse" in row]
        if not values:
            raise ValueError(f"the {self.kind} training log has no validation rows")
        return float(values[-1])

    def __str__(self) -> str:
        how = "loaded from the cache" if self.seconds is None else f"trained in {self.seconds:.0f} s"
        return f"{self.kind}: {how} ({sum(p.numel() for p in self.model.parameters()):,} weights)"


def load_with_history(kind: str, dataset, profile: str | None = None) -> TrainedTokenizer:
    """``models.load("tokenizer/<kind>", dataset)`` (trained on first use, then cached), with its training log and,
    when this call trained it, how long that took."""
    from motionlab.tokenizers.training import KINDS

    if kind not in KINDS:
        raise ValueError(f"kind must be one of {sorted(KINDS)}, got {kind!r}")
    profile = get_profile(profile)
    config = KINDS[kind](profile, feature_dim=dataset.kind.feature_dim, n_joints=dataset.skeleton.n_joints)
    extra = {"data": dataset.key}
    cached = is_trained(kind, config, profile, extra=extra)
    start = time.perf_counter()
    model = models.load(f"tokenizer/{kind}", dataset, profile)
    seconds = None if cached else time.perf_counter() - start
    return TrainedTokenizer(kind, model, load_result(kind, config, profile, extra=extra), seconds)


__all__ = [
    "CONFIG_FIELDS",
    "JERK_COLUMNS",
    "TrainedTokenizer",
    "config_table",
    "error_table",
    "jerk_table",
    "load_with_history",
    "usage_table",
]
