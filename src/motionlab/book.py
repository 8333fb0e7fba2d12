"""Helpers every chapter of the book uses: one ``setup()`` call, "show me the code", animations.

A chapter notebook starts with two cells::

    # cell tags: ["parameters"]  -- papermill overrides these; nbval/jupyter-book read the env
    import os
    profile = os.environ.get("MOTIONLAB_PROFILE", "laptop")   # smoke | laptop | full
    seed = 0

    from motionlab import book
    settings = book.setup(seed=seed, profile=profile)           # the run's settings: .profile, .sizes
    profile = settings.profile

The library is the single source of truth. To *teach* a function, show its source instead of
retyping it, so the text can never drift from the code that runs::

    book.show_source(motionlab.flow.euler_sample)

Animations are embedded in the page as a JavaScript player (``book.embed_animation(anim)``); they play
in the rendered site opened from disk, with no network. A "Try it" is ``book.try_it(draw, param=[values])``: the
figures are computed when the chapter runs and the sliders choose among them in the browser, so they answer on the
static site too (:mod:`motionlab.try_it`).

A chapter ends with ``book.what_reproduces_here(prefix)``: the claims it tests, their verdicts and why.

Exercises
---------
Exercises are markdown cells in the notebook (never code cells, so that nbval and the book build have
nothing to execute). Use MyST admonitions: the task is visible, the hint and the answer are folded
``{dropdown}`` blocks that the reader opens on purpose. Number exercises per chapter (``Exercise 3.2``).
The markdown source of one exercise::

    ```{admonition} Exercise 3.2 — fewer Euler steps
    :class: tip
    Decode the same tokens with 1, 2, 4 and 16 Euler steps and plot sJPE against the number of steps.
    Where does the curve flatten, and why does a straight flow need so few steps?
    ```

    ```{dropdown} Hint
    `motionlab.flow` samplers take `steps=`; keep the noise generator seed fixed across runs.
    ```

    ```{dropdown} Answer
    For an exactly straight flow, one Euler step is exact; the learned flow is only nearly straight ...
    ```

The answer dropdown may contain a code block (a fenced ```` ```python ```` block inside the dropdown),
which is shown but never executed. Both directives come with Jupyter Book 1 (sphinx-design,
sphinx-togglebutton) and need no network; keep the text plain MyST so a later move to Jupyter Book 2
stays easy.
"""

from __future__ import annotations

import inspect
import random
import re
import textwrap
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from motionlab.profiles import env_threads
from motionlab.try_it import try_it  # noqa: F401 -- a chapter helper: book.try_it

if TYPE_CHECKING:
    from motionlab.settings import RunSettings

# Small, crisp figures: a book page is ~700 px wide and the site must stay light.
RC_PARAMS = {
    "figure.figsize": (6.0, 3.2),
    "figure.dpi": 90,
    "savefig.dpi": 90,
    "font.size": 9,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    # to_jshtml embeds every frame as base64 PNG; past this many MB matplotlib silently drops frames.
    "animation.embed_limit": 40.0,
    "animation.html": "jshtml",
}

# matplotlib's jshtml player links Font Awesome 4 from a CDN for its button icons. The book theme
# already ships Font Awesome (which also understands the v4 class names), so the link is dropped to
# keep pages free of network requests.
_CDN_LINK = re.compile(r"<link[^>]*href=[\"']https?://[^\"']*font-awesome[^\"']*[\"'][^>]*>\s*", re.IGNORECASE)


def setup(
    seed: int = 0, profile: str | None = None, threads: int | None = None, precision: str | None = None
) -> RunSettings:
    """Resolve the chapter's run settings, seed every RNG, set plotting defaults; return the settings.

    The returned :class:`~motionlab.settings.RunSettings` carries the validated ``profile`` and the chapter sizes of
    that profile (``settings.sizes``, :mod:`motionlab.sizes`).

    ``profile`` falls back to ``$MOTIONLAB_PROFILE`` and then ``"laptop"`` (see :mod:`motionlab.profiles`);
    ``precision`` to ``$MOTIONLAB_PRECISION`` and then ``"auto"`` (see :mod:`motionlab.precision`): together they
    become the kernel's :class:`~motionlab.settings.RunSettings`, which every library call in the chapter then
    reads. ``threads`` defaults to ``$MOTIONLAB_THREADS``, else 1: the book's
    small convolutions gain little from a second thread on an idle machine and become many times slower
    when anything else shares the CPU (measured on 2-core machines), so one thread is the predictable choice.
    Library code never relies on these global seeds: it takes explicit generators. The seeds only
    make ad-hoc cells in a chapter (``torch.randn`` in a demo) repeatable.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    if threads is not None and (not isinstance(threads, int) or threads < 1):
        raise ValueError(f"threads must be a positive int or None, got {threads!r}")
    from motionlab.settings import apply_settings, resolve_settings  # imports torch: only when a chapter starts

    settings = resolve_settings(profile, precision, threads if threads is not None else (env_threads() or 1))
    profile = apply_settings(settings).profile  # also sets torch's threads

    random.seed(int(seed))
    np.random.seed(int(seed) % 2**32)  # noqa: NPY002 -- the global RNG that ad-hoc cells use
    import torch  # local: importing motionlab.book should not pay for torch when unused

    torch.manual_seed(int(seed))

    import matplotlib as mpl

    mpl.rcParams.update(RC_PARAMS)
    global _started, _profile
    _started, _profile = time.perf_counter(), f"{profile}, {settings.resolved_precision()}"
    return settings


_started: float | None = None  # when setup() ran: the chapter's start
_profile: str | None = None


def chapter_time() -> float:
    """Print and return the seconds since :func:`setup`: each chapter ends with this line, so a reader sees
    what the chapter cost on their machine (models come from the cache when ``motionlab train book`` ran first)."""
    if _started is None:
        raise RuntimeError("book.setup() was not called in this kernel, so the chapter has no start time")
    seconds = time.perf_counter() - _started
    print(f"this chapter ran in {seconds / 60:.1f} min ({seconds:.0f} s, profile {_profile})")
    return seconds


def repository_path(*parts: str) -> Path:
    """A file or folder of the book's repository (e.g. ``"book", "data", "discord_sweep"``: results measured
    once and committed), found from the working directory upwards, so a chapter finds it wherever it runs."""
    here = Path.cwd().resolve()
    for folder in (here, *here.parents):
        candidate = folder.joinpath(*parts)
        if candidate.exists():
            return candidate
    raise FileNotFoundError(
        f"{Path(*parts)} not found in {here} or any folder above it: run the chapter inside the book's repository"
    )


def show_source(obj: object, docstring: bool = True):
    """Display the library source of a function, class or module, syntax-highlighted.

    Returns an ``IPython.display.Code`` object: as the last expression of a cell it renders in
    Jupyter and in the book. This is the "show me the code" pattern: the chapter explains, the
    library implements, and the page shows exactly the code that ran. ``docstring=False`` leaves a
    function's or class's docstring out, where the page's prose already says what it documents.
    """
    if not (inspect.isfunction(obj) or inspect.isclass(obj) or inspect.ismethod(obj) or inspect.ismodule(obj)):
        raise ValueError(f"obj must be a function, method, class or module, got {type(obj).__name__}")
    from IPython.display import Code

    try:
        source = inspect.getsource(obj)
    except (OSError, TypeError) as err:  # built-ins and objects defined in a notebook have no file
        raise ValueError(f"no source available for {obj!r}: {err}") from err
    source = textwrap.dedent(source)  # methods come indented
    return Code(source if docstring else _without_docstring(source), language="python")


def _without_docstring(source: str) -> str:
    """``source`` of one function or class without its docstring (unchanged when it has none)."""
    import ast

    body = getattr(ast.parse(source).body[0], "body", [])
    first = body[0] if body else None
    if not (
        isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str)
    ):
        return source
    lines = source.splitlines(keepends=True)
    return "".join(lines[: first.lineno - 1] + lines[first.end_lineno :])


def embed_animation(anim, close: bool = True, default_mode: str = "loop"):
    """An ``IPython.display.HTML`` with ``anim`` as a self-contained JavaScript player.

    Frames are embedded as base64 PNGs (mind ``animation.embed_limit``). The player's CDN icon font
    link is removed (the book theme provides the icons), so the page works offline. ``close`` closes
    the animation's figure so that the notebook does not also show a duplicate still image.
    ``default_mode`` is the player's end behaviour: ``"loop"``, ``"once"`` or ``"reflect"``.
    """
    if not hasattr(anim, "to_jshtml"):
        raise ValueError(f"anim must be a matplotlib.animation.Animation, got {type(anim).__name__}")
    from IPython.display import HTML

    html = _CDN_LINK.sub("", anim.to_jshtml(default_mode=default_mode))
    if close:
        import matplotlib.pyplot as plt

        plt.close(anim._fig)
    return HTML(html)


def display_path(path: str | Path) -> str:
    """``path`` as a page may show it: inside the cache root as ``<motionlab cache>/...``, inside the home folder as
    ``~/...``. A rendered book must not carry the absolute paths of the machine that built it."""
    from motionlab.paths import cache_dir

    path = Path(path).expanduser().resolve()
    for root, shown in ((cache_dir().resolve(), "<motionlab cache>"), (Path.home().resolve(), "~")):
        if path == root or root in path.parents:
            return str(Path(shown, path.relative_to(root)))
    return str(path)


def what_reproduces_here(chapter: str, profile: str | None = None):
    """The table that ends a chapter: each claim of the papers the chapter tests, and its own findings, with the
    verdict and why, judged on the numbers the chapter recorded (call it after its last ``results.record``).

    ``chapter`` is the chapter's results prefix (``"discord"``, ``"tps"``, ...); ``profile`` defaults to the run's
    (what :func:`setup` resolved). Our numbers and the training runs each verdict reads are folded under each row;
    *What reproduces* judges every claim of both papers.
    """
    from motionlab.results import CHAPTERS, chapter_findings

    if chapter not in CHAPTERS:
        raise ValueError(f"chapter must be a results prefix, one of {sorted(CHAPTERS)}; got {chapter!r}")
    return chapter_findings(chapter, profile)
