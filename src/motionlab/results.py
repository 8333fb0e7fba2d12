"""Measured results, and the papers' claims they are judged against.

Every chapter ends by recording what it measured::

    from motionlab import results
    results.record("discord", "sjpe_rf", 0.412, ci=0.013, note="16 Euler steps, 64 clips")

With repeated evaluations, record the mean and the 95% half-width, e.g. from
``motionlab.metrics.protocol.mean_ci(values)`` -> ``(mean, half_width)``.

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

Verdicts: a comparison "holds" when the point estimates satisfy it. When both sides carry a
confidence interval and the intervals overlap, the verdict is "inconclusive": the ordering might be
noise. The chapter that records each key prefix:

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

HOLDS = "holds"
FAILS = "does not hold"
INCONCLUSIVE = "inconclusive"
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
    value: float,
    ci: float | tuple[float, float] | None = None,
    unit: str | None = None,
    note: str | None = None,
    profile: str | None = None,
) -> Result:
    """Store ``chapter/key = value`` for ``profile`` (default: ``$MOTIONLAB_PROFILE``); return it.

    Recording a key again replaces it. ``ci`` is a 95% half-width or a ``(low, high)`` interval.
    """
    chapter, key = _check_name("chapter", chapter), _check_name("key", key)
    number = _check_number("value", value)
    interval = _check_ci(number, ci)
    for arg, text in (("unit", unit), ("note", note)):
        if text is not None and not isinstance(text, str):
            raise ValueError(f"{arg} must be a string or None, got {type(text).__name__}")
    profile = get_profile(profile)
    result = Result(chapter, key, number, interval, unit, note, profile,
                    datetime.now(timezone.utc).isoformat(timespec="seconds"))

    path = results_dir(profile) / f"{chapter}.json"
    entries = _read(path)
    entries[key] = {"value": number, "ci": list(interval) if interval else None, "unit": unit,
                    "note": note, "recorded_at": result.recorded_at}
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
            out[f"{chapter}/{key}"] = Result(chapter, key, float(entry["value"]), ci, entry.get("unit"),
                                             entry.get("note"), profile, entry.get("recorded_at", ""))
    return out


# ----------------------------------------------------------------------------------------------
# Rules: how one claim is judged from recorded results


def _compare(a: Result, b: Result, holds: bool) -> str:
    """Verdict of an ordering between two results, "inconclusive" when their intervals overlap."""
    lo_a, hi_a = a.ci or (a.value, a.value)
    lo_b, hi_b = b.ci or (b.value, b.value)
    if (a.ci or b.ci) and lo_a <= hi_b and lo_b <= hi_a:
        return INCONCLUSIVE
    return HOLDS if holds else FAILS


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
        return _compare(r[self.a], r[self.b], r[self.a].value < r[self.b].value)

    def describe(self) -> str:
        return f"{self.a} < {self.b}"


@dataclass(frozen=True)
class Greater(Less):
    """``a > b``."""

    def judge(self, r: Mapping[str, Result]) -> str:
        return _compare(r[self.a], r[self.b], r[self.a].value > r[self.b].value)

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
        return _combine([_compare(lo, x, lo.value < x.value), _compare(x, hi, x.value < hi.value)])

    def describe(self) -> str:
        return f"{self.low} < {self.x} < {self.high}"


@dataclass(frozen=True)
class Increasing:
    """``keys[0] < keys[1] < ...`` (each neighbouring pair judged)."""

    ordered: tuple[str, ...]

    @property
    def keys(self) -> tuple[str, ...]:
        return self.ordered

    def judge(self, r: Mapping[str, Result]) -> str:
        pairs = zip(self.ordered[:-1], self.ordered[1:], strict=True)
        return _combine([_compare(r[a], r[b], r[a].value < r[b].value) for a, b in pairs])

    def describe(self) -> str:
        return " < ".join(self.ordered)


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


Rule = Less | Greater | Between | Increasing | Within


@dataclass(frozen=True)
class Evidence:
    """A measured quantity that explains a verdict (the *mechanism*, not the verdict): a label and the keys shown.

    It never changes the verdict; the table prints ``label: key = value, ...`` from the recorded numbers.
    """

    label: str
    keys: tuple[str, ...]

    def format(self, recorded: Mapping[str, Result]) -> str:
        parts = [f"{k.split('/', 1)[-1]} = {recorded[k].format()}" if k in recorded else f"{k.split('/', 1)[-1]}: —"
                 for k in self.keys]  # fmt: skip
        return f"{self.label}: " + ", ".join(parts)


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

CLAIMS: tuple[Claim, ...] = (
    # --- DisCoRD (Cho et al.) ------------------------------------------------------------------
    Claim("DisCoRD", "Table 1", "Decoding the same tokens with the rectified-flow decoder lowers sJPE.",
          "MoMask 0.512 → 0.385; T2M-GPT 0.564 → 0.488; KIT-ML MoMask 0.384 → 0.359",
          Less("discord/sjpe_rf", "discord/sjpe_ff")),
    Claim("DisCoRD", "Fig. 5, Fig. C", "The flow decoder removes frame-wise noise: Noise sJPE falls.",
          "shown per sample (jerk plots), no table", Less("discord/noise_sjpe_rf", "discord/noise_sjpe_ff")),
    Claim("DisCoRD", "Fig. 5, Fig. B", "The flow decoder restores dynamism lost to quantization: Static sJPE falls.",
          "shown per sample (jerk plots), no table", Less("discord/static_sjpe_rf", "discord/static_sjpe_ff")),
    Claim("DisCoRD", "Table 1", "Reconstruction FID improves with the flow decoder.",
          "MoMask 0.019 → 0.011; T2M-GPT 0.089 → 0.031; MMM 0.097 → 0.020",
          Less("discord/fid_rf", "discord/fid_ff")),
    Claim("DisCoRD", "Table 1", "Positional accuracy is not what improves: MPJPE gets worse on HumanML3D.",
          "MoMask 29.5 → 33.3 mm; T2M-GPT 60.0 → 71.5 mm (KIT-ML MoMask improves: 37.5 → 33.0)",
          Greater("discord/mpjpe_rf", "discord/mpjpe_ff")),
    Claim("DisCoRD", "Table E", "Few steps suffice: FID at 2 steps is close to FID at 16 steps (the paper's steps "
          "are midpoint grid points: 2 = 2 network evaluations, 16 = 30).",
          "FID 0.034 (2 steps) vs 0.032 (16 steps)",
          Within("discord/fid_steps2", "discord/fid_steps16", 0.25)),
    Claim("DisCoRD", "Fig. 6", "sJPE is more sensitive to the number of steps than FID: fewer steps, higher sJPE.",
          "sJPE rises as steps drop from 16 to 2 while FID barely moves (plot)",
          Greater("discord/sjpe_steps2", "discord/sjpe_steps16")),
    Claim("DisCoRD", "Table E", "Decoding time grows with the number of steps (midpoint grid points).",
          "0.016 s (2 steps) → 0.221 s (16) → 1.426 s (100), batch of 32, RTX 4090",
          Less("discord/time_steps2", "discord/time_steps16")),
    Claim("DisCoRD", "Table E, Fig. 6", "At 16 steps the flow decoder is about as fast as the feed-forward decoder.",
          "0.221 s vs MoMask 0.244 s on a GPU",
          Within("discord/time_steps16", "discord/time_ff", 0.5)),
    Claim("DisCoRD", "Table 6", "Stacked per-frame projection generalises better than Repeat & Linear to tokens "
          "not seen in training.", "generation FID 0.032 vs 0.038 (reconstruction FID 0.011 vs 0.011)",
          Less("projection/heldout_mse_stacked", "projection/heldout_mse_repeat_linear")),
    Claim("DisCoRD", "Fig. 4", "Frame-wise Gaussian noise shows up as Noise sJPE, not Static sJPE.",
          "Noise sJPE rises steeply with σ; Static sJPE stays low (plot)",
          Greater("sjpe/noise_sjpe_high", "sjpe/static_sjpe_high")),
    Claim("DisCoRD", "Fig. 4", "Noise sJPE grows with the noise level.", "monotone curve over σ (plot)",
          Increasing(("sjpe/noise_sjpe_low", "sjpe/noise_sjpe_mid", "sjpe/noise_sjpe_high"))),
    # --- M2D2M (Chi et al.) --------------------------------------------------------------------
    Claim("M2D2M", "Table 1, Fig. 5", "Concatenating real motions makes a jerky transition.",
          "Jerk: GT concat 1.371 vs GT single 1.192", Greater("tps/jerk_gt_concat", "tps/jerk_gt_single")),
    Claim("M2D2M", "Table 1", "TPS transitions are smoother than concatenated real motions but not over-smoothed.",
          "Jerk: GT single 1.192 < M2D2M 1.238 < GT concat 1.371",
          Between("tps/jerk_tps", "tps/jerk_gt_single", "tps/jerk_gt_concat")),
    Claim("M2D2M", "Supp. Table 5", "Joint denoising steps smooth the transition compared with independent sampling.",
          "Jerk: w/o TPS 1.402 → T_s = 90: 1.238", Less("tps/jerk_tps", "tps/jerk_independent")),
    Claim("M2D2M", "Supp. Table 5", "Fidelity trade-off: individual-motion FID rises as T_s shrinks "
          "(keys: T_s = 100%, 90%, 50% of T).", "FID 0.196 (T_s=100) < 0.254 (90) < 0.371 (50), T = 100",
          Increasing(("tps/fid_ts100", "tps/fid_ts90", "tps/fid_ts50"))),
    Claim("M2D2M", "Table 6", "Handshake over-smooths: its transition Jerk falls below real single motions.",
          "Jerk: Handshake 1.097 vs GT single 1.192", Less("tps/jerk_handshake", "tps/jerk_gt_single")),
    Claim("M2D2M", "Table 6", "SLERP over-smooths even more: transition Jerk below real single motions.",
          "Jerk: SLERP −3.554 vs GT single 1.192", Less("tps/jerk_slerp", "tps/jerk_gt_single")),
    Claim("M2D2M", "Table 6", "TPS keeps individual motions more faithful than Handshake.",
          "individual FID: TPS 0.254 vs Handshake 1.279 (SLERP 1.402)",
          Less("tps/fid_ts90", "tps/fid_handshake")),
    Claim("M2D2M", "Table 5", "With TPS, dynamic β(t,d) gives smoother transitions than uniform β_t.",
          "Jerk 1.238 vs 1.265 (T_s = 90)", Less("tps/jerk_tps", "tps/jerk_tps_uniform")),
    Claim("M2D2M", "Table 3", "Dynamic transition probabilities improve single-motion FID over uniform ones.",
          "FID 0.087 (β(t,d)) vs 0.115 (β_t); KIT-ML 0.378 vs 0.404",
          Less("transitions/fid_dynamic", "transitions/fid_uniform"),
          mechanism=(
              Evidence("largest TV between rows of the dynamic and the uniform forward process Q̄_t (η = 0.25, 0.5, 2; "
                       "at most K·β̄_T)", ("transitions/max_tv_eta0.25", "transitions/max_tv_eta0.5",
                                           "transitions/max_tv_eta2", "transitions/kbeta_bar_t")),
              Evidence("FID dynamic − uniform, interval over training seeds",
                       ("transitions/fid_dynamic_minus_uniform",)),
              Evidence("FID gap between two training seeds of the same model (paired over repeats)",
                       ("transitions/fid_seed_gap_dynamic", "transitions/fid_seed_gap_uniform")),
          )),
    Claim("M2D2M", "Supp. Table 2", "Classifier-free guidance improves single-motion fidelity.",
          "FID 0.107 (s = 0) → 0.087 (s = 4)", Less("diffusion/fid_guided", "diffusion/fid_unguided"),
          mechanism=(
              Evidence("NLL of the true code at t = T: unconditional branch vs the code frequencies' entropy",
                       ("diffusion/nll_uncond_xt", "diffusion/unigram_entropy")),
              Evidence("entropy of p(x0 | x_T) (nats), s = 0 → 4",
                       ("diffusion/entropy_xt_s0", "diffusion/entropy_xt_s4")),
              Evidence("code-histogram TV to the real tokens, s = 0 → 4",
                       ("diffusion/hist_tv_s0", "diffusion/hist_tv_s4")),
              Evidence("adjacent repeats: real, s = 0, s = 4",
                       ("diffusion/repeat_rate_real", "diffusion/repeat_rate_s0", "diffusion/repeat_rate_s4")),
              Evidence("R-Top3, s = 0 → 4", ("diffusion/top3_unguided", "diffusion/top3_guided")),
          )),
)


# The papers' own numbers for our keys (HumanML3D; DisCoRD rows use MoMask's tokenizer). Judging
# them with the rules above must reproduce each paper's conclusion: a check that every rule points
# the way its claim does. Keys whose quantity the paper only plots are absent.
PAPER_NUMBERS: dict[str, tuple[float, str]] = {
    "discord/sjpe_ff": (0.512, "DisCoRD Table 1"), "discord/sjpe_rf": (0.385, "DisCoRD Table 1"),
    "discord/fid_ff": (0.019, "DisCoRD Table 1"), "discord/fid_rf": (0.011, "DisCoRD Table 1"),
    "discord/mpjpe_ff": (29.5, "DisCoRD Table 1"), "discord/mpjpe_rf": (33.3, "DisCoRD Table 1"),
    "discord/fid_steps2": (0.034, "DisCoRD Table E"), "discord/fid_steps16": (0.032, "DisCoRD Table E"),
    "discord/time_steps2": (0.016, "DisCoRD Table E"), "discord/time_steps16": (0.221, "DisCoRD Table E"),
    "discord/time_ff": (0.244, "DisCoRD Table E"),
    "tps/jerk_gt_single": (1.192, "M2D2M Table 1"), "tps/jerk_gt_concat": (1.371, "M2D2M Table 1"),
    "tps/jerk_tps": (1.238, "M2D2M Table 1"), "tps/jerk_independent": (1.402, "M2D2M Supp. Table 5"),
    "tps/fid_ts100": (0.196, "M2D2M Supp. Table 5"), "tps/fid_ts90": (0.254, "M2D2M Supp. Table 5"),
    "tps/fid_ts50": (0.371, "M2D2M Supp. Table 5"),
    "tps/jerk_handshake": (1.097, "M2D2M Table 6"), "tps/jerk_slerp": (-3.554, "M2D2M Table 6"),
    "tps/fid_handshake": (1.279, "M2D2M Table 6"), "tps/jerk_tps_uniform": (1.265, "M2D2M Table 5"),
    "transitions/fid_dynamic": (0.087, "M2D2M Table 3"), "transitions/fid_uniform": (0.115, "M2D2M Table 3"),
    "diffusion/fid_guided": (0.087, "M2D2M Supp. Table 2"), "diffusion/fid_unguided": (0.107, "M2D2M Supp. Table 2"),
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
    ours: str
    verdict: str
    missing: tuple[str, ...] = ()
    mechanism: str = ""  # one line per Evidence, from the recorded numbers ("" when the claim has none)


@dataclass
class ClaimsTable:
    """Rows of :func:`claims_table`; renders as HTML in Jupyter and in the book."""

    rows: list[ClaimRow] = field(default_factory=list)
    profile: str = "laptop"

    def __iter__(self) -> Iterator[ClaimRow]:
        return iter(self.rows)

    def __len__(self) -> int:
        return len(self.rows)

    def counts(self) -> dict[str, int]:
        return {v: sum(row.verdict == v for row in self.rows) for v in VERDICTS}

    def _repr_html_(self) -> str:
        # Four columns so the table fits a book page; the verdict comes first because it is the news.
        colour = {HOLDS: "#1a7f37", FAILS: "#cf222e", INCONCLUSIVE: "#9a6700", MISSING: "#57606a"}
        esc = html.escape
        lines = [f'<div style="overflow-x:auto"><table class="claims-table" style="font-size:0.85em">'
                 f"<caption>Claims vs. our measurements (profile <code>{esc(self.profile)}</code>)</caption>",
                 "<thead><tr><th>Verdict</th><th>Claim</th><th>Paper</th><th>Ours</th></tr></thead><tbody>"]
        for row in self.rows:
            verdict = f'<td style="color:{colour[row.verdict]};font-weight:bold">{esc(row.verdict)}</td>'
            why = "".join(f"<br><small><i>measured mechanism:</i> {esc(line)}</small>"
                          for line in row.mechanism.split("\n") if line)  # fmt: skip
            claim = (f"<td>{esc(row.statement)}<br><small>{esc(row.paper)}, {esc(row.source)} &middot; "
                     f"chapter {esc(row.chapter)}</small>{why}</td>")
            ours = "<br>".join(f'<code style="overflow-wrap:anywhere">{esc(line)}</code>'
                               for line in row.ours.split("\n"))
            lines.append(f"<tr>{verdict}{claim}<td>{esc(row.paper_value)}</td><td>{ours}</td></tr>")
        lines.append("</tbody></table></div>")
        return "\n".join(lines)

    def to_markdown(self) -> str:
        out = ["| Paper | Where | Claim | Paper | Ours | Verdict | Measured mechanism |", "|---" * 7 + "|"]
        for r in self.rows:
            cells = (r.paper, r.source, r.statement, r.paper_value, r.ours.replace("\n", "; "), r.verdict,
                     r.mechanism.replace("\n", "; "))
            out.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
        return "\n".join(out)


def judge(claim: Claim, recorded: Mapping[str, Result]) -> ClaimRow:
    """One row: the claim, our numbers for its keys, and the verdict."""
    missing = tuple(k for k in claim.keys if k not in recorded)
    # Keys of one chapter are shown without the "chapter/" prefix (the row names the chapter).
    one_chapter = len({k.split("/", 1)[0] for k in claim.keys}) == 1
    label = {k: k.split("/", 1)[-1] if one_chapter else k for k in claim.keys}
    ours = "\n".join(f"{label[k]} = {recorded[k].format()}" if k in recorded else f"{label[k]}: —"
                      for k in claim.keys)
    verdict = MISSING if missing else claim.rule.judge(recorded)
    mechanism = "\n".join(e.format(recorded) for e in claim.mechanism)
    return ClaimRow(claim.paper, claim.source, claim.statement, claim.paper_value, claim.rule.describe(),
                    claim.chapter, ours, verdict, missing, mechanism)


def claims_table(profile: str | None = None, recorded: Mapping[str, Result] | None = None,
                 claims: Sequence[Claim] = CLAIMS) -> ClaimsTable:
    """Judge every claim on the results recorded for ``profile`` (or on ``recorded`` if given)."""
    profile = get_profile(profile)
    recorded = load_all(profile) if recorded is None else recorded
    return ClaimsTable([judge(c, recorded) for c in claims], profile)
