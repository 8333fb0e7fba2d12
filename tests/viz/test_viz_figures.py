"""Training curves, 2-D codebook snapshots, point clouds and the trajectory explorer."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402

from motionlab.tokenizers.analysis import drifting_ring, train_toy_quantizer  # noqa: E402
from motionlab.viz import plot_clouds, plot_codebook_snapshots, plot_history, trajectory_explorer  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def log(n, scale=1.0, val_every=0):
    rows = [{"step": s, "loss": scale / (s + 1), "perplexity": 2.0 + s} for s in range(n)]
    if val_every:
        rows += [{"step": s, "val_mse": 0.5} for s in range(0, n, val_every)]  # validation rows lack "loss"
    return rows


def test_plot_history_draws_one_line_per_run_and_panel():
    axes = plot_history(
        {"a": log(5, val_every=2), "b": log(3, 2.0)}, {"loss": "training loss", "perplexity": "pp"}, log=["loss"]
    )
    assert len(axes) == 2
    assert [len(ax.lines) for ax in axes] == [2, 2]
    assert axes[0].get_yscale() == "log" and axes[1].get_yscale() == "linear"
    assert axes[0].get_ylabel() == "training loss" and axes[0].get_xlabel() == "step"
    x, y = axes[0].lines[0].get_data()
    assert list(x) == [0, 1, 2, 3, 4] and np.allclose(y, [1 / (s + 1) for s in range(5)])  # val rows skipped
    (one,) = plot_history({"a": log(4)}, ["loss"], xlabel="training step")
    assert one.get_xlabel() == "training step" and one.get_ylabel() == "loss"


def test_plot_history_checks_its_arguments():
    with pytest.raises(ValueError, match="no history logged 'val_mse'"):
        plot_history({"a": log(3)}, ["val_mse"])
    with pytest.raises(ValueError, match="axes"):
        _, ax = plt.subplots()
        plot_history({"a": log(3)}, ["loss", "perplexity"], axes=ax)
    with pytest.raises(ValueError, match="at least one"):
        plot_history({}, ["loss"])


def test_codebook_snapshots_show_the_saved_step_at_or_after_each_request():
    _, trace = train_toy_quantizer(codebook_size=8, steps=40, seed=0, every=10)

    def data_at(step):
        return drifting_ring(step, torch.Generator().manual_seed(0))

    axes = plot_codebook_snapshots(trace, data_at, label="run", show_at=(5, 20, 400))
    assert [ax.get_title() for ax in axes] == ["run, step 10", "run, step 20", "run, step 40"]  # 400: the last saved
    codes = axes[1].collections[1].get_offsets()
    assert np.allclose(codes, trace.codebooks[2])  # the codebook after step 20
    assert len(axes[0].collections[0].get_offsets()) == 256  # that step's data
    with pytest.raises(ValueError, match="2-D codebooks"):
        plot_codebook_snapshots(type("T", (), {"steps": [0], "codebooks": np.zeros((1, 4, 3))})(), data_at)


def test_plot_clouds_draws_each_cloud_on_square_axes():
    rng = np.random.default_rng(0)
    clouds = {"a": rng.normal(size=(50, 2)), "b": None, "c": torch.randn(30, 2)}
    axes = plot_clouds(clouds, background=rng.normal(size=(20, 2)), lim=2.0)
    assert [ax.get_title() for ax in axes] == ["a", "b", "c"]
    assert axes[0].get_xlim() == (-2.0, 2.0) and axes[2].get_ylim() == (-2.0, 2.0)
    assert [len(ax.collections) for ax in axes] == [2, 1, 2]  # background + cloud; "b" only the background
    assert axes[1].texts[0].get_text() == "not possible"
    assert len(axes[2].collections[1].get_offsets()) == 30
    _, ax = plt.subplots()
    (single,) = plot_clouds({"x": rng.normal(size=(5, 2))}, ax, colors=np.arange(5))
    assert single is ax
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        plot_clouds({"bad": np.zeros((4, 3))})
    with pytest.raises(ValueError, match="empty"):
        plot_clouds({})


def test_trajectory_explorer_shows_the_default_clip(monkeypatch):
    pytest.importorskip("ipywidgets")
    shown = []
    monkeypatch.setattr(plt, "show", lambda: shown.append(plt.gcf()))
    motion = np.zeros((12, 22, 3))
    motion[:, :, 1] = np.linspace(0, 1, 12)[:, None]
    calls = []

    def motions_of(i):
        calls.append(i)
        return {"clip": motion + i}

    trajectory_explorer(motions_of, ["first", "second"], joint=20)
    assert calls == [0] and len(shown) == 1
    top, bottom = shown[0].axes
    assert top.get_title() == "left_wrist" and len(top.lines) == 1 and len(bottom.lines) == 1
    with pytest.raises(ValueError, match="joint"):
        trajectory_explorer(motions_of, ["first"], joint=30)
    with pytest.raises(ValueError, match="choices"):
        trajectory_explorer(motions_of, [], joint=0)
