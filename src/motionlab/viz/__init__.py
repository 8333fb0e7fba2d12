"""Visualisation: stick-figure animations, trajectory/jerk plots, the feature layout.

The plotting functions are imported on first use: importing ``motionlab.viz.palette`` (what the HTML writer
needs) must not start matplotlib, which costs about a second.
"""

from importlib import import_module
from typing import Any

_WHERE = {
    "plot_feature_layout": "plots",
    "plot_trajectories": "plots",
    "animate_motions": "skeleton",
    "plot_pose": "skeleton",
}

__all__ = ["animate_motions", "plot_feature_layout", "plot_pose", "plot_trajectories"]


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(import_module(f"{__name__}.{_WHERE[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
