"""The motion player: panels at least 300 px tall within the page's width, titles wrapped (never cut), and
segments (which action plays) labelled frame by frame with their boundaries marked."""

import matplotlib

matplotlib.use("Agg")

import matplotlib as mpl  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from motionlab.representation import forward_kinematics  # noqa: E402
from motionlab.viz import animate_motions  # noqa: E402
from motionlab.viz.skeleton import MIN_PANEL_PX, PAGE_WIDTH, panel_grid, segment_at, wrap_title  # noqa: E402

LONG = "a person walks forward slowly, stops, turns around to the left and then waves with the right hand"


@pytest.fixture(autouse=True)
def book_dpi():
    with mpl.rc_context({"figure.dpi": 90}):  # the book's dpi (motionlab.book.RC_PARAMS)
        yield
    plt.close("all")


def walk(frames=40):
    quats = np.zeros((frames, 22, 4))
    quats[..., 0] = 1.0
    root = np.stack([np.linspace(0, 1, frames), np.full(frames, 0.95), np.zeros(frames)], axis=-1)
    return forward_kinematics(quats, root, "t2m")


def panels(anim):
    return [ax for ax in anim._fig.axes if ax.name == "3d"]


def texts(anim):
    return [t.get_text() for t in anim._fig.texts]


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_every_panel_is_300_px_tall_and_the_player_fits_the_page(n):
    anim = animate_motions([walk()] * n, titles=[f"motion {i}" for i in range(n)])
    fig = anim._fig
    width, height = fig.get_size_inches()
    assert width <= PAGE_WIDTH + 1e-9
    for ax in panels(anim):
        box = ax.get_position(original=True)
        assert box.height * height * fig.dpi >= MIN_PANEL_PX - 1e-6  # not shrunk: the figure is at most page wide
        assert box.x0 >= -1e-9 and box.x1 <= 1 + 1e-9
    assert len(panels(anim)) == n


def test_panels_wrap_into_even_rows():
    height = MIN_PANEL_PX / 90
    assert panel_grid(1, height)[:2] == (1, 1)
    assert panel_grid(3, height)[:2] == (2, 2)  # two per row fit in 7.4 inches
    assert panel_grid(4, height)[:2] == (2, 2)
    assert panel_grid(3, 2.0)[:2] == (1, 3)  # smaller panels: three side by side
    rows, cols, width = panel_grid(2, 20.0)
    assert (rows, cols) == (2, 1) and width == PAGE_WIDTH  # a panel wider than the page is narrowed


def test_an_explicit_size_is_the_panel_height():
    fig = animate_motions([walk()] * 3, size=2.0)._fig
    assert fig.get_size_inches()[0] == pytest.approx(6.0)
    assert [round(ax.get_position(original=True).height * fig.get_size_inches()[1], 6) for ax in fig.axes] == [2.0] * 3


def test_long_titles_wrap_over_lines_and_keep_every_word():
    anim = animate_motions([walk(), walk()], titles=[LONG, "short"])
    shown = texts(anim)
    assert "short" in shown
    (long_title,) = [t for t in shown if "\n" in t]
    assert long_title.replace("\n", " ") == LONG  # wrapped, not cut
    assert all(len(line) <= len(LONG) // 2 for line in long_title.split("\n"))
    assert wrap_title("", 2.0) == "" and wrap_title("abc", 2.0) == "abc"


def test_segments_label_every_frame_and_mark_the_boundaries():
    segments = [(0, "a person walks forward"), (15, LONG), (30, "a person jumps")]
    anim = animate_motions([walk(), walk()], titles=["real", "generated"], segments=segments, max_frames=40)
    fig = anim._fig
    (label,) = [t for t in fig.texts if t.get_gid() == "segment"]
    (timeline,) = [ax for ax in fig.axes if ax.get_gid() == "timeline"]
    boundaries = [line.get_xdata()[0] for line in timeline.lines if line.get_gid() == "boundary"]
    assert boundaries == pytest.approx([15 / 20, 30 / 20])  # seconds at 20 fps
    (cursor,) = [line for line in timeline.lines if line.get_gid() == "cursor"]
    for frame, k in [(0, 0), (14, 0), (15, 1), (29, 1), (30, 2), (39, 2)]:
        anim._draw_frame(frame)
        assert label.get_text().replace("\n", " ") == f"{k + 1}/3: {segments[k][1]}"
        assert cursor.get_xdata()[0] == pytest.approx(frame / 20)
    assert segment_at(segments, 22) == 1


def test_segments_with_subsampled_frames_follow_the_motion_frames():
    anim = animate_motions(walk(120), segments=[(0, "a"), (61, "b")], max_frames=30)  # stride 4: 0, 4, ..., 116
    (label,) = [t for t in anim._fig.texts if t.get_gid() == "segment"]
    anim._draw_frame(60)
    assert label.get_text() == "1/2: a"
    anim._draw_frame(64)
    assert label.get_text() == "2/2: b"


@pytest.mark.parametrize(
    "segments, match",
    [
        ([], "non-empty"),
        ("walk", "non-empty"),
        ([(5, "a")], "begin at 0"),
        ([(0, "a"), (0, "b")], "increase"),
        ([(0, "a"), (20, "b"), (10, "c")], "increase"),
        ([(0, "a"), (40, "b")], "below 40"),
        ([(0.0, "a")], "int start_frame"),
        ([(0, 3)], "str label"),
        ([(0, "a", "b")], "pair"),
    ],
)
def test_bad_segments_are_rejected(segments, match):
    with pytest.raises(ValueError, match=match):
        animate_motions(walk(40), segments=segments)


def test_bad_sizes_and_titles_are_rejected():
    for size in (0, -1.0, True, "big"):
        with pytest.raises(ValueError, match="size"):
            animate_motions(walk(), size=size)
    with pytest.raises(ValueError, match="width"):
        animate_motions(walk(), width=0)
    with pytest.raises(ValueError, match="titles must be str"):
        animate_motions([walk()], titles=[3])
    with pytest.raises(ValueError, match="at least one"):
        animate_motions([])
