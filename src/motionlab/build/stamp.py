"""Where and how a recorded measurement was made: the stamp every committed experiment record carries."""

from __future__ import annotations

import platform
import subprocess
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
