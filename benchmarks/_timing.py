"""The timing rules every benchmark here follows, in one place.

- One torch thread unless ``--threads`` says otherwise: the numbers then measure work, not the scheduler.
- Variants that are compared run interleaved in one process (A, B, A, B, ...), after one untimed warm-up
  call each, so a slow spell of a shared machine hits all of them alike.
- A fixed number of rounds (``--repeats``), no early stop; every round times each variant once.
- Each variant reports the median and the spread (min–max) of wall time and of process CPU time
  (``time.process_time``: the steadier number on a busy machine); a comparison reports the ratio of the
  two variants *within each round* (median and min–max), which cancels most of the machine's drift.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch


def add_timing_arguments(parser: argparse.ArgumentParser, repeats: int = 5) -> None:
    """``--repeats`` (rounds) and ``--threads`` (torch CPU threads, default 1)."""
    parser.add_argument("--repeats", type=int, default=repeats, help=f"timed rounds (default {repeats})")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")


def apply_threads(threads: int) -> int:
    """Set torch's CPU threads (and refuse nonsense); returns the number in use."""
    if threads < 1:
        raise ValueError(f"--threads must be >= 1, got {threads}")
    torch.set_num_threads(threads)
    return torch.get_num_threads()


@dataclass
class Timing:
    """Seconds of every round of one variant: ``wall`` and ``cpu``, ``(rounds,)`` each."""

    wall: np.ndarray
    cpu: np.ndarray

    def summary(self) -> dict[str, float]:
        return {
            f"{kind}_{stat}": float(fn(getattr(self, kind)))
            for kind in ("wall", "cpu")
            for stat, fn in (("median", np.median), ("min", np.min), ("max", np.max))
        }


def interleaved(variants: Mapping[str, Callable[[], object]], repeats: int, warmup: int = 1) -> dict[str, Timing]:
    """Time each variant ``repeats`` times, round by round (A, B, A, B, ...), after ``warmup`` untimed rounds."""
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    for _ in range(warmup):
        for fn in variants.values():
            fn()
    walls: dict[str, list[float]] = {name: [] for name in variants}
    cpus: dict[str, list[float]] = {name: [] for name in variants}
    for _ in range(repeats):
        for name, fn in variants.items():
            wall, cpu = time.perf_counter(), time.process_time()
            fn()
            cpus[name].append(time.process_time() - cpu)
            walls[name].append(time.perf_counter() - wall)
    return {name: Timing(np.array(walls[name]), np.array(cpus[name])) for name in variants}


def ratio(slow: Timing, fast: Timing) -> dict[str, float]:
    """``slow / fast`` per round, wall and CPU: median, min and max."""
    out = {}
    for kind in ("wall", "cpu"):
        r = getattr(slow, kind) / np.maximum(getattr(fast, kind), 1e-12)
        out |= {f"{kind}_median": float(np.median(r)), f"{kind}_min": float(r.min()), f"{kind}_max": float(r.max())}
    return out


def write_records(path: Path | None, records: list[dict]) -> None:
    """Write ``records`` as a JSON list to ``path`` (its folder created), or nothing when ``path`` is None."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(records, indent=1) + "\n")
    print(f"wrote {path}")


def spread(values: np.ndarray, scale: float = 1.0, digits: int = 3) -> str:
    """``"median (min–max)"`` of ``values * scale``."""
    v = np.asarray(values) * scale
    return f"{np.median(v):.{digits}f} ({v.min():.{digits}f}–{v.max():.{digits}f})"


def ratio_text(r: Mapping[str, float], kind: str = "cpu") -> str:
    """``"6.1× (5.8–6.4)"`` from :func:`ratio`'s result."""
    return f"{r[f'{kind}_median']:.2f}× ({r[f'{kind}_min']:.2f}–{r[f'{kind}_max']:.2f})"
