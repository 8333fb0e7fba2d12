"""Visualisation: stick-figure animations, trajectory/jerk plots, the feature layout, training curves, 2-D codebooks
and point clouds, and small tables for reading (:class:`~motionlab.viz.tables.Table`).

The plotting functions are imported on first use: importing ``motionlab.viz.tables``
must not start matplotlib, which costs about a second.
"""

from importlib import import_module
from typing import Any

_WHERE = {
    "plot_clouds": "plots",
    "plot_codebook_snapshots": "plots",
    "plot_feature_layout": "plots",
    "plot_history": "plots",
    "plot_trajectories": "plots",
    "trajectory_explorer": "plots",
    "animate_motions": "skeleton",
    "plot_pose": "skeleton",
    "Table": "tables",
    "feature_differences": "tables",
    "skeleton_table": "tables",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(import_module(f"{__name__}.{_WHERE[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
