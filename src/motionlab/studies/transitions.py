"""Chapter 09's close look at one example: M2D2M's transition Jerk (Eq. 10) at each boundary of a few multi-motions
sampled different ways, as a table (the measurement is :func:`motionlab.multimotion.transition_jerk`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from motionlab.multimotion.evaluation import DEFAULT_WINDOW, motion_parts, transition_jerk
from motionlab.viz.tables import Table


def boundary_jerk_table(motions: Mapping, window: int = DEFAULT_WINDOW) -> Table:
    """Eq. 10 around every boundary of each named multi-motion (``.features``/``.boundaries`` or a pair), and their
    mean: a :class:`~motionlab.viz.tables.Table` with one row per name, lower is smoother."""
    if not motions:
        raise ValueError("motions is empty: pass {name: multi-motion}")
    rows = {}
    for name, motion in motions.items():
        features, boundaries = motion_parts(motion)
        jerk = transition_jerk(features, boundaries, window)
        rows[name] = {**{f"boundary {i + 1}": float(j) for i, j in enumerate(jerk)}, "mean": float(np.mean(jerk))}
    note = f"Jerk (M2D2M Eq. 10) in the {window} frames around each boundary; lower is smoother."
    return Table("motion", rows, notes=(note,))


__all__ = ["boundary_jerk_table"]
