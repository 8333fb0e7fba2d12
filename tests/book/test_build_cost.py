"""tools/build_cost.py: a build's CPU minutes per model and chapter, and an earlier build's beside them."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("build_cost", ROOT / "tools" / "build_cost.py")
build_cost = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(build_cost)


def _write(folder: Path, name: str, training: dict[str, float], chapters: dict[str, float]) -> tuple[Path, Path]:
    t, c = folder / f"{name}-training.json", folder / f"{name}.json"
    t.write_text(
        json.dumps({m: {"seconds": s * 1.1, "cpu_seconds": s, "precision": "fp32"} for m, s in training.items()})
    )
    c.write_text(
        json.dumps({"profile": "laptop", "wall_seconds": 1.0, **{k: {"seconds": s} for k, s in chapters.items()}})
    )
    return t, c


def test_the_table_totals_cpu_minutes_and_compares_with_an_earlier_build(tmp_path):
    before = build_cost.read_build(*_write(tmp_path, "old", {"a": 600, "b": 1200}, {"01": 300}))
    now = build_cost.read_build(*_write(tmp_path, "new", {"a": 600}, {"01": 150}))
    table = build_cost.cost_table(now, before)
    lines = table.splitlines()
    assert lines[0] == "| | before, CPU min | now, CPU min |" and lines[1] == "|---|---|---|"
    assert "| b | 20.0 | — |" in lines  # a model the new plan no longer trains
    assert "| **training** | **30.0** | **10.0** |" in lines
    assert "| **chapters** | **5.0** | **2.5** |" in lines
    assert lines[-1] == "| **total** | **35.0** | **12.5** (36%) |"
    alone = build_cost.cost_table(now).splitlines()
    assert alone[0] == "| | CPU min |" and alone[-1] == "| **total** | **12.5** |"


def test_only_the_models_the_plan_trains_count():
    recorded = {"data": 1.0, "tokenizer/vq": 2.0, "t2m/dynamic-seed1": 3.0, "not/a-model": 4.0}
    assert build_cost.planned(recorded, "laptop") == {"data": 1.0, "tokenizer/vq": 2.0}  # laptop: no seed replicates
    assert "t2m/dynamic-seed1" in build_cost.planned(recorded, "smoke")


def test_a_missing_record_is_reported(tmp_path, capsys):
    assert build_cost.main(["--training", str(tmp_path / "none.json"), "--chapters", str(tmp_path / "no.json")]) == 1
    assert "no such record" in capsys.readouterr().err
