"""Recording measured results: one JSON file per chapter and profile, written atomically.

Every chapter ends by recording what it measured::

    from motionlab import results
    results.record("discord", "sjpe_rf", 0.412, ci=0.013, note="16 Euler steps, 64 clips")

With repeated evaluations, record the mean and the 95% half-width, e.g. from
``motionlab.estimate.mean_ci(values)`` -> an ``Estimate`` (which ``record`` takes as the value).

One JSON file per chapter and profile holds the numbers:
``$MOTIONLAB_RESULTS/<profile>/<chapter>.json`` if that variable is set, else
``<cache root>/results/<profile>/<chapter>.json`` (see :mod:`motionlab.paths`). Writes are atomic
(write a temporary file, then ``os.replace``), so a crashed chapter never leaves half a file.

:data:`CLAIMS` lists what the two papers claim, the paper's own numbers, which recorded keys
(``chapter/key``) are *our* numbers, and the rule that decides whether the claim holds here.
:func:`claims_table` joins the two; "What reproduces" (chapter 99) shows it. A claim whose keys
have not been recorded is shown as "not yet measured", never dropped.

Our numbers come from the embedded procedural dataset and small CPU models, so the rules compare
*directions* measured under one protocol (flow decoder vs feed-forward decoder on the same tokens;
TPS vs concatenation), not the papers' absolute values.

Verdicts: a comparison "holds" when the point estimates satisfy it. When a side carries a confidence
interval and the 95% interval of the difference (half-width ``sqrt(h_a² + h_b²)``) contains 0, the verdict is
"inconclusive": the ordering might be noise. The chapter that records each key prefix:

==============  ====================================
prefix          chapter
==============  ====================================
``vq``          02 Vector quantization
``flow``        03 Rectified flow
``projection``  04 Condition projection
``discord``     05 DisCoRD
``sjpe``        06 sJPE
``diffusion``   07 Discrete diffusion
``transitions`` 08 Dynamic transitions
``tps``         09 Two-Phase Sampling
==============  ===================================="""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from motionlab.comparison import FAILS, HOLDS, INCONCLUSIVE  # one set of verdicts, shared with the sentences
from motionlab.estimate import Estimate, format_estimate
from motionlab.paths import cache_dir
from motionlab.profiles import get_profile

RESULTS_ENV = "MOTIONLAB_RESULTS"

CHAPTERS = {
    "motion_data": "01 Motion as data",
    "vq": "02 Vector quantization",
    "flow": "03 Rectified flow",
    "projection": "04 Condition projection",
    "discord": "05 DisCoRD",
    "sjpe": "06 sJPE",
    "diffusion": "07 Discrete diffusion",
    "transitions": "08 Dynamic transitions",
    "tps": "09 Two-Phase Sampling",
}

_NAME = re.compile(r"^[a-z0-9][a-z0-9_.\-]*$")


MISSING = "not yet measured"
VERDICTS = (HOLDS, FAILS, INCONCLUSIVE, MISSING)


# ----------------------------------------------------------------------------------------------
# Recording


@dataclass(frozen=True)
class Result:
    """One measured number: ``value`` with an optional confidence interval ``ci = (low, high)``."""

    chapter: str
    key: str
    value: float
    ci: tuple[float, float] | None = None
    unit: str | None = None
    note: str | None = None
    profile: str = "laptop"
    recorded_at: str = ""
    precision: str | None = None  # the precision the chapter's models ran in (None: not recorded)

    @property
    def name(self) -> str:
        return f"{self.chapter}/{self.key}"

    def format(self) -> str:
        """``0.412 [0.399, 0.425] s`` — value, interval, unit."""
        text = _fmt(self.value)
        if self.ci is not None:
            text += f" [{_fmt(self.ci[0])}, {_fmt(self.ci[1])}]"
        return f"{text} {self.unit}" if self.unit else text

    @property
    def estimate(self) -> Estimate:
        """The value as an :class:`~motionlab.metrics.Estimate` (the larger side of ``ci`` as its half-width)."""
        half = 0.0 if self.ci is None else max(self.value - self.ci[0], self.ci[1] - self.value, 0.0)
        return Estimate(self.value, half, 1 if self.ci is None else 2, self.unit)

    def describe(self) -> str:
        """``0.412 ± 0.013 mm``: for a reader. The interval is shown only where it has width (a deterministic value,
        or one decoded once, carries none), to two significant digits, with the value rounded to match."""
        return format_estimate(self.value, self.ci, self.unit)


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def results_dir(profile: str | None = None) -> Path:
    """The folder holding one ``<chapter>.json`` per chapter for ``profile`` (created on demand)."""
    profile = get_profile(profile)
    root = os.environ.get(RESULTS_ENV)
    folder = (Path(root).expanduser() if root else cache_dir() / "results") / profile
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _check_name(arg: str, value: object) -> str:
    if not isinstance(value, str) or not _NAME.match(value):
        raise ValueError(f"{arg} must be a lowercase name like 'sjpe_rf' (letters, digits, _ . -), got {value!r}")
    return value


def _check_number(arg: str, value: object) -> float:
    if isinstance(value, (bool, str, bytes)):
        raise ValueError(f"{arg} must be a real number, got {type(value).__name__}")
    try:
        number = float(value)  # accepts numpy/torch scalars and 1-element arrays
    except (TypeError, ValueError) as err:
        raise ValueError(f"{arg} must be a real number, got {type(value).__name__}") from err
    if not math.isfinite(number):
        raise ValueError(f"{arg} must be finite, got {number}")
    return number


def _check_ci(value: float, ci: object) -> tuple[float, float] | None:
    """``ci`` is a half-width (``value ± ci``) or a ``(low, high)`` pair containing ``value``."""
    if ci is None:
        return None
    if isinstance(ci, Sequence) and not isinstance(ci, str):
        if len(ci) != 2:
            raise ValueError(f"ci must be a half-width or a (low, high) pair, got {ci!r}")
        low, high = _check_number("ci[0]", ci[0]), _check_number("ci[1]", ci[1])
    else:
        half = _check_number("ci", ci)
        if half < 0:
            raise ValueError(f"ci half-width must be >= 0, got {half}")
        low, high = value - half, value + half
    if not low <= value <= high:
        raise ValueError(f"ci ({low}, {high}) must contain the value {value}")
    return (low, high)


def record(
    chapter: str,
    key: str,
    value: float | Estimate,
    ci: float | tuple[float, float] | None = None,
    unit: str | None = None,
    note: str | None = None,
    profile: str | None = None,
) -> Result:
    """Store ``chapter/key = value`` for ``profile`` (default: ``$MOTIONLAB_PROFILE``); return it.

    Recording a key again replaces it. ``value`` is a number or an :class:`~motionlab.metrics.Estimate` (its
    half-width, when it has one, and its unit are the defaults of ``ci`` and ``unit``). ``ci`` is a 95% half-width or a
    ``(low, high)`` interval. The run's precision (``fp32`` | ``bf16``, :mod:`motionlab.precision`) is stored beside it.
    """
    from motionlab.precision import network_precision  # imports torch: only when a chapter records

    if isinstance(value, Estimate):
        ci = ci if ci is not None or value.half_width <= 0 else value.half_width
        unit = unit if unit is not None else value.unit
        value = value.mean

    chapter, key = _check_name("chapter", chapter), _check_name("key", key)
    number = _check_number("value", value)
    interval = _check_ci(number, ci)
    for arg, text in (("unit", unit), ("note", note)):
        if text is not None and not isinstance(text, str):
            raise ValueError(f"{arg} must be a string or None, got {type(text).__name__}")
    profile = get_profile(profile)
    recorded_at = datetime.now(timezone.utc).isoformat(timespec="seconds")
    result = Result(chapter, key, number, interval, unit, note, profile, recorded_at, network_precision())

    path = results_dir(profile) / f"{chapter}.json"
    entries = _read(path)
    entries[key] = {
        "value": number,
        "ci": list(interval) if interval else None,
        "unit": unit,
        "note": note,
        "recorded_at": result.recorded_at,
        "precision": result.precision,
    }
    _write_atomic(path, {"chapter": chapter, "profile": profile, "results": entries})
    return result


def record_table(
    chapter: str, table: Any, keys: Mapping[str, tuple[str, str]], note: str | None = None
) -> list[Result]:
    """Record cells of an evaluation ``table`` (:class:`~motionlab.evaluation.EvaluationTable`) for the claims table:
    ``keys`` maps a claim key to its ``(row, metric)``, each recorded with its interval under the table's profile. The
    note defaults to the table's header line (what was evaluated, repeats, seed)."""
    return [
        record(chapter, key, table.estimate(row, metric), note=note or table.header(), profile=table.profile)
        for key, (row, metric) in keys.items()
    ]


def _read(path: Path) -> dict:
    if not path.is_file():
        return {}
    return dict(json.loads(path.read_text()).get("results", {}))


def _write_atomic(path: Path, payload: dict) -> None:
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w") as handle:
            json.dump(payload, handle, indent=1, sort_keys=True)
            handle.write("\n")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_all(profile: str | None = None) -> dict[str, Result]:
    """Every recorded result for ``profile``, keyed ``"chapter/key"``."""
    profile = get_profile(profile)
    out: dict[str, Result] = {}
    for path in sorted(results_dir(profile).glob("*.json")):
        chapter = path.stem
        for key, entry in sorted(_read(path).items()):
            ci = tuple(entry["ci"]) if entry.get("ci") is not None else None
            out[f"{chapter}/{key}"] = Result(
                chapter,
                key,
                float(entry["value"]),
                ci,
                entry.get("unit"),
                entry.get("note"),
                profile,
                entry.get("recorded_at", ""),
                entry.get("precision"),
            )
    return out
