"""Where a book build's CPU time goes: training minutes per model and execution minutes per chapter, as a table.

Reads the two files a measured build records (``motionlab train book --record`` and ``motionlab book execute
--record``, or a build's own ``_build/executed/<profile>/training.json`` and ``timings.json``) and prints a Markdown
table of CPU minutes per model and per chapter. ``--against`` adds the columns of an earlier build (its two files)
and the ratio of the totals, the way a change that cuts the build's arithmetic is judged: both builds on one
machine, CPU minutes, not wall minutes.

A model counts when the current plan (:func:`motionlab.build.book_models.book_jobs`) trains it, so a record that
still lists a model the plan dropped does not inflate the total; ``--against`` counts the earlier build's whole
record. A chapter's minutes are its kernel's wall time (one torch thread each, one chapter per core).

    python tools/build_cost.py                                  # book/data/build_times/laptop*.json
    python tools/build_cost.py --against OLD-training.json OLD.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TIMES = ROOT / "book" / "data" / "build_times"


def read_build(training: Path, chapters: Path) -> tuple[dict[str, float], dict[str, float]]:
    """``(CPU seconds per model, seconds per chapter)`` from a build's two records."""
    models = {name: float(entry["cpu_seconds"]) for name, entry in json.loads(training.read_text()).items()}
    record = json.loads(chapters.read_text())
    per_chapter = {name: float(entry["seconds"]) for name, entry in record.items() if isinstance(entry, dict)}
    return models, per_chapter


def cost_table(
    now: tuple[dict[str, float], dict[str, float]], before: tuple[dict[str, float], dict[str, float]] | None = None
) -> str:
    """The Markdown table: one row per model and chapter, totals, and (with ``before``) the ratio now / before."""

    def minutes(seconds: float | None) -> str:
        return "—" if seconds is None else f"{seconds / 60:.1f}"

    head = "| | CPU min |" if before is None else "| | before, CPU min | now, CPU min |"
    lines = [head, "|---" * (head.count("|") - 1) + "|"]
    totals = []
    for kind, index in (("training", 0), ("chapters", 1)):
        names = list(dict.fromkeys([*(before[index] if before else {}), *now[index]]))
        for name in names:
            cells = [minutes(now[index].get(name))]
            if before is not None:
                cells.insert(0, minutes(before[index].get(name)))
            lines.append(f"| {name} | {' | '.join(cells)} |")
        total_now = sum(now[index].values())
        total_before = sum(before[index].values()) if before else None
        totals.append((total_now, total_before))
        cells = [f"**{minutes(total_now)}**"]
        if before is not None:
            cells.insert(0, f"**{minutes(total_before)}**")
        lines.append(f"| **{kind}** | {' | '.join(cells)} |")
    all_now = sum(t[0] for t in totals)
    if before is None:
        lines.append(f"| **total** | **{minutes(all_now)}** |")
    else:
        all_before = sum(t[1] for t in totals)
        lines.append(f"| **total** | **{minutes(all_before)}** | **{minutes(all_now)}** ({all_now / all_before:.0%}) |")
    return "\n".join(lines)


def planned(models: dict[str, float], profile: str) -> dict[str, float]:
    """The entries of ``models`` that ``profile``'s plan trains (the data step included)."""
    from motionlab.build.book_models import book_jobs

    names = [job.name for job in book_jobs(profile)]
    return {name: models[name] for name in names if name in models}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", default="laptop")
    parser.add_argument("--training", type=Path, help="per-model record (default: book/data/build_times/<profile>-…)")
    parser.add_argument("--chapters", type=Path, help="per-chapter record (default: book/data/build_times/<profile>…)")
    parser.add_argument("--against", type=Path, nargs=2, metavar=("TRAINING", "CHAPTERS"), help="an earlier build")
    args = parser.parse_args(argv)
    training = args.training or TIMES / f"{args.profile}-training.json"
    chapters = args.chapters or TIMES / f"{args.profile}.json"
    missing = [str(p) for p in (training, chapters, *(args.against or ())) if not p.is_file()]
    if missing:
        print(f"no such record: {', '.join(missing)}", file=sys.stderr)
        return 1
    models, per_chapter = read_build(training, chapters)
    before = read_build(*args.against) if args.against else None
    print(cost_table((planned(models, args.profile), per_chapter), before))
    return 0


if __name__ == "__main__":
    sys.exit(main())
