"""The intro's chapter map: which models each chapter loads, and the measured times it shows."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import yaml

from motionlab.build.book_models import CHAPTER_MODELS, book_jobs, chapter_costs
from motionlab.sizes import chapter_sizes

ROOT = Path(__file__).resolve().parents[2]


def _toc_chapters() -> list[str]:
    toc = yaml.safe_load((ROOT / "book" / "_toc.yml").read_text())
    files = [entry["file"] for part in toc["parts"] for entry in part["chapters"]]
    return [Path(f).name for f in files if f.startswith("notebooks/")]


def test_every_chapter_names_its_models_and_every_model_serves_a_chapter():
    assert list(CHAPTER_MODELS) == _toc_chapters()
    replicates = {f"t2m/{arm}-seed{k}" for arm in ("dynamic", "uniform") for k in (1, 2)}
    for profile in ("smoke", "laptop"):
        jobs = {job.name for job in book_jobs(profile)}
        loaded = {m for models in CHAPTER_MODELS.values() for m in models}
        # chapter 08 loads the training-seed replicates its profile's sizes name, and only those are trained
        seeds = chapter_sizes(profile).transitions.training_seeds[1:]
        assert {m for m in replicates if m in jobs} == {
            f"t2m/{a}-seed{k}" for a in ("dynamic", "uniform") for k in seeds
        }
        assert loaded - (replicates - jobs) <= jobs, sorted(loaded - jobs)
        assert jobs <= loaded, f"trained but loaded by no chapter: {sorted(jobs - loaded)}"
    assert chapter_sizes("laptop").transitions.training_seeds == (0,)  # the laptop reads the study's replicates


def test_a_model_is_charged_to_the_first_chapter_that_loads_it():
    training = {
        "data": {"seconds": 60},
        "tokenizer/vq": {"seconds": 600},
        "tokenizer/rvq": {"seconds": 300},
        "evaluator": {"seconds": 120},
    }
    execution = {
        "01_motion_data": {"seconds": 30},
        "02_vector_quantization": {"seconds": 90},
        "06_sjpe": {"seconds": 200},
    }
    costs = chapter_costs(training, execution)
    assert costs == {"01_motion_data": (90, 30), "02_vector_quantization": (990, 90), "06_sjpe": (320, 200)}


def test_the_intro_shows_the_recorded_laptop_times():
    times = ROOT / "book" / "data" / "build_times"
    assert (times / "laptop.json").is_file() and (times / "laptop-training.json").is_file(), (
        "record a measured laptop build: train book --record, book execute --record"
    )
    check = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "chapter_map.py"), "--check"], capture_output=True, text=True
    )
    assert check.returncode == 0, check.stderr
    intro = (ROOT / "book" / "intro.md").read_text()
    assert "| # | chapter | builds | needs | read (min) | cold / warm (min) |" in intro


def test_recording_training_times_keeps_the_entries_of_cached_models(tmp_path):
    from motionlab.build.plan import JobResult
    from motionlab.cli import _record_training

    path = tmp_path / "laptop-training.json"
    _record_training(path, [JobResult("data", "trained", 70.0, 65.0), JobResult("evaluator", "trained", 200, 190)])
    _record_training(path, [JobResult("data", "cached"), JobResult("evaluator", "trained", 150.04, 140.06)])
    assert json.loads(path.read_text()) == {
        "data": {"seconds": 70.0, "cpu_seconds": 65.0, "precision": "fp32"},
        "evaluator": {"seconds": 150.0, "cpu_seconds": 140.1, "precision": "fp32"},
    }


def test_train_book_in_the_repository_keeps_its_times_beside_the_build(tmp_path, monkeypatch):
    from motionlab import cli
    from motionlab.build.plan import JobResult

    (tmp_path / "book").mkdir()
    (tmp_path / "book" / "_toc.yml").write_text("format: jb-book\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))
    monkeypatch.setattr("motionlab.build.book_models.book_jobs", lambda profile: [])
    monkeypatch.setattr(
        "motionlab.build.plan.run_plan", lambda plan, workers: [JobResult("data", "trained", 80.0, 6.0)]
    )
    args = cli.build_parser().parse_args(["train", "book", "--profile", "smoke"])
    args.settings = cli._settings(args)  # what main() resolves before any command
    assert cli._train_book(args, {}) == 0
    kept = json.loads((tmp_path / "_build" / "executed" / "smoke" / "training.json").read_text())
    assert kept == {"data": {"seconds": 80.0, "cpu_seconds": 6.0, "precision": "fp32"}}
    assert not (tmp_path / "book" / "data").exists()  # only --record writes into the book's sources


def test_recorded_times_name_the_precision_each_model_trained_in(tmp_path, monkeypatch):
    from motionlab.build.plan import JobResult
    from motionlab.cli import _record_training

    monkeypatch.setenv("MOTIONLAB_PRECISION", "bf16")
    path = tmp_path / "training.json"
    _record_training(path, [JobResult("tokenizer/vq", "trained", 10.0, 9.0), JobResult("evaluator", "trained", 5, 4)])
    recorded = json.loads(path.read_text())
    assert recorded["tokenizer/vq"]["precision"] == "bf16" and recorded["evaluator"]["precision"] == "fp32"


def test_chapter_04s_ablation_has_its_own_budget_where_the_profile_says_so():
    from motionlab.flow import discord_config
    from motionlab.models import projection_config
    from motionlab.sizes import DISCORD_ABLATION

    changed = ("projection", "train_steps", "warmup_steps", "width")
    for profile in ("smoke", "laptop", "full"):
        own, budget = discord_config(profile), DISCORD_ABLATION.get(profile, {})
        ablation = {kind: projection_config(profile, None, kind) for kind in ("stacked", "repeat", "transposed")}
        assert {c.train_steps for c in ablation.values()} == {budget.get("train_steps", own.train_steps)}
        assert {c.width for c in ablation.values()} == {budget.get("width", own.width)}
        assert {c.projection for c in ablation.values()} == {"stacked", "repeat", "transposed"}
        # apart from the projection, the budget and the width, the ablation is chapter 05's decoder
        same = {k: v for k, v in own.to_dict().items() if k not in changed}
        assert all({k: v for k, v in c.to_dict().items() if k in same} == same for c in ablation.values())
        # the stacked ablation decoder is chapter 05's own exactly where the profile changes nothing
        assert (ablation["stacked"] == own) == (not budget)
    laptop = discord_config("laptop")
    assert DISCORD_ABLATION["laptop"]["train_steps"] < laptop.train_steps
    assert DISCORD_ABLATION["laptop"]["width"] < laptop.width
    assert DISCORD_ABLATION["laptop"]["warmup_steps"] == DISCORD_ABLATION["laptop"]["train_steps"] // 20
