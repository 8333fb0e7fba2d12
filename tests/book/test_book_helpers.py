"""motionlab.book: setup() seeds and configures, show_source() shows library code, animations embed."""

from __future__ import annotations

import random
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402
from matplotlib.animation import FuncAnimation  # noqa: E402

from motionlab import book, results  # noqa: E402


def test_setup_returns_profile_and_seeds_everything(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_PROFILE", "smoke")
    threads = torch.get_num_threads()
    try:
        assert book.setup(seed=3).profile == "smoke"
        first = (random.random(), np.random.rand(), torch.rand(1).item())  # noqa: NPY002
        assert book.setup(seed=3, profile="FULL").profile == "full"
        second = (random.random(), np.random.rand(), torch.rand(1).item())  # noqa: NPY002
        assert first == second
        assert matplotlib.rcParams["animation.embed_limit"] == book.RC_PARAMS["animation.embed_limit"]
        book.setup(seed=0, threads=1)
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(threads)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"), ({"profile": "big"}, "profile"), ({"threads": 0}, "threads")],
)
def test_setup_validates(kwargs, match):
    with pytest.raises(ValueError, match=match):
        book.setup(**kwargs)


@pytest.mark.parametrize("value", ["0", "two"])
def test_setup_rejects_a_bad_threads_variable(monkeypatch, value):
    monkeypatch.setenv("MOTIONLAB_THREADS", value)
    with pytest.raises(ValueError, match="MOTIONLAB_THREADS must be a positive int"):
        book.setup(seed=0)


def test_show_source_can_leave_the_docstring_out():
    full, bare = book.show_source(results.record).data, book.show_source(results.record, docstring=False).data
    assert '"""' in full and '"""' not in bare and bare.startswith("def record(")
    assert set(bare.splitlines()) <= set(full.splitlines()) and bare.splitlines()[-1] == full.splitlines()[-1]


def test_show_source_gives_highlightable_library_code():
    code = book.show_source(results.Less.judge)  # a method: the source comes back dedented
    assert code.language == "python" and code.data.startswith("def judge(")
    html = code._repr_html_()
    assert "judge" in html and "<span" in html  # pygments highlighted it
    assert book.show_source(results.record).data.startswith("def record(")
    with pytest.raises(ValueError, match="obj must be"):
        book.show_source(42)
    namespace: dict = {}
    exec("def made_at_runtime():\n    return 1", namespace)  # no file behind it, like a notebook cell
    with pytest.raises(ValueError, match="no source"):
        book.show_source(namespace["made_at_runtime"])


def test_embed_animation_is_self_contained():
    fig, ax = plt.subplots(figsize=(1, 1), dpi=20)
    (line,) = ax.plot([0, 1], [0, 0])
    anim = FuncAnimation(fig, lambda i: line.set_ydata([0, i]) or (line,), frames=3)
    html = book.embed_animation(anim).data
    assert "data:image/png;base64" in html and "<img" in html
    assert "http://" not in html and "https://" not in html
    assert not plt.fignum_exists(fig.number), "the figure should be closed to avoid a duplicate still"
    with pytest.raises(ValueError, match="anim"):
        book.embed_animation(fig)


def test_display_path_hides_the_machines_folders(isolated_cache):
    assert book.display_path(isolated_cache / "results" / "smoke") == "<motionlab cache>/results/smoke"
    assert book.display_path(Path.home() / "data" / "HumanML3D") == "~/data/HumanML3D"


def test_what_reproduces_here_judges_the_chapters_recorded_numbers(isolated_cache, monkeypatch):
    monkeypatch.delenv(results.RESULTS_ENV, raising=False)
    empty = book.what_reproduces_here("vq", "smoke")
    assert {row.verdict for row in empty.rows} == {results.MISSING}
    results.record("vq", "mpjpe_vq", 40.0, unit="mm", profile="smoke")
    results.record("vq", "mpjpe_rvq", 30.0, ci=1.0, unit="mm", profile="smoke")
    found = book.what_reproduces_here("vq", "smoke")
    assert found.rows[0].verdict == results.HOLDS
    html = found._repr_html_()
    # claim, verdict and why on the page; our numbers folded under the row
    assert html.index("<th>claim</th>") < html.index("<th>verdict</th>") < html.index("<th>why, as measured</th>")
    assert html.index("<summary>our numbers</summary>") < html.index("30.0 ± 1.0 mm (residual VQ)")
    assert "| claim | verdict | why, as measured |" in str(found)
    with pytest.raises(ValueError, match="results prefix"):
        book.what_reproduces_here("chapter 2")
