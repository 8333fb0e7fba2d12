"""The flow part's diagrams: rectified-flow paths (03), the condition projection (04), sJPE's two halves (06)."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402

from motionlab.flow.toy import flow_trajectory, straightness  # noqa: E402
from motionlab.metrics import finite_difference_jerk  # noqa: E402
from motionlab.viz import diagrams  # noqa: E402

flow = diagrams.flow


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def texts(fig) -> str:
    return " ".join(t.get_text() for t in fig.findobj(matplotlib.text.Text))


def test_the_ring_field_is_the_average_velocity_of_the_straight_paths():
    field = flow.RingField(seed=0)
    assert field.centres.shape == (8, 2) and 0.1 < field.spread < 0.2  # measured on sample_toy's ring
    x = torch.randn(6, 2, generator=torch.Generator().manual_seed(1))
    # at t = 0, x_t = x0 says nothing about x1: every point heads for the data mean (the ring's centre)
    assert torch.allclose(field(x, torch.zeros(6)), field.centres.mean(0).float() - x, atol=0.05)
    # given its cluster, a path is almost the straight line to the cluster; without it, it bends
    x0 = torch.randn(200, 2, generator=torch.Generator().manual_seed(2))
    ids = torch.randint(0, 8, (200,), generator=torch.Generator().manual_seed(3))
    bent = straightness(flow_trajectory(field, x0, 32, "midpoint")).mean()
    straight = straightness(flow_trajectory(field, x0, 32, "midpoint", ids)).mean()
    assert straight > 0.97 > bent
    end = flow_trajectory(field, x0, 64, "midpoint", ids)[-1]
    assert (end - field.centres[ids].float()).norm(dim=1).median() < 0.3  # it lands in its own cluster


def test_rectified_paths_draws_four_panels_and_rejects_bad_input():
    fig = flow.rectified_paths(n_paths=10, step=0.4)
    axes = fig.axes
    assert len(axes) == 4 and fig.get_size_inches()[0] <= flow.MAX_WIDTH
    assert len(axes[0].lines) == 10 and len(axes[1].lines) == 10 and len(axes[2].lines) == 10
    words = texts(fig)
    for expected in ("straight lines that cross", "curved", "Euler step", "midpoint step", "t = 0.4"):
        assert expected in words
    with pytest.raises(ValueError, match="n_paths"):
        flow.rectified_paths(n_paths=1)
    with pytest.raises(ValueError, match="step"):
        flow.rectified_paths(step=0.0)


def test_projection_features_repeat_gives_equal_frames_stacked_distinct_ones():
    feats = flow.projection_features(q=4, n_tokens=3, code_dim=5, cond_dim=6, seed=0)
    assert feats["stacked"].shape == feats["repeat"].shape == (12, 6)
    repeat = feats["repeat"].reshape(3, 4, 6)
    stacked = feats["stacked"].reshape(3, 4, 6)
    assert np.allclose(repeat, repeat[:, :1])  # the q frames of one token are one vector
    assert (np.abs(stacked - stacked[:, :1]).max(axis=(1, 2)) > 1e-3).all()
    again = flow.projection_features(q=4, n_tokens=3, code_dim=5, cond_dim=6, seed=0)
    assert np.array_equal(again["stacked"], feats["stacked"])  # seeded: the picture does not change between builds
    with pytest.raises(ValueError, match="q"):
        flow.projection_features(q=0)


def test_condition_projection_draws_both_projections_and_rejects_bad_input():
    fig = flow.condition_projection(q=4, n_tokens=3)
    assert fig.get_size_inches()[0] <= flow.MAX_WIDTH
    words = texts(fig)
    for expected in ("repeat", "stack", "unstack", "plain repetition", "q distinct frames", "q equal frames"):
        assert expected in words
    images = fig.axes[0].get_images()
    assert len(images) == 2  # the frame features of the two projections
    stacked, repeat = (np.asarray(im.get_array()) for im in images)
    assert np.allclose(repeat[:, 0], repeat[:, 3]) and not np.allclose(stacked[:, 0], stacked[:, 3])
    with pytest.raises(ValueError, match="q"):
        flow.condition_projection(q=1)
    with pytest.raises(ValueError, match="16 frames"):
        flow.condition_projection(q=4, n_tokens=5)


def test_sjpe_halves_shades_what_the_elements_count():
    pred, truth = flow.example_jerk()
    jp, jt = (np.abs(finite_difference_jerk(x, 20.0, axis=0))[:, 0] for x in (pred, truth))
    half = len(jp) // 2
    assert (jp[: half - 3] > jt[: half - 3]).mean() > 0.7  # the jittery half mostly adds jerk
    assert jt.max() > 2 * jp[half:].max()  # the blurred half misses the drop's jerk
    fig = flow.sjpe_halves()
    assert fig.get_size_inches()[0] <= flow.MAX_WIDTH and len(fig.axes) == 2
    words = texts(fig)
    for expected in ("Noise: jerk added", "Static: jerk missed", "Noise element", "Static element"):
        assert expected in words
    bars = [p.get_height() for p in fig.axes[1].patches]
    assert len(bars) == 2 * len(jp) and max(bars) <= 1 and min(bars) >= -1
    with pytest.raises(ValueError, match="fps"):
        flow.sjpe_halves(fps=0.0)
