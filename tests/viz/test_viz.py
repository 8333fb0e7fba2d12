import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from motionlab.representation import T2M, forward_kinematics  # noqa: E402
from motionlab.viz import animate_motions, plot_feature_layout, plot_pose, plot_trajectories  # noqa: E402


def rest_motion(frames=30):
    quats = np.zeros((frames, 22, 4))
    quats[..., 0] = 1.0
    root = np.stack([np.linspace(0, 1, frames), np.full(frames, 0.95), np.zeros(frames)], axis=-1)
    return forward_kinematics(quats, root, "t2m")


def test_animation_subsamples_and_embeds():
    anim = animate_motions([rest_motion(130), rest_motion(40)], titles=["a", "b"], max_frames=20, trail_joint=20)
    html = anim.to_jshtml()
    assert "<img" in html or "data:image/png" in html
    assert len(list(anim.new_frame_seq())) <= 20


def test_static_plots_draw():
    motion = rest_motion()
    assert plot_pose(motion[0]) is not None
    axes = plot_trajectories({"a": motion, "b": motion + 0.01}, joint=20)
    assert len(axes[0].lines) == 2 and len(axes[1].lines) == 2
    ax = plot_feature_layout("t2m")
    assert ax.get_xlim() == (0, T2M.feature_dim)


def test_bad_inputs():
    with pytest.raises(ValueError, match=r"\(T, J, 3\)"):
        animate_motions(np.zeros((5, 22)))
    with pytest.raises(ValueError, match="titles"):
        animate_motions([rest_motion()], titles=["a", "b"])
    with pytest.raises(ValueError, match="joint must be"):
        plot_trajectories({"a": rest_motion()}, joint=30)
    with pytest.raises(ValueError, match="NaN"):
        plot_pose(np.full((22, 3), np.nan))
