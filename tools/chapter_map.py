"""Write each chapter's reading time and measured cold / warm minutes into the intro's chapter map (book/intro.md).

The times come from two files that the build records (commit them after a measured build):

    motionlab train book --record      ->  book/data/build_times/<profile>-training.json   (per model)
    motionlab book execute --record    ->  book/data/build_times/<profile>.json            (per chapter)

Warm is a chapter's execution with its models cached; cold adds the training of the models it is the first to
load (see ``motionlab.build.book_models.chapter_costs``). The reading time is counted from the notebook itself
(:func:`reading_minutes`). ``--check`` only reports whether the intro is up to date
(a test runs it, so the map cannot drift from the recorded measurements).

    python tools/chapter_map.py [--profile laptop] [--check]
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

from motionlab.build import reading_time
from motionlab.build.book_models import chapter_costs

ROOT = Path(__file__).resolve().parent.parent
HEADER = "| # | chapter | builds | needs | read (min) | cold / warm (min) |"
_ROW = re.compile(r"^\| (\d\d|s\d) \| \[[^\]]*\]\(\.\./notebooks/(\w+)\.ipynb\) \|")


def load_reading(root: Path, chapters: list[str]) -> dict[str, float]:
    """``{chapter: reading minutes}`` of ``notebooks/<chapter>.ipynb`` under ``root``
    (:mod:`motionlab.build.reading_time`: prose, shown code and figures)."""
    return {chapter: time.minutes for chapter, time in reading_time.load_reading(root, chapters).items()}


def load_costs(root: Path, profile: str) -> dict[str, tuple[float, float]]:
    """``{chapter: (cold, warm)}`` seconds from the recorded build times of ``profile``."""
    times = root / "book" / "data" / "build_times"
    execution = json.loads((times / f"{profile}.json").read_text())
    training = json.loads((times / f"{profile}-training.json").read_text())
    return chapter_costs(training, {k: v for k, v in execution.items() if isinstance(v, dict)})


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f}"


def render(intro: str, costs: dict[str, tuple[float, float]], reading: dict[str, float] | None = None) -> str:
    """``intro`` with the chapter map's last two columns set from ``reading`` (minutes) and ``costs`` (seconds);
    a chapter without a time gets "—". A map that has no reading column yet gets one."""
    reading = reading or {}
    lines, in_map = intro.splitlines(), False
    for i, line in enumerate(lines):
        if line.startswith("| # | chapter |"):
            lines[i], in_map = HEADER, True
            continue
        if in_map and line.startswith("|---"):
            lines[i] = "|---" * (HEADER.count("|") - 1) + "|"
            continue
        match = _ROW.match(line) if in_map else None
        if match:
            cells = line.rstrip().rstrip("|").split(" | ")
            cost, read = costs.get(match.group(2)), reading.get(match.group(2))
            cells = cells[:4] + [f"{max(1, round(read))}" if read is not None else "—"]
            cells.append(f"{_minutes(cost[0])} / {_minutes(cost[1])}" if cost else "—")
            lines[i] = " | ".join(cells) + " |"
        elif in_map and not line.startswith("|"):
            in_map = False
    return "\n".join(lines) + ("\n" if intro.endswith("\n") else "")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", default="laptop")
    parser.add_argument("--check", action="store_true", help="exit 1 if book/intro.md is not up to date")
    args = parser.parse_args(argv)
    intro_path = ROOT / "book" / "intro.md"
    intro = intro_path.read_text()
    chapters = [m.group(2) for m in map(_ROW.match, intro.splitlines()) if m]
    updated = render(intro, load_costs(ROOT, args.profile), load_reading(ROOT, chapters))
    if args.check:
        if updated != intro:
            print(
                "book/intro.md's chapter map differs from the notebooks' reading times or the recorded build times: "
                "run tools/chapter_map.py",
                file=sys.stderr,
            )
            return 1
        return 0
    intro_path.write_text(updated)
    print(f"chapter map updated from the notebooks and the {args.profile} build times")
    return 0


if __name__ == "__main__":
    sys.exit(main())
