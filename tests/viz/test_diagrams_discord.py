"""Chapter 05's pipeline diagram: it draws, its sizes are the config's, its labels follow the config's departures."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

from motionlab.flow import DisCoRDConfig, discord_config  # noqa: E402
from motionlab.models import xpred_config  # noqa: E402
from motionlab.viz.diagrams import discord  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def texts(fig) -> str:
    return "\n".join(t.get_text() for ax in fig.axes for t in ax.texts)


def test_the_papers_decoder_is_drawn_with_table_a_sizes():
    fig = discord.pipeline()
    (ax,) = fig.axes
    label = texts(fig)
    for expected in (
        "16 tokens × 6 layers",  # a 64-frame window of MoMask's RVQ ids
        "16 × 512",  # summed code vectors
        "repeat ×4, stack: 16 × 2048",
        "linear, unstack: 64 × 512",
        "64 × 256",  # the frame-wise condition
        "64 × 519",  # x_t (263) concatenated with C (256)
        "15 midpoint steps = 30 U-Net calls",
        "channels 512, 512, 1024",
        r"$\mathbf{x}_0 \sim \mathcal{N}(0, I)$",
        r"$v_\theta(\mathbf{x}_t, t, \mathbf{C})$",
    ):
        assert expected in label, expected
    boxes = [p for p in ax.patches if isinstance(p, FancyBboxPatch)]
    arrows = [p for p in ax.patches if isinstance(p, FancyArrowPatch)]
    assert len(boxes) == 9 and len(arrows) == 9  # 8 boxes and the dashed ODE loop; every arrow of the data flow
    assert fig.get_size_inches()[0] <= 7.4


def test_sizes_and_departures_follow_the_config():
    config = xpred_config("laptop", None, feature_dim=251, code_dim=32)  # x-prediction from zero noise, 8 steps
    label = texts(discord.pipeline(config, residual_layers=1, frames=96))
    assert "24 tokens × 1 layer (" in label and "24 × 32" in label
    assert f"96 × {251 + config.cond_dim}" in label and "96 × 251" in label
    assert "8 midpoint steps = 16 U-Net calls" in label
    assert r"$\mathbf{x}_0 = 0$ (temperature 0)" in label
    assert r"outputs $\hat{\mathbf{x}}_1$" in label and "v_\\theta" not in label
    paper = texts(discord.pipeline(discord_config("laptop")))  # the paper's protocol: v from N(0, I), 15 steps
    assert "15 midpoint steps = 30 U-Net calls" in paper and r"\mathcal{N}(0, I)" in paper and "v_\\theta" in paper
    warm = texts(discord.pipeline(DisCoRDConfig(temperature=0.5)))
    assert r"\mathcal{N}(0, 0.5^2 I)" in warm


@pytest.mark.parametrize(
    "projection,expected",
    [("repeat", "repeat ×4: 64 × 512\nlinear per frame: 64 × 256"), ("transposed", "transposed conv, stride 4")],
)
def test_the_ablations_projections_are_drawn_as_they_compute(projection, expected):
    assert expected in texts(discord.pipeline(DisCoRDConfig(projection=projection)))


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="DisCoRDConfig"):
        discord.pipeline({"width": 512})
    for layers in (0, 1.5, True):
        with pytest.raises(ValueError, match="residual_layers"):
            discord.pipeline(residual_layers=layers)
    for frames in (0, 62, 64.0):
        with pytest.raises(ValueError, match="frames"):
            discord.pipeline(frames=frames)
