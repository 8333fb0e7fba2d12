"""Where motionlab keeps what it generates: the embedded dataset and trained models.

Everything lives under one cache root: ``$MOTIONLAB_HOME`` if set, else ``~/.cache/motionlab``.
Nothing is ever downloaded; the cache only holds what this machine produced.
"""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """The cache root (created on demand); an empty ``$MOTIONLAB_HOME`` counts as unset, never as the current folder."""
    home = os.environ.get("MOTIONLAB_HOME", "").strip()
    root = Path(home or Path.home() / ".cache" / "motionlab").expanduser()
    root.mkdir(parents=True, exist_ok=True)
    return root


def cache_path(*parts: str) -> Path:
    """A path inside the cache root; parent folders are created, the path itself is not."""
    path = cache_dir().joinpath(*parts)
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def shared_data_dir() -> Path | None:
    """The optional folder of real demo clips (``../shared/data`` beside a checkout), or None.

    ``$MOTIONLAB_SHARED_DATA`` wins; otherwise the current folder and its parents are searched for
    ``shared/data``. These clips are never copied into the project; chapters use them only when present.
    """
    env = os.environ.get("MOTIONLAB_SHARED_DATA")
    if env:
        return Path(env) if Path(env).is_dir() else None
    here = Path.cwd().resolve()
    for folder in (here, *here.parents):
        candidate = folder / "shared" / "data"
        if candidate.is_dir():
            return candidate
    return None
