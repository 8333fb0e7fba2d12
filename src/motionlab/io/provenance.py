"""Where a generated motion came from: the text, the profile, the seed, the models and the code that made it.

A motion file outlives the terminal that printed how it was made, so every file ``motionlab generate`` writes
carries that record: an HTML page shows it under the animation (and keeps it in its JSON payload); a ``.bvh`` or
``.npy`` file, whose formats have no place for comments that readers such as Blender's importer accept, gets a
sidecar ``<file>.json`` beside it.
"""

from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Mapping
from pathlib import Path

from .common import write_text_atomic


def code_version() -> str:
    """``commit <short hash>`` of the checkout the running package was imported from, else ``motionlab <version>``.

    The commit is read in the package's own folder (not the current directory, which may be another repository)
    and only when git tracks the package's files there, so an installed copy never reports a foreign commit.
    """
    from .. import __version__

    package = Path(__file__).resolve().parent.parent
    try:
        tracked = subprocess.run(
            ["git", "-C", str(package), "ls-files", "--error-unmatch", "__init__.py"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        if tracked.returncode == 0:
            head = subprocess.run(
                ["git", "-C", str(package), "rev-parse", "--short", "HEAD"],
                capture_output=True,
                text=True,
                timeout=10,
            )
            if head.returncode == 0 and head.stdout.strip():
                return f"commit {head.stdout.strip()}"
    except (OSError, subprocess.SubprocessError):
        pass
    return f"motionlab {__version__}"


def motion_provenance(
    texts: list[str], profile: str, seed: int, models: list[str], **details: object
) -> dict[str, str]:
    """The record a generated motion carries, as ordered ``{field: text}``.

    ``details`` add fields such as the decoder, the lengths or the data (``None`` values are left out).
    """
    record = {
        "text": " / ".join(texts),
        "profile": profile,
        "seed": str(seed),
        "models": ", ".join(models),
    }
    record.update({key: str(value) for key, value in details.items() if value is not None})
    record["code"] = code_version()
    return record


def sidecar_path(path: str | os.PathLike) -> Path:
    """Where the provenance of a ``.bvh``/``.npy`` file goes: the file's name with ``.json`` appended."""
    path = Path(path)
    return path.with_name(path.name + ".json")


def write_sidecar(path: str | os.PathLike, provenance: Mapping[str, object]) -> Path:
    """Write ``provenance`` (strings, and the segments of a multi-action motion) as JSON beside the motion file
    ``path`` (atomically); returns the sidecar's path."""
    return write_text_atomic(sidecar_path(path), json.dumps(dict(provenance), indent=1) + "\n")


__all__ = ["code_version", "motion_provenance", "sidecar_path", "write_sidecar"]
