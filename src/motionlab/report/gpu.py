"""What the library's training steps and decodes cost on a GPU, read from the recorded runs of the GPU benchmark.

Each file in ``book/data/gpu/`` is one run of ``benchmarks/bench_gpu.py`` (or, for the first run, the hand-written
script it grew from): a ``machine`` record (the GPU, torch, CUDA, the commit, the measured matmul peak) and one record
per training step and per decode timed. This module turns a run into the tables chapter 98 shows and into the
projection a reader planning a full-scale run needs: each model's published schedule at the measured step time.
"""

from __future__ import annotations

import functools
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from motionlab.data.humanml3d import HUMANML3D_SPLIT_SIZES
from motionlab.diffusion.training import diffusion_training_config, optimisation
from motionlab.flow.config import discord_config
from motionlab.sizes import chapter_sizes
from motionlab.tokenizers.config import rvq_config

from .store import Result

# Library changes after which a recorded run's "library train_step" times no longer time the code: (commit, what).
# Each removed work from a step and added none, so a run recorded before them bounds today's step from above.
TRAIN_STEP_CHANGES = (
    ("8eff267", "training steps stopped reading values back to the host"),
    ("7e11823", "the RVQ's layer dropout reads the host once per step"),
)

MODEL_NAMES = {
    "rvq": "MoMask RVQ-VAE",
    "discord": "DisCoRD decoder",
    "t2m": "M2D2M text encoder + denoiser",
}
# The benchmark's model that times each part motionlab.train.compiling compiles.
VARIANTS = ("library train_step", "module", "module, compiled", "module, compiled, CUDA graphs", "official module")


@dataclass(frozen=True)
class GPURun:
    """One recorded run: where it ran and what it measured."""

    path: Path
    machine: dict
    train: list[dict] = field(default_factory=list)
    decode: list[dict] = field(default_factory=list)

    @property
    def peak_tflops(self) -> float | None:
        """The bf16 matmul peak measured in the same run (TFLOP/s)."""
        return self.machine.get("matmul_tflops", {}).get("bf16")

    def describe(self) -> str:
        m = self.machine
        return (
            f"{m['device']}, torch {m['torch']}, CUDA {m['cuda']}, commit {m['commit']}, {m['date']}; bf16 matmul "
            f"peak {self.peak_tflops:.0f} TFLOP/s"
        )

    def predates(self) -> list[tuple[str, str]]:
        """The :data:`TRAIN_STEP_CHANGES` this run's commit lacks, by git's history (a commit git cannot place, as
        outside a clone, counts as lacking them: the caveat is kept where it cannot be checked)."""
        return [change for change in TRAIN_STEP_CHANGES if not _contains(self.machine.get("commit"), change[0])]

    def train_step_caveat(self) -> str | None:
        """A sentence for the pages that show this run's library train_step times, where it :meth:`predates` a
        change that alters them (None where it does not)."""
        changes = self.predates()
        if not changes:
            return None
        what = "; ".join(f"{text} ({commit})" for commit, text in changes)
        return (
            f"**Measured before** {what}: its *library train_step* rows time the code as it was then and bound "
            "today's from above; the bare module's rows do not depend on it. `BENCH_ONLY=1 tools/gpu_lease.sh` "
            "measures them again."
        )

    def decode_seconds(self, decoder: str, precision: str, batch: int, points: int) -> float | None:
        """Seconds per decode call of ``decoder`` (``points`` grid points; 0: the feed-forward decoder), or None."""
        for r in self.decode:
            if (r["decoder"], r["precision"], r["batch"], r["points"]) == (decoder, precision, batch, points):
                return r["seconds_median"]
        return None

    def compile_seconds(self, model: str, precision: str = "bf16", graphs: bool = False) -> float | None:
        """Seconds the first call of ``model``'s compiled step took (with CUDA graphs where ``graphs``; measured in
        ``precision``, else in any precision), or None where this run did not compile it so."""
        variant = "module, compiled, CUDA graphs" if graphs else "module, compiled"
        timed = [r for r in self.train if r["model"] == model and r["variant"] == variant and "compile_s" in r]
        timed.sort(key=lambda r: r["precision"] != precision)
        return float(timed[0]["compile_s"]) if timed else None

    def step_ms(self, model: str, variant: str, precision: str = "bf16") -> float | None:
        for r in self.train:
            if (r["model"], r["variant"], r["precision"]) == (model, variant, precision):
                return r["step_ms_median"]
        return None


@functools.cache
def _contains(commit: str | None, change: str) -> bool:
    """Whether ``commit`` has ``change`` in its history (False where git cannot tell). Cached: a plan asks once per
    model, and a commit's history does not change."""
    import subprocess

    if not commit:
        return False
    here = Path(__file__).resolve().parent  # git finds the repository from inside it; a wheel has none
    try:
        found = subprocess.run(
            ["git", "-C", str(here), "merge-base", "--is-ancestor", change, commit], capture_output=True
        )
    except OSError:  # no git
        return False
    return found.returncode == 0


def read_gpu_run(path: str | os.PathLike) -> GPURun:
    """One run's records (a JSON list with exactly one ``machine`` record)."""
    records = json.loads(Path(path).read_text())
    machines = [r for r in records if r.get("section") == "machine"]
    if len(machines) != 1:
        raise ValueError(f"{path}: a GPU run holds exactly one machine record, found {len(machines)}")
    by = lambda section: [r for r in records if r.get("section") == section]  # noqa: E731
    return GPURun(Path(path), machines[0], by("train"), by("decode"))


def load_gpu_runs(folder: str | os.PathLike) -> list[GPURun]:
    """Every recorded run in ``folder``, oldest first (an absent folder: none)."""
    folder = Path(folder)
    runs = [read_gpu_run(p) for p in sorted(folder.glob("*.json"))] if folder.is_dir() else []
    return sorted(runs, key=lambda r: (r.machine["date"], r.path.name))


def full_schedule_steps() -> dict[str, int]:
    """Optimizer steps of each model's schedule in the ``full`` profile (the papers' where they state one), the
    text-to-motion model's 110 epochs counted over HumanML3D's train split."""
    t2m = diffusion_training_config("full", num_codes=rvq_config("full").codebook_size)
    return {
        "rvq": rvq_config("full").train.steps,
        "discord": discord_config("full").train_steps,
        "t2m": optimisation(t2m, HUMANML3D_SPLIT_SIZES["train"]).steps,
    }


def step_table(run: GPURun) -> str:
    """Markdown: every timed step of ``run``, its FLOPs and its share of the run's bf16 matmul peak."""
    rows = [
        "| model | precision | what ran | batch | ms / step | TFLOP / step | share of bf16 peak |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    order = {v: i for i, v in enumerate(VARIANTS)}
    for r in sorted(run.train, key=lambda r: (r["model"], r["precision"], order.get(r["variant"], 9))):
        share = r["tflop_per_step"] / (r["step_ms_median"] / 1e3) / run.peak_tflops if run.peak_tflops else math.nan
        rows.append(
            f"| {MODEL_NAMES[r['model']]} | {r['precision']} | {r['variant']} | {r['batch']} | "
            f"{r['step_ms_median']:.1f} | {r['tflop_per_step']:.2f} | {100 * share:.1f}% |"
        )
    return "\n".join(rows)


def projection_table(run: GPURun, precision: str = "bf16") -> str:
    """Markdown: each model's ``full`` schedule in hours at each measured step time of ``run``."""
    steps = full_schedule_steps()
    present = [v for v in VARIANTS if any(run.step_ms(m, v, precision) for m in steps)]
    rows = [
        "| model | the full profile's schedule | " + " | ".join(present) + " |",
        "|---|---:|" + "---:|" * len(present),
    ]
    for model, n in steps.items():
        cells = []
        for variant in present:
            ms = run.step_ms(model, variant, precision)
            cells.append(f"{n * ms / 3.6e6:.1f} h" if ms else "not measured")
        rows.append(f"| {MODEL_NAMES[model]} | {n:,} steps | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def decode_table(run: GPURun) -> str:
    """Markdown: DisCoRD's Table E grid (seconds per call, 196 frames) for every decoder and precision of ``run``."""
    grid = sorted({(r["batch"], r["points"]) for r in run.decode if r["points"]})
    header = " | ".join(f"batch {b}, {p} points" for b, p in grid)
    rows = [
        f"| decoder | precision | {header} | feed-forward (batch 1 / 32) |",
        "|---|---|" + "---:|" * (len(grid) + 1),
    ]
    for decoder in sorted({r["decoder"] for r in run.decode if r["points"]}):
        for precision in sorted({r["precision"] for r in run.decode if r["decoder"] == decoder}):
            cells = [run.decode_seconds(decoder, precision, b, p) for b, p in grid]
            ff_name = "official feed-forward" if decoder.startswith("official") else "feed-forward"
            ff = [run.decode_seconds(ff_name, "fp32", b, 0) for b in (1, 32)]
            ff_text = " / ".join(f"{s:.4f}" for s in ff if s is not None) if precision == "fp32" else ""
            text = " | ".join(f"{s:.4f}" if s is not None else "–" for s in cells)
            rows.append(f"| {decoder} | {precision} | {text} | {ff_text} |")
    return "\n".join(rows)


def table1_decode_seconds(run: GPURun, precision: str = "bf16", decoder: str = "motionlab") -> float | None:
    """GPU seconds of DisCoRD Table 1's decoding at full scale (every test clip, every seed) at ``run``'s batch-32,
    16-point decode time; None where ``run`` did not time it. The evaluator's forward passes come on top."""
    sizes = chapter_sizes("full").discord
    per_call = run.decode_seconds(decoder, precision, 32, 16)
    if per_call is None:
        return None
    clips = sizes.test_clips if sizes.test_clips is not None else HUMANML3D_SPLIT_SIZES["test"]  # None: all of it
    return math.ceil(clips / 32) * sizes.seeds * per_call


# DisCoRD Table E's timing keys (chapter 05 records them on the CPU): (decoder, grid points) in a run's decode records
TABLE_E_KEYS = {
    "discord/time_steps2": ("motionlab", 2),
    "discord/time_steps16": ("motionlab", 16),
    "discord/time_ff": ("feed-forward", 0),
}
TABLE_E_BATCH = 32  # the paper's batch for Table E's times


def table_e_results(run: GPURun, precision: str = "fp32") -> dict[str, Result]:
    """Table E's timing keys as ``run`` measured them: seconds per call at batch 32, 196 frames, the full sizes (the
    feed-forward decoder is timed in fp32 only, so the comparison is fp32). Keys the run did not time are left out;
    medians, so no interval."""
    note = f"{run.machine['device']}, {precision}, batch {TABLE_E_BATCH}, 196 frames, full sizes, {run.path.name}"
    out = {}
    for name, (decoder, points) in TABLE_E_KEYS.items():
        value = run.decode_seconds(decoder, precision, TABLE_E_BATCH, points)
        if value is not None:
            chapter, key = name.split("/")
            out[name] = Result(chapter, key, float(value), unit="s", note=note, profile="full", precision=precision)
    return out


def newest_gpu_run(profile: str | None = None) -> GPURun | None:
    """The newest run recorded in the repository's ``book/data/gpu`` (None: none, or no repository). A GPU run times
    the full sizes, so it is the same for every profile; ``profile`` is accepted for the claims table's loaders."""
    from .spread import find_folder

    folder = find_folder(("book", "data", "gpu"))
    runs = load_gpu_runs(folder) if folder is not None else []
    return runs[-1] if runs else None


__all__ = [
    "GPURun",
    "TRAIN_STEP_CHANGES",
    "TABLE_E_KEYS",
    "newest_gpu_run",
    "table_e_results",
    "decode_table",
    "full_schedule_steps",
    "load_gpu_runs",
    "projection_table",
    "read_gpu_run",
    "step_table",
    "table1_decode_seconds",
]
