"""Where and how a recorded measurement was made: the stamp every committed experiment record carries."""

from __future__ import annotations

import json
import platform
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any


def commit() -> str | None:
    """The short hash of the repository's HEAD (None outside a git checkout)."""
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        return None
    return out.stdout.strip() or None


def machine_stamp() -> dict[str, Any]:
    """The CPU, architecture, the run's precision, torch's thread count and the commit, for a record's JSON."""
    import torch

    from motionlab.precision import read_cpu_info, resolve_precision

    return {
        "cpu": read_cpu_info().summary,
        "machine": platform.machine(),
        "precision": resolve_precision(),
        "torch_threads": torch.get_num_threads(),
        "commit": commit(),
    }


def record_once(path: Path, name: str, measure: Callable[[], dict[str, Any]], doing: str = "measuring") -> bool:
    """Write the record ``measure()`` returns to ``path`` as indented JSON (by one atomic rename), unless ``path``
    holds it already: an experiment's record is measured once, and a rerun skips it. Says on stderr what ``name`` is
    doing; True where it measured."""
    from motionlab.io.common import write_text_atomic

    if path.exists():
        print(f"{name}: recorded already ({path})", file=sys.stderr)
        return False
    print(f"{name}: {doing}", file=sys.stderr)
    write_text_atomic(path, json.dumps(measure(), indent=1) + "\n")
    print(f"{name}: wrote {path}", file=sys.stderr)
    return True
