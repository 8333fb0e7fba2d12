"""The diagrams of chapters 01 and 02: motion as data, residual vector quantization."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from motionlab import representation, tokenizers  # noqa: E402
from motionlab.viz.diagrams import foundations  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def texts(fig: Figure) -> list[str]:
    return [t.get_text() for ax in fig.axes for t in ax.texts]


def test_motion_as_data_labels_every_feature_group_with_its_computed_range_and_width():
    fig = foundations.motion_as_data()
    assert isinstance(fig, Figure) and fig.get_size_inches()[0] <= 7.4
    shown = "\n".join(texts(fig))
    for name, sl in representation.feature_slices("t2m").items():
        assert foundations.GROUP_LABELS[name] in shown
        assert f"[{sl.start}:{sl.stop}]" in shown
    assert "63 = 21 × 3" in shown and "126 = 21 × 6" in shown and "66 = 22 × 3" in shown
    assert "263" in shown
    for step in ("process_joints", "recover_from_ric", "recover_from_rot"):
        assert step in shown


def test_motion_as_data_draws_the_feature_column_to_scale():
    fig = foundations.motion_as_data()
    ax = fig.axes[0]
    colour = matplotlib.colors.to_rgba(foundations.GROUP_COLORS["rot"])
    rot = [p for p in ax.patches if p.get_facecolor() == colour]
    ric = [p for p in ax.patches if p.get_facecolor() == matplotlib.colors.to_rgba(foundations.GROUP_COLORS["ric"])]
    assert len(rot) == len(ric) == 1
    assert rot[0].get_height() / ric[0].get_height() == pytest.approx(126 / 63)


def test_motion_as_data_follows_the_skeleton_it_is_given():
    shown = "\n".join(texts(foundations.motion_as_data(skeleton="kit")))
    kit = representation.get_skeleton("kit")
    assert f"R}}^{{{kit.feature_dim}}}" in shown and f"{kit.n_joints} joints" in shown
    assert f"{3 * (kit.n_joints - 1)} = {kit.n_joints - 1} × 3" in shown


def test_motion_as_data_draws_the_poses_of_a_clip_and_their_times():
    rng = np.random.default_rng(0)
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (41, 22, 1))
    root = np.stack([np.zeros(41), np.full(41, 0.95), np.linspace(0, 2, 41)], axis=1)  # walks 2 m along z
    joints = representation.forward_kinematics(identity, root, "t2m") + rng.normal(0, 0.01, (41, 22, 3))
    fig = foundations.motion_as_data(joints, n_poses=3)
    chains = len(representation.T2M.chains)
    assert len(fig.axes[0].lines) >= 3 * chains  # every chain of every pose
    assert any("t = 0.0, 1.0, 2.0 s" in t for t in texts(fig))


def test_motion_as_data_rejects_bad_input():
    with pytest.raises(ValueError, match="shape"):
        foundations.motion_as_data(np.zeros((10, 21, 3)))
    with pytest.raises(ValueError, match="NaN"):
        foundations.motion_as_data(np.full((10, 22, 3), np.nan))
    with pytest.raises(ValueError, match="n_poses"):
        foundations.motion_as_data(n_poses=0)
    with pytest.raises(ValueError):
        foundations.motion_as_data(skeleton="no such skeleton")


def test_residual_vq_reads_its_sizes_from_the_config():
    config = tokenizers.RVQConfig()
    fig = foundations.residual_vq()
    assert isinstance(fig, Figure) and fig.get_size_inches()[0] <= 7.4
    shown = "\n".join(texts(fig))
    assert f"{config.num_layers} layers, each a codebook of {config.codebook_size} codes" in shown
    assert f"per {tokenizers.RVQVAE.downsample} frames" in shown
    assert f"ids in 0 … {config.codebook_size - 1}" in shown
    assert "layer 0: nearest" in shown and f"layer {config.num_layers - 1}: nearest" in shown
    assert "layer 2: nearest" not in shown  # three layers drawn: 0, 1, a gap, R - 1
    assert "⋮" in shown


def test_residual_vq_draws_every_layer_of_a_small_config():
    config = tokenizers.rvq_config("full", num_layers=3, codebook_size=16, code_dim=8)
    shown = "\n".join(texts(foundations.residual_vq(config, positions=5)))
    assert all(f"layer {k}: nearest\nof 16 codes" in shown for k in range(3))
    assert "⋮" not in shown
    assert "mathbf{r}^{2} = \\mathbf{r}^{1} - \\mathbf{q}^{1}" in shown  # the residual passed on at every step
    assert "3 × $T/4$ ids in 0 … 15" in shown


def test_residual_vq_rejects_bad_input():
    with pytest.raises(ValueError, match="RVQConfig"):
        foundations.residual_vq(tokenizers.vq_config("full"))
    with pytest.raises(ValueError, match="shown_layers"):
        foundations.residual_vq(shown_layers=1)
    with pytest.raises(ValueError, match="positions"):
        foundations.residual_vq(positions=9)
