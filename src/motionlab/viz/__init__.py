"""Visualisation: stick-figure animations, trajectory/jerk plots, the feature layout."""

from .plots import plot_feature_layout, plot_trajectories
from .skeleton import animate_motions, plot_pose

__all__ = ["animate_motions", "plot_feature_layout", "plot_pose", "plot_trajectories"]
