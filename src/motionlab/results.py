"""Measured results, and the papers' claims they are judged against.

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
==============  ====================================
"""

from __future__ import annotations

import html
import json
import math
import os
import re
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

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

from motionlab.report.phrases import FAILS, HOLDS, INCONCLUSIVE  # noqa: E402  (one set of verdicts)

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
    result = Result(
        chapter, key, number, interval, unit, note, profile, datetime.now(timezone.utc).isoformat(timespec="seconds")
    )

    path = results_dir(profile) / f"{chapter}.json"
    entries = _read(path)
    entries[key] = {
        "value": number,
        "ci": list(interval) if interval else None,
        "unit": unit,
        "note": note,
        "recorded_at": result.recorded_at,
        "precision": network_precision(),
    }
    _write_atomic(path, {"chapter": chapter, "profile": profile, "results": entries})
    return result


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
            )
    return out


# ----------------------------------------------------------------------------------------------
# What each key measures, for sentences a reader can follow (no raw keys on a page)

# ``chapter/key`` -> (quantity, condition). Every key a claim, a mechanism or a chapter finding reads has one (a test
# checks); a key without one (an ad-hoc claim) is shown by its name.
QUANTITIES: dict[str, tuple[str, str]] = {
    # 01 Motion as data
    "motion_data/roundtrip_error": ("largest joints → features → joints error", ""),
    "motion_data/wrist_jerk_slow": ("mean wrist jerk", "a slow clip"),
    "motion_data/wrist_jerk_noisy": ("mean wrist jerk", "the same clip + 5 mm noise"),
    "motion_data/wrist_jerk_fast": ("mean wrist jerk", "a fast clip"),
    # 02 Vector quantization
    "vq/mpjpe_vq": ("MPJPE", "VQ, one codebook"),
    "vq/mpjpe_rvq": ("MPJPE", "residual VQ"),
    "vq/mpjpe_rvq_layers1": ("MPJPE", "first residual layer only"),
    "vq/static_sjpe_ff_vq": ("Static sJPE", "VQ decoder"),
    "vq/static_sjpe_ff_rvq": ("Static sJPE", "residual VQ decoder"),
    "vq/noise_sjpe_ff_vq": ("Noise sJPE", "VQ decoder"),
    "vq/noise_sjpe_ff_rvq": ("Noise sJPE", "residual VQ decoder"),
    "vq/sjpe_ff_vq": ("sJPE", "VQ decoder"),
    "vq/sjpe_ff_rvq": ("sJPE", "residual VQ decoder"),
    # 03 Rectified flow
    "flow/straightness_unconditional": ("path straightness (chord/arc)", "unconditional field"),
    "flow/straightness_conditional": ("path straightness (chord/arc)", "class-conditional field"),
    "flow/energy_unconditional_euler_nfe1": ("energy distance to the data", "unconditional, 1 Euler step"),
    "flow/energy_conditional_euler_nfe1": ("energy distance to the data", "conditional, 1 Euler step"),
    "flow/energy_unconditional_euler_nfe16": ("energy distance to the data", "unconditional, 16 Euler steps"),
    "flow/energy_unconditional_midpoint_nfe30": ("energy distance to the data", "unconditional, 15 midpoint steps"),
    "flow/energy_floor": ("energy distance", "two samples of the data (the noise floor)"),
    # 04 Condition projection
    "projection/heldout_mse_stacked": ("held-out reconstruction MSE", "stacked projection"),
    "projection/heldout_mse_repeat_linear": ("held-out reconstruction MSE", "repeat & linear"),
    "projection/heldout_mse_transposed": ("held-out reconstruction MSE", "transposed convolution"),
    "projection/train_fm_stacked": ("flow-matching loss", "training clips, stacked"),
    "projection/heldout_fm_stacked": ("flow-matching loss", "held-out clips, stacked"),
    # 05 DisCoRD
    "discord/sjpe_rf": ("sJPE", "flow decoder"),
    "discord/sjpe_ff": ("sJPE", "feed-forward decoder"),
    "discord/noise_sjpe_rf": ("Noise sJPE", "flow decoder"),
    "discord/noise_sjpe_ff": ("Noise sJPE", "feed-forward decoder"),
    "discord/static_sjpe_rf": ("Static sJPE", "flow decoder"),
    "discord/static_sjpe_ff": ("Static sJPE", "feed-forward decoder"),
    "discord/fid_rf": ("reconstruction FID", "flow decoder"),
    "discord/fid_ff": ("reconstruction FID", "feed-forward decoder"),
    "discord/mpjpe_rf": ("MPJPE", "flow decoder"),
    "discord/mpjpe_ff": ("MPJPE", "feed-forward decoder"),
    "discord/fid_steps2": ("FID", "2 steps"),
    "discord/fid_steps16": ("FID", "16 steps"),
    "discord/sjpe_steps2": ("sJPE", "2 steps"),
    "discord/sjpe_steps16": ("sJPE", "16 steps"),
    "discord/time_steps2": ("time to decode a batch", "2 steps"),
    "discord/time_steps16": ("time to decode a batch", "16 steps"),
    "discord/time_ff": ("time to decode a batch", "feed-forward decoder"),
    "discord/noise_sjpe_boundary_share_rf": (
        "share of Noise sJPE on jerk centred on a token boundary",
        "flow decoder (¼ if the token grid left no trace)",
    ),
    "discord/noise_sjpe_boundary_share_ff": (
        "share of Noise sJPE on jerk centred on a token boundary",
        "feed-forward decoder",
    ),
    "discord/noise_sjpe_extra_at_boundaries": (
        "Noise sJPE the flow decoder adds over the feed-forward one",
        "on the ¼ of jerk stencils centred on a token boundary",
    ),
    "discord/noise_sjpe_extra_elsewhere": (
        "Noise sJPE the flow decoder adds over the feed-forward one",
        "on the other ¾",
    ),
    "discord/joint_jerk_rf": ("mean joint jerk", "flow decoder"),
    "discord/joint_jerk_ff": ("mean joint jerk", "feed-forward decoder"),
    "discord/joint_jerk_gt": ("mean joint jerk", "ground truth"),
    "discord/train_steps": ("training steps", "flow decoder (the paper: 481,896 at batch 768)"),
    "discord/sjpe_crossing_minutes": (
        "training minutes at which sJPE falls below the feed-forward decoder's",
        "longest sweep run",
    ),
    "discord/longest_run_minutes": ("training minutes", "longest sweep run"),
    "discord/noise_sjpe_steps2": ("Noise sJPE", "2 steps"),
    "discord/noise_sjpe_steps16": ("Noise sJPE", "16 steps"),
    "discord/flops_ratio_steps16": ("arithmetic (FLOPs), 16 steps ÷ feed-forward", ""),
    "discord/time_ratio_steps16": ("CPU time, 16 steps ÷ feed-forward", ""),
    # 06 sJPE
    "sjpe/noise_sjpe_low": ("Noise sJPE", "low noise"),
    "sjpe/noise_sjpe_mid": ("Noise sJPE", "medium noise"),
    "sjpe/noise_sjpe_high": ("Noise sJPE", "high noise"),
    "sjpe/static_sjpe_high": ("Static sJPE", "high noise"),
    # 07 Discrete diffusion
    "diffusion/fid_guided": ("FID", "guided, s = 4"),
    "diffusion/fid_unguided": ("FID", "unguided, s = 0"),
    "diffusion/nll_uncond_xt": ("NLL of the true code at t = T", "unconditional branch"),
    "diffusion/unigram_entropy": ("entropy", "the code frequencies"),
    "diffusion/entropy_xt_s0": ("entropy of p(x0 | x_T)", "s = 0"),
    "diffusion/entropy_xt_s4": ("entropy of p(x0 | x_T)", "s = 4"),
    "diffusion/hist_tv_s0": ("code-histogram TV to real tokens", "s = 0"),
    "diffusion/hist_tv_s4": ("code-histogram TV to real tokens", "s = 4"),
    "diffusion/repeat_rate_real": ("adjacent repeats", "real tokens"),
    "diffusion/repeat_rate_s0": ("adjacent repeats", "s = 0"),
    "diffusion/repeat_rate_s4": ("adjacent repeats", "s = 4"),
    "diffusion/top3_unguided": ("R-Top3", "s = 0"),
    "diffusion/top3_guided": ("R-Top3", "s = 4"),
    # 08 Dynamic transitions
    "transitions/fid_dynamic": ("FID", "dynamic β(t, d)"),
    "transitions/fid_uniform": ("FID", "uniform β_t"),
    "transitions/max_tv_eta0.25": ("largest TV", "η = 0.25"),
    "transitions/max_tv_eta0.5": ("largest TV", "η = 0.5"),
    "transitions/max_tv_eta2": ("largest TV", "η = 2"),
    "transitions/kbeta_bar_t": ("the cap K·β̄_T", ""),
    "transitions/fid_dynamic_minus_uniform": ("FID, dynamic − uniform", ""),
    "transitions/fid_seed_gap_dynamic": ("FID, seed 1 − seed 0", "dynamic"),
    "transitions/fid_seed_gap_uniform": ("FID, seed 1 − seed 0", "uniform"),
    # 09 Two-Phase Sampling
    "tps/jerk_gt_single": ("transition Jerk", "real single motions"),
    "tps/jerk_gt_concat": ("transition Jerk", "real motions concatenated"),
    "tps/jerk_tps": ("transition Jerk", "TPS"),
    "tps/jerk_independent": ("transition Jerk", "independent sampling"),
    "tps/jerk_handshake": ("transition Jerk", "Handshake"),
    "tps/jerk_slerp": ("transition Jerk", "SLERP"),
    "tps/jerk_tps_uniform": ("transition Jerk", "TPS, uniform β_t"),
    "tps/fid_ts100": ("individual-motion FID", "T_s = T"),
    "tps/fid_ts90": ("individual-motion FID", "T_s = 0.9 T"),
    "tps/fid_ts50": ("individual-motion FID", "T_s = 0.5 T"),
    "tps/fid_handshake": ("individual-motion FID", "Handshake"),
    "tps/fid_separate": ("individual-motion FID", "actions decoded alone"),
    "tps/jerk_separate": ("transition Jerk", "actions decoded alone, motions concatenated"),
    "tps/segment_jerk_tps": ("Jerk inside the actions", "TPS"),
    "tps/jerk_tps_minus_independent": ("transition Jerk, TPS − independent", "paired per boundary"),
    "tps/jerk_tps_minus_uniform": ("transition Jerk, TPS dynamic − uniform β", "paired per boundary"),
    "tps/jerk_concat_minus_inside": ("transition Jerk, real cut − inside the clips it joins", "paired per boundary"),
    "tps/tokens_changed_ts90": ("tokens the joint phase changes", "T_s = 0.9 T"),
    "tps/tokens_changed_ts50": ("tokens the joint phase changes", "T_s = 0.5 T"),
}


def quantity(key: str) -> tuple[str, str]:
    """``(quantity, condition)`` of a ``chapter/key``: ``("sJPE", "flow decoder")``."""
    return QUANTITIES.get(key, (key.split("/", 1)[-1], ""))


def _relation(a: Result | None, b: Result | None) -> str:
    if a is None or b is None:
        return "vs"
    return "<" if a.value < b.value else ">" if a.value > b.value else "="


def describe_values(
    keys: Sequence[str], recorded: Mapping[str, Result], compare: bool = True, name: bool = True
) -> str:
    """Our numbers for ``keys`` as a phrase: ``sJPE: 3.62 ± 0.011 (flow decoder) > 2.57 (feed-forward decoder)``.

    Keys of one quantity share its name, each value followed by its condition. With ``compare``, neighbouring values
    are joined by how they compare (``<``, ``>``, ``=``); else by commas. ``name=False`` leaves out a shared quantity
    (the caller has named it). A key not recorded reads "not yet measured". Two different values never read alike:
    where three digits would print them equal, both get more.
    """
    names = [quantity(k)[0] for k in keys]
    shared = len(set(names)) == 1
    values = [recorded[k].describe() if k in recorded else "not yet measured" for k in keys]
    for i in range(1, len(keys)):
        a, b = recorded.get(keys[i - 1]), recorded.get(keys[i])
        if a is not None and b is not None and a.value != b.value and values[i - 1] == values[i]:
            for digits in range(4, 8):
                values[i - 1], values[i] = (format_estimate(r.value, r.ci, r.unit, significant=digits) for r in (a, b))
                if values[i - 1] != values[i]:
                    break
    text = ""
    for i, key in enumerate(keys):
        quantity_name, condition = quantity(key)
        if shared:
            part = f"{values[i]} ({condition})" if condition else values[i]
        else:
            part = f"{quantity_name} ({condition}) {values[i]}" if condition else f"{quantity_name} {values[i]}"
        if i:
            text += f" {_relation(recorded.get(keys[i - 1]), recorded.get(key))} " if compare else ", "
        text += part
    return f"{names[0]}: {text}" if shared and name else text


# ----------------------------------------------------------------------------------------------
# Rules: how one claim is judged from recorded results


def _compare(a: Result, b: Result, expected: str) -> str:
    """Verdict of the expectation that ``a`` is ``"lower"`` (or ``"higher"``) than ``b``, by the one rule
    (:meth:`motionlab.report.Comparison.judge`): "inconclusive" when a side carries an interval and the 95% interval
    of the difference, half-width ``sqrt(h_a² + h_b²)`` for independent estimates, contains 0.

    Not "when their intervals overlap": two 95% intervals can overlap while the difference is clear (for equal
    widths the overlap test works at about the 99.5% level, not 95%). Where both were measured on the same samples,
    a paired difference recorded beside them (a mechanism row) is sharper still.
    """
    from motionlab.report import compare

    return compare(a.estimate, b.estimate).judge(expected)


def _combine(verdicts: Sequence[str]) -> str:
    if FAILS in verdicts:
        return FAILS
    if INCONCLUSIVE in verdicts:
        return INCONCLUSIVE
    return HOLDS


@dataclass(frozen=True)
class Less:
    """``a < b``."""

    a: str
    b: str

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.a, self.b)

    def judge(self, r: Mapping[str, Result]) -> str:
        return _compare(r[self.a], r[self.b], "lower")

    def describe(self) -> str:
        return f"{self.a} < {self.b}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        """Our numbers for the rule's keys, for a reader (``describe`` is the rule itself)."""
        return describe_values(self.keys, r)


@dataclass(frozen=True)
class Greater(Less):
    """``a > b``."""

    def judge(self, r: Mapping[str, Result]) -> str:
        return _compare(r[self.a], r[self.b], "higher")

    def describe(self) -> str:
        return f"{self.a} > {self.b}"


@dataclass(frozen=True)
class Between:
    """``low < x < high``."""

    x: str
    low: str
    high: str

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.x, self.low, self.high)

    def judge(self, r: Mapping[str, Result]) -> str:
        x, lo, hi = r[self.x], r[self.low], r[self.high]
        return _combine([_compare(lo, x, "lower"), _compare(x, hi, "lower")])

    def describe(self) -> str:
        return f"{self.low} < {self.x} < {self.high}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        return describe_values((self.low, self.x, self.high), r)


@dataclass(frozen=True)
class Increasing:
    """``keys[0] < keys[1] < ...`` (each neighbouring pair judged)."""

    ordered: tuple[str, ...]

    @property
    def keys(self) -> tuple[str, ...]:
        return self.ordered

    def judge(self, r: Mapping[str, Result]) -> str:
        pairs = zip(self.ordered[:-1], self.ordered[1:], strict=True)
        return _combine([_compare(r[a], r[b], "lower") for a, b in pairs])

    def describe(self) -> str:
        return " < ".join(self.ordered)

    def sentence(self, r: Mapping[str, Result]) -> str:
        return describe_values(self.ordered, r)


@dataclass(frozen=True)
class Within:
    """``|a - b| <= rel_tol * |b|``: ``a`` is comparable to the reference ``b``."""

    a: str
    b: str
    rel_tol: float

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.a, self.b)

    def judge(self, r: Mapping[str, Result]) -> str:
        a, b = r[self.a].value, r[self.b].value
        return HOLDS if abs(a - b) <= self.rel_tol * abs(b) else FAILS

    def describe(self) -> str:
        return f"{self.a} within ±{self.rel_tol:.0%} of {self.b}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        text = describe_values(self.keys, r, compare=False)
        if self.a in r and self.b in r and r[self.b].value:
            a, b = r[self.a].value, r[self.b].value
            gap = abs(a - b) / abs(b)
            apart = f"{gap:.0%} apart" if gap <= 1 or not a else f"{max(abs(a / b), abs(b / a)):.3g} times apart"
            text += f": {apart} (the claim allows {self.rel_tol:.0%})"
        return text


@dataclass(frozen=True)
class AtMost:
    """``x <= limit``: a measured error stays below a tolerance (the limit is a setting, never a result)."""

    x: str
    limit: float

    @property
    def keys(self) -> tuple[str, ...]:
        return (self.x,)

    def judge(self, r: Mapping[str, Result]) -> str:
        return HOLDS if r[self.x].value <= self.limit else FAILS

    def describe(self) -> str:
        return f"{self.x} <= {self.limit:g}"

    def sentence(self, r: Mapping[str, Result]) -> str:
        unit = r[self.x].unit if self.x in r else None
        return f"{describe_values(self.keys, r)} (at most {format_estimate(self.limit, unit=unit)})"


Rule = Less | Greater | Between | Increasing | Within | AtMost


@dataclass(frozen=True)
class Evidence:
    """A measured quantity that explains a verdict (the *mechanism*, not the verdict): a label and the keys shown.

    It never changes the verdict; the table prints ``label: value (condition), ...`` from the recorded numbers (each
    key's quantity and condition come from :data:`QUANTITIES`).
    """

    label: str
    keys: tuple[str, ...]

    def format(self, recorded: Mapping[str, Result]) -> str:
        return f"{self.label}: {describe_values(self.keys, recorded, compare=False, name=False)}"


@dataclass(frozen=True)
class Claim:
    """A claim of a paper, the paper's numbers, and the rule that judges it on our numbers."""

    paper: str
    source: str
    statement: str
    paper_value: str
    rule: Rule
    mechanism: tuple[Evidence, ...] = ()  # what our measurements say about *why* the claim holds or fails

    @property
    def keys(self) -> tuple[str, ...]:
        return self.rule.keys

    @property
    def mechanism_keys(self) -> tuple[str, ...]:
        return tuple(k for e in self.mechanism for k in e.keys)

    @property
    def chapter(self) -> str:
        prefix = self.keys[0].split("/", 1)[0]
        return CHAPTERS.get(prefix, prefix)


# ----------------------------------------------------------------------------------------------
# The registry. Paper numbers are HumanML3D unless marked; "FF" = the feed-forward VQ decoder.

# Why the laptop flow decoder is rough, as measured: where its extra jerk sits, how far its budget is from a crossing.
_FLOW_BUDGET = (
    Evidence("training steps, and the sweep's longest run", ("discord/train_steps", "discord/longest_run_minutes")),
    Evidence(
        "when sJPE falls below the feed-forward decoder's (measured if inside the run, else extrapolated in log-time)",
        ("discord/sjpe_crossing_minutes",),
    ),
    Evidence(
        "where the extra jerk sits: share on the ¼ of jerk stencils centred on a token boundary",
        (
            "discord/noise_sjpe_boundary_share_rf",
            "discord/noise_sjpe_boundary_share_ff",
            "discord/noise_sjpe_extra_at_boundaries",
            "discord/noise_sjpe_extra_elsewhere",
        ),
    ),
)
_JOINT_JERK = (
    Evidence(
        "mean joint jerk (m/s³): flow decoder, feed-forward decoder, ground truth",
        ("discord/joint_jerk_rf", "discord/joint_jerk_ff", "discord/joint_jerk_gt"),
    ),
)
_STEPS_NOISE = (
    Evidence(
        "Noise sJPE, 2 → 16 steps (the jitter an evaluation of the field leaves in each frame)",
        ("discord/noise_sjpe_steps2", "discord/noise_sjpe_steps16"),
    ),
)
_CPU_TIME = (
    Evidence(
        "CPU time vs arithmetic, 16 steps ÷ feed-forward (close when time follows FLOPs, as on a busy CPU; "
        "on a GPU a small batch is bound by kernel-launch latency instead)",
        ("discord/time_ratio_steps16", "discord/flops_ratio_steps16"),
    ),
)
# The multi-motion generator's seams: smoother than the insides of its actions, before TPS does anything.
_SEAMS = (
    Evidence(
        "Jerk inside the generated actions vs at their seams (tokens decoded together) vs actions decoded alone",
        ("tps/segment_jerk_tps", "tps/jerk_tps", "tps/jerk_separate"),
    ),
)

CLAIMS: tuple[Claim, ...] = (
    # --- DisCoRD (Cho et al.) ------------------------------------------------------------------
    Claim(
        "DisCoRD",
        "Table 1",
        "Decoding the same tokens with the rectified-flow decoder lowers sJPE.",
        "MoMask 0.512 → 0.385; T2M-GPT 0.564 → 0.488; KIT-ML MoMask 0.384 → 0.359",
        Less("discord/sjpe_rf", "discord/sjpe_ff"),
        mechanism=_FLOW_BUDGET,
    ),
    Claim(
        "DisCoRD",
        "Fig. 5, Fig. C",
        "The flow decoder removes frame-wise noise: Noise sJPE falls.",
        "shown per sample (jerk plots), no table",
        Less("discord/noise_sjpe_rf", "discord/noise_sjpe_ff"),
        mechanism=_FLOW_BUDGET,
    ),
    Claim(
        "DisCoRD",
        "Fig. 5, Fig. B",
        "The flow decoder restores dynamism lost to quantization: Static sJPE falls.",
        "shown per sample (jerk plots), no table",
        Less("discord/static_sjpe_rf", "discord/static_sjpe_ff"),
        mechanism=_JOINT_JERK,
    ),
    Claim(
        "DisCoRD",
        "Table 1",
        "Reconstruction FID improves with the flow decoder.",
        "MoMask 0.019 → 0.011; T2M-GPT 0.089 → 0.031; MMM 0.097 → 0.020",
        Less("discord/fid_rf", "discord/fid_ff"),
        mechanism=_FLOW_BUDGET[:2],
    ),
    Claim(
        "DisCoRD",
        "Table 1",
        "Positional accuracy is not what improves: MPJPE gets worse on HumanML3D.",
        "MoMask 29.5 → 33.3 mm; T2M-GPT 60.0 → 71.5 mm (KIT-ML MoMask improves: 37.5 → 33.0)",
        Greater("discord/mpjpe_rf", "discord/mpjpe_ff"),
        mechanism=_FLOW_BUDGET[:1] + _JOINT_JERK,
    ),
    Claim(
        "DisCoRD",
        "Table E",
        "Few steps suffice: FID at 2 steps is close to FID at 16 steps (the paper's steps "
        "are midpoint grid points: 2 = 2 network evaluations, 16 = 30).",
        "FID 0.034 (2 steps) vs 0.032 (16 steps)",
        Within("discord/fid_steps2", "discord/fid_steps16", 0.25),
        mechanism=_STEPS_NOISE,
    ),
    Claim(
        "DisCoRD",
        "Fig. 6",
        "sJPE is more sensitive to the number of steps than FID: fewer steps, higher sJPE.",
        "sJPE rises as steps drop from 16 to 2 while FID barely moves (plot)",
        Greater("discord/sjpe_steps2", "discord/sjpe_steps16"),
        mechanism=_STEPS_NOISE,
    ),
    Claim(
        "DisCoRD",
        "Table E",
        "Decoding time grows with the number of steps (midpoint grid points).",
        "0.016 s (2 steps) → 0.221 s (16) → 1.426 s (100), batch of 32, RTX 4090",
        Less("discord/time_steps2", "discord/time_steps16"),
        mechanism=_CPU_TIME,
    ),
    Claim(
        "DisCoRD",
        "Table E, Fig. 6",
        "At 16 steps the flow decoder is about as fast as the feed-forward decoder.",
        "0.221 s vs MoMask 0.244 s on a GPU",
        Within("discord/time_steps16", "discord/time_ff", 0.5),
        mechanism=_CPU_TIME,
    ),
    Claim(
        "DisCoRD",
        "Table 6",
        "Stacked per-frame projection generalises better than Repeat & Linear to tokens not seen in training.",
        "generation FID 0.032 vs 0.038 (reconstruction FID 0.011 vs 0.011)",
        Less("projection/heldout_mse_stacked", "projection/heldout_mse_repeat_linear"),
        mechanism=(
            Evidence(
                "no generalisation gap to close at this budget: flow-matching loss on held-out vs training clips",
                ("projection/heldout_fm_stacked", "projection/train_fm_stacked"),
            ),
            Evidence("the third projection", ("projection/heldout_mse_transposed",)),
        ),
    ),
    Claim(
        "DisCoRD",
        "Fig. 4",
        "Frame-wise Gaussian noise shows up as Noise sJPE, not Static sJPE.",
        "Noise sJPE rises steeply with σ; Static sJPE stays low (plot)",
        Greater("sjpe/noise_sjpe_high", "sjpe/static_sjpe_high"),
    ),
    Claim(
        "DisCoRD",
        "Fig. 4",
        "Noise sJPE grows with the noise level.",
        "monotone curve over σ (plot)",
        Increasing(("sjpe/noise_sjpe_low", "sjpe/noise_sjpe_mid", "sjpe/noise_sjpe_high")),
    ),
    # --- M2D2M (Chi et al.) --------------------------------------------------------------------
    Claim(
        "M2D2M",
        "Table 1, Fig. 5",
        "Concatenating real motions makes a jerky transition.",
        "Jerk: GT concat 1.371 vs GT single 1.192",
        Greater("tps/jerk_gt_concat", "tps/jerk_gt_single"),
        mechanism=(
            Evidence(
                "paired per boundary: the cut against windows inside the two clips it joins",
                ("tps/jerk_concat_minus_inside",),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 1",
        "TPS transitions are smoother than concatenated real motions but not over-smoothed.",
        "Jerk: GT single 1.192 < M2D2M 1.238 < GT concat 1.371",
        Between("tps/jerk_tps", "tps/jerk_gt_single", "tps/jerk_gt_concat"),
        mechanism=_SEAMS,
    ),
    Claim(
        "M2D2M",
        "Supp. Table 5",
        "Joint denoising steps smooth the transition compared with independent sampling.",
        "Jerk: w/o TPS 1.402 → T_s = 90: 1.238",
        Less("tps/jerk_tps", "tps/jerk_independent"),
        mechanism=(
            Evidence("paired per boundary", ("tps/jerk_tps_minus_independent",)),
            Evidence("how much the joint phase changes", ("tps/tokens_changed_ts90",)),
            *_SEAMS,
        ),
    ),
    Claim(
        "M2D2M",
        "Supp. Table 5",
        "Fidelity trade-off: individual-motion FID rises as T_s shrinks (keys: T_s = 100%, 90%, 50% of T).",
        "FID 0.196 (T_s=100) < 0.254 (90) < 0.371 (50), T = 100",
        Increasing(("tps/fid_ts100", "tps/fid_ts90", "tps/fid_ts50")),
        mechanism=(
            Evidence("how much the joint phase changes", ("tps/tokens_changed_ts90", "tps/tokens_changed_ts50")),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 6",
        "Handshake over-smooths: its transition Jerk falls below real single motions.",
        "Jerk: Handshake 1.097 vs GT single 1.192",
        Less("tps/jerk_handshake", "tps/jerk_gt_single"),
        mechanism=_SEAMS,
    ),
    Claim(
        "M2D2M",
        "Table 6",
        "SLERP over-smooths even more: transition Jerk below real single motions.",
        "Jerk: SLERP −3.554 vs GT single 1.192",
        Less("tps/jerk_slerp", "tps/jerk_gt_single"),
        mechanism=_SEAMS,
    ),
    Claim(
        "M2D2M",
        "Table 6",
        "TPS keeps individual motions more faithful than Handshake.",
        "individual FID: TPS 0.254 vs Handshake 1.279 (SLERP 1.402)",
        Less("tps/fid_ts90", "tps/fid_handshake"),
        mechanism=(
            Evidence(
                "what the evaluator sees: actions decoded alone (as Handshake's are) vs cut from one "
                "decoded sequence (TPS, independent)",
                ("tps/fid_separate", "tps/fid_ts100"),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 5",
        "With TPS, dynamic β(t,d) gives smoother transitions than uniform β_t.",
        "Jerk 1.238 vs 1.265 (T_s = 90)",
        Less("tps/jerk_tps", "tps/jerk_tps_uniform"),
        mechanism=(
            Evidence("paired per boundary", ("tps/jerk_tps_minus_uniform",)),
            Evidence(
                "largest TV between rows of the dynamic and uniform forward processes (η = 0.25, the "
                "multi-motion model's)",
                ("transitions/max_tv_eta0.25",),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Table 3",
        "Dynamic transition probabilities improve single-motion FID over uniform ones.",
        "FID 0.087 (β(t,d)) vs 0.115 (β_t); KIT-ML 0.378 vs 0.404",
        Less("transitions/fid_dynamic", "transitions/fid_uniform"),
        mechanism=(
            Evidence(
                "largest TV between rows of the dynamic and the uniform forward process Q̄_t (η = 0.25, 0.5, 2; "
                "at most K·β̄_T)",
                (
                    "transitions/max_tv_eta0.25",
                    "transitions/max_tv_eta0.5",
                    "transitions/max_tv_eta2",
                    "transitions/kbeta_bar_t",
                ),
            ),
            Evidence("FID dynamic − uniform, interval over training seeds", ("transitions/fid_dynamic_minus_uniform",)),
            Evidence(
                "FID gap between two training seeds of the same model (paired over repeats)",
                ("transitions/fid_seed_gap_dynamic", "transitions/fid_seed_gap_uniform"),
            ),
        ),
    ),
    Claim(
        "M2D2M",
        "Supp. Table 2",
        "Classifier-free guidance improves single-motion fidelity.",
        "FID 0.107 (s = 0) → 0.087 (s = 4)",
        Less("diffusion/fid_guided", "diffusion/fid_unguided"),
        mechanism=(
            Evidence(
                "NLL of the true code at t = T: unconditional branch vs the code frequencies' entropy",
                ("diffusion/nll_uncond_xt", "diffusion/unigram_entropy"),
            ),
            Evidence(
                "entropy of p(x0 | x_T) (nats), s = 0 → 4", ("diffusion/entropy_xt_s0", "diffusion/entropy_xt_s4")
            ),
            Evidence(
                "code-histogram TV to the real tokens, s = 0 → 4", ("diffusion/hist_tv_s0", "diffusion/hist_tv_s4")
            ),
            Evidence(
                "adjacent repeats: real, s = 0, s = 4",
                ("diffusion/repeat_rate_real", "diffusion/repeat_rate_s0", "diffusion/repeat_rate_s4"),
            ),
            Evidence("R-Top3, s = 0 → 4", ("diffusion/top3_unguided", "diffusion/top3_guided")),
        ),
    ),
)


# The papers' own numbers for our keys (HumanML3D; DisCoRD rows use MoMask's tokenizer). Judging
# them with the rules above must reproduce each paper's conclusion: a check that every rule points
# the way its claim does. Keys whose quantity the paper only plots are absent.
PAPER_NUMBERS: dict[str, tuple[float, str]] = {
    "discord/sjpe_ff": (0.512, "DisCoRD Table 1"),
    "discord/sjpe_rf": (0.385, "DisCoRD Table 1"),
    "discord/fid_ff": (0.019, "DisCoRD Table 1"),
    "discord/fid_rf": (0.011, "DisCoRD Table 1"),
    "discord/mpjpe_ff": (29.5, "DisCoRD Table 1"),
    "discord/mpjpe_rf": (33.3, "DisCoRD Table 1"),
    "discord/fid_steps2": (0.034, "DisCoRD Table E"),
    "discord/fid_steps16": (0.032, "DisCoRD Table E"),
    "discord/time_steps2": (0.016, "DisCoRD Table E"),
    "discord/time_steps16": (0.221, "DisCoRD Table E"),
    "discord/time_ff": (0.244, "DisCoRD Table E"),
    "tps/jerk_gt_single": (1.192, "M2D2M Table 1"),
    "tps/jerk_gt_concat": (1.371, "M2D2M Table 1"),
    "tps/jerk_tps": (1.238, "M2D2M Table 1"),
    "tps/jerk_independent": (1.402, "M2D2M Supp. Table 5"),
    "tps/fid_ts100": (0.196, "M2D2M Supp. Table 5"),
    "tps/fid_ts90": (0.254, "M2D2M Supp. Table 5"),
    "tps/fid_ts50": (0.371, "M2D2M Supp. Table 5"),
    "tps/jerk_handshake": (1.097, "M2D2M Table 6"),
    "tps/jerk_slerp": (-3.554, "M2D2M Table 6"),
    "tps/fid_handshake": (1.279, "M2D2M Table 6"),
    "tps/jerk_tps_uniform": (1.265, "M2D2M Table 5"),
    "transitions/fid_dynamic": (0.087, "M2D2M Table 3"),
    "transitions/fid_uniform": (0.115, "M2D2M Table 3"),
    "diffusion/fid_guided": (0.087, "M2D2M Supp. Table 2"),
    "diffusion/fid_unguided": (0.107, "M2D2M Supp. Table 2"),
}


def paper_results() -> dict[str, Result]:
    """:data:`PAPER_NUMBERS` as results (no intervals), to judge the claims on the papers' own numbers."""
    out = {}
    for name, (value, source) in PAPER_NUMBERS.items():
        chapter, key = name.split("/", 1)
        out[name] = Result(chapter, key, value, None, None, source, "full", "")
    return out


def claim_keys(claims: Sequence[Claim] = CLAIMS) -> tuple[str, ...]:
    """Every ``chapter/key`` the claims read, in first-use order: the keys chapters must record."""
    return tuple(dict.fromkeys(k for c in claims for k in c.keys))


# ----------------------------------------------------------------------------------------------
# The table


@dataclass(frozen=True)
class ClaimRow:
    paper: str
    source: str
    statement: str
    paper_value: str
    rule: str
    chapter: str
    ours: str  # our numbers as a phrase, with units and intervals (see describe_values)
    verdict: str
    missing: tuple[str, ...] = ()
    mechanism: str = ""  # one line per Evidence, from the recorded numbers ("" when the claim has none)


VERDICT_COLOURS = {HOLDS: "#1a7f37", FAILS: "#cf222e", INCONCLUSIVE: "#9a6700", MISSING: "#57606a"}


def _verdict_html(verdict: str) -> str:
    style = f"color:{VERDICT_COLOURS[verdict]};font-weight:bold"
    return f'<span class="ml-verdict" style="{style}">{html.escape(verdict)}</span>'


def count_sentence(counts: Mapping[str, int], noun: str = "claims") -> str:
    """``5 of 11 claims hold, 4 do not hold, 2 inconclusive``: the verdicts of a group, in words."""
    total = sum(counts.values())
    parts = [f"{counts.get(HOLDS, 0)} of {total} {noun} hold"]
    parts += [
        f"{counts[v]} {'do not hold' if v == FAILS else v}" for v in (FAILS, INCONCLUSIVE, MISSING) if counts.get(v)
    ]
    return ", ".join(parts)


@dataclass
class ClaimsTable:
    """Rows of :func:`claims_table`; renders as HTML in Jupyter and in the book: a summary line per paper, then
    one row per claim (verdict, claim, the paper's number, ours as a phrase) and, under a claim whose mechanism was
    measured, a full-width line with it."""

    rows: list[ClaimRow] = field(default_factory=list)
    profile: str = "laptop"

    def __iter__(self) -> Iterator[ClaimRow]:
        return iter(self.rows)

    def __len__(self) -> int:
        return len(self.rows)

    def counts(self) -> dict[str, int]:
        return {v: sum(row.verdict == v for row in self.rows) for v in VERDICTS}

    def by_paper(self) -> dict[str, dict[str, int]]:
        """``{paper: {verdict: count}}``, papers in the order of the rows."""
        out: dict[str, dict[str, int]] = {}
        for row in self.rows:
            out.setdefault(row.paper, dict.fromkeys(VERDICTS, 0))[row.verdict] += 1
        return out

    def summary(self) -> list[str]:
        """One line per paper: ``DisCoRD: 5 of 11 claims hold, 4 do not hold, 2 inconclusive``."""
        return [f"{paper}: {count_sentence(counts)}" for paper, counts in self.by_paper().items()]

    def summary_html(self) -> str:
        """The summary lines as a box: "What reproduces" opens with it."""
        lines = "".join(
            f'<p class="ml-claims-summary" style="margin:0.2em 0"><b>{html.escape(paper)}</b>: '
            f"{html.escape(count_sentence(counts))}.</p>"
            for paper, counts in self.by_paper().items()
        )
        return (
            f'<div class="admonition note ml-findings" style="border-left:4px solid #276be9;padding:0.3em 0.9em">'
            f'<p class="admonition-title" style="font-weight:bold">What reproduces (profile '
            f"<code>{html.escape(self.profile)}</code>)</p>{lines}</div>"
        )

    def _repr_html_(self) -> str:
        return self.html()

    def html(self, summary: bool = True) -> str:
        """The table as HTML; ``summary=False`` leaves out the summary lines (shown elsewhere on the page)."""
        esc = html.escape
        out = ['<div class="ml-claims">']
        for paper, counts in self.by_paper().items() if summary else ():
            out.append(
                f'<p class="ml-claims-summary" style="margin:0.2em 0"><b>{esc(paper)}</b>: '
                f"{esc(count_sentence(counts))}.</p>"
            )
        out += [
            '<table class="ml-claims-table" style="width:100%;font-size:0.9em">',
            f"<caption>Claims vs. our measurements (profile <code>{esc(self.profile)}</code>)</caption>",
            '<colgroup><col style="width:7.5em"><col style="width:36%"><col style="width:24%"><col></colgroup>',
            "<thead><tr><th>Verdict</th><th>Claim</th><th>Paper</th><th>Ours</th></tr></thead><tbody>",
        ]
        for row in self.rows:
            claim = (
                f"{esc(row.statement)}<br><small>{esc(row.paper)}, {esc(row.source)} &middot; "
                f"chapter {esc(row.chapter)}</small>"
            )
            out.append(
                f"<tr><td>{_verdict_html(row.verdict)}</td><td>{claim}</td><td>{esc(row.paper_value)}</td>"
                f"<td>{esc(row.ours)}</td></tr>"
            )
            if row.mechanism:
                lines = "<br>".join(esc(line) for line in row.mechanism.split("\n") if line)
                out.append(
                    f'<tr class="ml-mechanism"><td></td><td colspan="3"><small><b>Why, as measured:</b> '
                    f"{lines}</small></td></tr>"
                )
        out.append("</tbody></table></div>")
        return "\n".join(out)

    def to_markdown(self) -> str:
        out = [f"- {line}" for line in self.summary()] + [""]
        out += ["| Paper | Where | Claim | Paper | Ours | Verdict | Measured mechanism |", "|---" * 7 + "|"]
        for r in self.rows:
            cells = (r.paper, r.source, r.statement, r.paper_value, r.ours, r.verdict, r.mechanism.replace("\n", "; "))
            out.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
        return "\n".join(out)


def judge(claim: Claim, recorded: Mapping[str, Result]) -> ClaimRow:
    """One row: the claim, our numbers for its keys (a phrase with units and intervals), and the verdict."""
    missing = tuple(k for k in claim.keys if k not in recorded)
    verdict = MISSING if missing else claim.rule.judge(recorded)
    mechanism = "\n".join(e.format(recorded) for e in claim.mechanism)
    return ClaimRow(
        claim.paper,
        claim.source,
        claim.statement,
        claim.paper_value,
        claim.rule.describe(),
        claim.chapter,
        claim.rule.sentence(recorded),
        verdict,
        missing,
        mechanism,
    )


def claims_table(
    profile: str | None = None, recorded: Mapping[str, Result] | None = None, claims: Sequence[Claim] = CLAIMS
) -> ClaimsTable:
    """Judge every claim on the results recorded for ``profile`` (or on ``recorded`` if given)."""
    profile = get_profile(profile)
    recorded = load_all(profile) if recorded is None else recorded
    return ClaimsTable([judge(c, recorded) for c in claims], profile)


# ----------------------------------------------------------------------------------------------
# What a chapter found: the box near each chapter's top


@dataclass(frozen=True)
class Finding:
    """A chapter's own result (not a paper's claim), judged like a claim on the chapter's recorded numbers."""

    statement: str
    rule: Rule

    @property
    def keys(self) -> tuple[str, ...]:
        return self.rule.keys


# Per chapter prefix: what the chapter shows besides the papers' claims (chapters 01-03 test no claim of a paper).
FINDINGS: dict[str, tuple[Finding, ...]] = {
    "motion_data": (
        Finding(
            "HumanML3D's features give the joints back exactly (up to canonicalisation).",
            AtMost("motion_data/roundtrip_error", 1e-5),
        ),
        Finding(
            "Frame-wise noise too small to see in a trajectory multiplies the jerk.",
            Less("motion_data/wrist_jerk_slow", "motion_data/wrist_jerk_noisy"),
        ),
    ),
    "vq": (
        Finding(
            "Residual quantization reconstructs positions more closely than one codebook.",
            Less("vq/mpjpe_rvq", "vq/mpjpe_vq"),
        ),
        Finding(
            "It also keeps more of the fast motion: less jerk lost (Static sJPE).",
            Less("vq/static_sjpe_ff_rvq", "vq/static_sjpe_ff_vq"),
        ),
        Finding(
            "Residual layers refine: decoding from all of them reconstructs closer than from the first alone.",
            Less("vq/mpjpe_rvq", "vq/mpjpe_rvq_layers1"),
        ),
    ),
    "flow": (
        Finding(
            "A condition (the class) straightens the learned paths.",
            Greater("flow/straightness_conditional", "flow/straightness_unconditional"),
        ),
        Finding(
            "With a condition, one network evaluation already lands near the data.",
            Less("flow/energy_conditional_euler_nfe1", "flow/energy_unconditional_euler_nfe1"),
        ),
        Finding(
            "Without one, more evaluations are needed: 16 Euler steps beat 1.",
            Less("flow/energy_unconditional_euler_nfe16", "flow/energy_unconditional_euler_nfe1"),
        ),
    ),
}


@dataclass(frozen=True)
class FindingRow:
    verdict: str
    statement: str
    ours: str
    source: str  # "DisCoRD, Table 1" for a paper's claim, "" for the chapter's own finding


@dataclass
class ChapterFindings:
    """What one chapter found, judged on its recorded numbers; renders as a box (HTML) in Jupyter and the book."""

    chapter: str
    profile: str
    rows: list[FindingRow] = field(default_factory=list)

    def counts(self) -> dict[str, int]:
        return {v: sum(row.verdict == v for row in self.rows) for v in VERDICTS}

    def _repr_html_(self) -> str:
        """A compact box: one line per finding (verdict, statement, source, our numbers), then where it comes from."""
        esc = html.escape
        items = []
        for row in self.rows:
            source = f' <span class="ml-source">({esc(row.source)})</span>' if row.source else ""
            items.append(
                f'<li style="margin:0.15em 0">{_verdict_html(row.verdict)}: {esc(row.statement)}{source} '
                f'<span class="ml-ours" style="opacity:0.8">Ours: {esc(row.ours)}.</span></li>'
            )
        claims = sum(bool(row.source) for row in self.rows)
        summary = count_sentence(self.counts(), "claims of the papers" if claims == len(self.rows) else "statements")
        body = "\n".join(items) if items else "<li>This chapter recorded nothing yet.</li>"
        return (
            f'<div class="admonition note ml-findings" style="border-left:4px solid #276be9;padding:0.2em 0.8em;'
            f'font-size:0.9em;line-height:1.4">'
            f'<p class="admonition-title" style="font-weight:bold">What this chapter found: {esc(summary)}</p>'
            f'<ul style="margin:0.2em 0;padding-left:1.2em">{body}</ul>'
            f'<p style="margin:0.2em 0 0.1em 0;opacity:0.8">Generated from the numbers this chapter recorded '
            f"(profile <code>{esc(self.profile)}</code>); <i>What reproduces</i> judges every claim of both papers."
            "</p></div>"
        )

    def _repr_markdown_(self) -> str:
        lines = [f"**What this chapter found** (profile `{self.profile}`):", ""]
        lines += [
            f"- **{r.verdict}**: {r.statement}" + (f" ({r.source})" if r.source else "") + f" Ours: {r.ours}."
            for r in self.rows
        ]
        return "\n".join(lines)


def chapter_findings(
    chapter: str, profile: str | None = None, recorded: Mapping[str, Result] | None = None
) -> ChapterFindings:
    """The papers' claims judged on keys of ``chapter`` (a prefix such as ``"discord"``), then its own findings."""
    if chapter not in CHAPTERS:
        raise ValueError(f"unknown chapter prefix {chapter!r}; one of {sorted(CHAPTERS)}")
    profile = get_profile(profile)
    recorded = load_all(profile) if recorded is None else recorded
    rows = []
    for claim in CLAIMS:
        if claim.keys[0].split("/", 1)[0] == chapter:
            row = judge(claim, recorded)
            rows.append(FindingRow(row.verdict, claim.statement, row.ours, f"{claim.paper}, {claim.source}"))
    for finding in FINDINGS.get(chapter, ()):
        verdict = MISSING if any(k not in recorded for k in finding.keys) else finding.rule.judge(recorded)
        rows.append(FindingRow(verdict, finding.statement, finding.rule.sentence(recorded), ""))
    return ChapterFindings(chapter, profile, rows)
