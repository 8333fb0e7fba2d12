"""Chapter 09's diagram of Two-Phase Sampling: it draws, its numbers are the sampler's and the schedule's, it rejects
what it cannot draw."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

from motionlab.diffusion import get_schedule  # noqa: E402
from motionlab.multimotion import phase_grid  # noqa: E402
from motionlab.viz.diagrams import tps  # noqa: E402

TEXTS = ["a person walks forward and then turns around to the left", "a person waves", "a man jumps"]
FRAMES = [48, 120, 60]  # 12 + 30 + 15 = 57 tokens


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def texts(fig) -> str:
    """Every text of the diagram on one line each, wrapped lines joined by spaces."""
    return "\n".join(t.get_text().replace("\n", " ") for ax in fig.axes for t in ax.texts)


def test_the_papers_setting_is_drawn_with_the_samplers_numbers():
    fig = tps.two_phase(TEXTS, FRAMES, 100, 90)
    (ax,) = fig.axes
    label = texts(fig)
    for expected in (
        "48 frames, 12 tokens",
        "120 frames, 30 tokens",
        "one sequence of 57 [MASK] tokens",
        "joint phase, t = 100 … 91 (10 steps)",  # every step on the full grid
        "t = 90 … 1 (90 steps)",
        "one motion of 228 frames",
        "boundaries at frames 48, 168",
        "$T_s = 90$",
        "$t = T_d = 100$",
    ):
        assert expected in label, expected
    assert f"“{TEXTS[0]}”" in label  # wrapped, not cut
    share = 1 - float(get_schedule(T=100).gamma_bar[90] / get_schedule(T=100).gamma_bar[100])
    assert f"about {100 * share:.0f} % hold a code" in label
    boxes = [p for p in ax.patches if isinstance(p, FancyBboxPatch)]
    arrows = [p for p in ax.patches if isinstance(p, FancyArrowPatch)]
    assert len(boxes) == 3 + 1 + 3 + 1  # texts, the joint phase, one independent phase per action, the output
    assert len(arrows) == 2 + 3 * 4  # into and out of the joint phase; per action: split, in, out, to the decoder
    assert fig.get_size_inches()[0] <= 7.4


def test_steps_follow_the_grid_and_T_s():
    label = texts(tps.two_phase(TEXTS[:2], FRAMES[:2], 100, 90, num_steps=25))
    joint, independent = tps.phase_steps(100, 90, 25)
    grid = phase_grid(100, 90, 25)
    assert joint + independent == len(grid) - 1 and joint == sum(t > 90 for t in grid[:-1])
    assert f"({joint} steps)" in label and f"({independent} steps)" in label
    alone = texts(tps.two_phase(["a man jumps"], [60], 10, 10))  # T_s = T: no joint step, one action
    assert "no joint phase ($T_s = T_d$)" in alone and "boundaries at frames none (one action)" in alone
    assert "no step ($T_s = 0$)" in texts(tps.two_phase(TEXTS[:2], FRAMES[:2], 10, 0))  # fully joint
    assert tps.decided_share(get_schedule(T=10), 10) == 0.0 and tps.decided_share(get_schedule(T=10), 0) == 1.0


@pytest.mark.parametrize(
    "args, kwargs, match",
    [
        (("a man jumps", [60]), {}, "list of str"),
        ((["a", "b"], [60]), {}, "one length per text"),
        ((["a"] * 7, [60] * 7), {}, "1 to 6 actions"),
        (([], []), {}, "1 to 6 actions"),
        ((["a", "b"], [60, 62]), {}, "multiples of 4"),
        ((["a"], [60], 100, 101), {}, "T_s"),
        ((["a"], [60], 100, -1), {}, "T_s"),
        ((["a"], [60], 0, 0), {}, "T must be"),
        ((["a"], [60], 100, 90), {"schedule": get_schedule(T=50)}, "T = 100"),
    ],
)
def test_bad_inputs_are_rejected(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        tps.two_phase(*args, **kwargs)


def test_mark_segments_draws_every_boundary_and_every_text_whole():
    fig, axes = plt.subplots(2, 1, figsize=(7.4, 3), sharex=True)
    for ax in axes:
        ax.plot([0, 11.4], [0, 1])
    tps.mark_segments(axes, [48, 168], TEXTS, fps=20)
    for ax in axes:
        lines = [line.get_xdata()[0] for line in ax.lines if line.get_gid() == "boundary"]
        assert lines == pytest.approx([2.4, 8.4])  # seconds at 20 fps
    labels = [t for t in axes[0].texts if t.get_gid() == "segment"]
    assert [t.get_text().replace("\n", " ") for t in labels] == [f"{i + 1}: {text}" for i, text in enumerate(TEXTS)]
    assert "\n" in labels[0].get_text()  # a long text over a short segment wraps
    assert [t.get_position()[0] for t in labels] == sorted(t.get_position()[0] for t in labels)
    assert not axes[1].texts


@pytest.mark.parametrize(
    "boundaries, texts_, fps, match",
    [
        ([48], TEXTS, 20, "one text per action"),
        ([48, 168], "abc", 20, "one text per action"),
        ([168, 48], TEXTS, 20, "increasing"),
        ([0, 48], TEXTS, 20, "positive"),
        ([48, 168], TEXTS, 0, "fps"),
    ],
)
def test_mark_segments_rejects_bad_input(boundaries, texts_, fps, match):
    _, ax = plt.subplots()
    with pytest.raises(ValueError, match=match):
        tps.mark_segments(ax, boundaries, texts_, fps)
