"""Run profiles: how big every experiment in the book is.

- ``smoke``: CI; seconds per chapter, numbers only prove the code runs.
- ``laptop``: the default for ``make book``; meaningful results on 2 CPU cores.
- ``full``: the papers' hyperparameters, meant for a GPU and the real datasets.

Chosen by the ``profile`` parameter of a chapter, else ``$MOTIONLAB_PROFILE``, else ``laptop``.
``$MOTIONLAB_THREADS`` (read by :func:`env_threads`) sets torch's CPU threads for the book and the CLI.
"""

from __future__ import annotations

import os

PROFILES = ("smoke", "laptop", "full")
DEFAULT_PROFILE = "laptop"


def get_profile(profile: str | None = None) -> str:
    """Validate ``profile`` (or read ``$MOTIONLAB_PROFILE``) and return one of :data:`PROFILES`."""
    value = profile if profile is not None else os.environ.get("MOTIONLAB_PROFILE", DEFAULT_PROFILE)
    value = str(value).strip().lower()
    if value not in PROFILES:
        raise ValueError(f"unknown profile {value!r}; expected one of {', '.join(PROFILES)}")
    return value


def env_threads() -> int | None:
    """``$MOTIONLAB_THREADS`` as a positive int, or ``None`` when it is not set (callers pick their default)."""
    value = os.environ.get("MOTIONLAB_THREADS")
    if value is None:
        return None
    try:
        threads = int(value)
    except ValueError:
        threads = 0
    if threads < 1:
        raise ValueError(f"MOTIONLAB_THREADS must be a positive int, got {value!r}")
    return threads
