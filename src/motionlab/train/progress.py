"""Where training progress goes besides the progress bar: hooks that see every step of every run.

The training loop calls :func:`report` after each step. Nothing listens by default; ``motionlab train
book`` installs a hook in each worker process that forwards (run, step, total) to the parent, which prints
one progress line per model. Hooks must be cheap: they run once per optimisation step.
"""

from __future__ import annotations

from collections.abc import Callable

ProgressHook = Callable[[str, int, int], None]  # (run description, steps done, total steps)

_hooks: list[ProgressHook] = []
_bars = True


def bars_enabled() -> bool:
    """Whether long loops may draw tqdm bars (off in ``train book``'s workers, which report through hooks)."""
    return _bars


def disable_bars() -> None:
    """No progress bars in this process from now on (its parent prints progress lines instead)."""
    global _bars
    _bars = False


def report(desc: str, step: int, total: int) -> None:
    """Tell every installed hook that run ``desc`` has finished ``step`` of ``total`` steps."""
    for hook in _hooks:
        hook(desc, step, total)


def add_progress_hook(hook: ProgressHook) -> None:
    """Install ``hook`` for the rest of the process (worker processes that only train)."""
    _hooks.append(hook)
