"""The front door: the README a newcomer reads first, the intro's start, and one source for the build times."""

from __future__ import annotations

import importlib.util
import json
import re
from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from motionlab.build.build_times import ColdBuild, build_phrase, cold_build_line, cold_builds, cold_tests, plan_change

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
INTRO = (ROOT / "book" / "intro.md").read_text(encoding="utf-8")
_spec = importlib.util.spec_from_file_location("chapter_map", ROOT / "tools" / "chapter_map.py")
chapter_map = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(chapter_map)

# a whole-build time as the pages write it: "about 44 min on an AMD EPYC Zen 3, AVX2 only (fp32)"
_BUILD_PHRASE = re.compile(r"about \d+ min on an? [^()]+? \((?:fp32|bf16)\)")


def test_the_readme_is_short_and_links_both_papers():
    assert len(README) <= 10_000, f"README.md has {len(README):,} characters"
    assert "https://arxiv.org/abs/2411.19527" in README and "https://arxiv.org/abs/2407.14502" in README
    for needed in ("make book", "make test", "npm", "jupyter lab notebooks/", "_build/html", "smoke", "laptop", "full"):
        assert needed in README, needed
    for moved in ("verdicts_by_run", "oneDNN", "PFLOP", "src/motionlab/\n"):  # maintainer detail lives elsewhere now
        assert moved not in README, moved


def test_the_readme_picture_is_committed_and_small():
    images = re.findall(r'<img src="([^"]+)"|!\[[^\]]*\]\(([^)]+)\)', README)
    paths = [ROOT / (a or b) for a, b in images]
    assert paths, "the README shows a picture of a generated motion"
    for path in paths:
        assert path.is_file() and path.stat().st_size < 200_000, path


def test_licence_and_citation_are_present():
    licence = (ROOT / "LICENSE").read_text()
    assert licence.startswith("MIT License") and "the motionlab authors" in licence
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert 'license = { text = "MIT" }' in pyproject
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert citation["cff-version"] == "1.2.0" and citation["license"] == "MIT"
    ids = {i["value"] for ref in citation["references"] for i in ref["identifiers"]}
    assert ids == {"arXiv:2411.19527", "arXiv:2407.14502"}
    assert "@software{motionlab2026" in README and "arXiv:2411.19527" in README and "chi2024m2d2m" in README


def test_readme_and_tool_quote_the_one_record_of_build_times():
    builds = cold_builds(ROOT)
    assert len(builds) >= 2 and builds[0].cpu.startswith("AMD EPYC Zen 3")  # slowest first
    tests = cold_tests(ROOT)
    assert tests, "the README's time for make test is recorded too"
    flat = " ".join(README.split())
    quoted = set(_BUILD_PHRASE.findall(flat))
    assert quoted == {r.phrase() for r in builds + tests}, "README.md quotes build times not in cold_builds.json"
    # the intro teaches; build times belong to the README and CONTRIBUTING.md
    assert not _BUILD_PHRASE.findall(" ".join(INTRO.split())), "book/intro.md quotes build times"
    make_test = flat[flat.index("`make test` is") :].split(". ")[0]
    assert all(t.phrase() in make_test for t in tests)  # quoted where make test is described, not make book
    assert all(build_phrase(b, ROOT) in cold_build_line(ROOT) for b in builds)
    # a build that trained fewer models than today's plan is quoted with its time predicted today
    assert all(build_phrase(b, ROOT) in flat for b in builds), "README.md quotes a build without today's prediction"


def test_train_book_prints_the_recorded_build_times(tmp_path, monkeypatch, capsys):
    from motionlab import cli

    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)  # outside the repository: nothing is recorded, the build times still come from it
    monkeypatch.setattr("motionlab.build.book_models.book_jobs", lambda profile, **_: [])
    monkeypatch.setattr("motionlab.build.plan.run_plan", lambda plan, workers: [])
    args = cli.build_parser().parse_args(["train", "book", "--profile", "laptop"])
    args.settings = cli._settings(args)
    assert cli._train_book(args, {}) == 0
    out = capsys.readouterr().out
    assert all(b.phrase() in out for b in cold_builds(ROOT))


def test_the_recorded_builds_match_their_per_model_records():
    from motionlab.build.book_models import book_jobs
    from motionlab.build.plan import Job, expected_wall_seconds

    record = json.loads((ROOT / "book" / "data" / "build_times" / "cold_builds.json").read_text())
    for build in record["builds"] + record["tests"]:
        assert set(build) <= {"cpu", "precision", "minutes", "commit", "date", "note"}
        assert build["precision"] in ("fp32", "bf16") and 0 < build["minutes"] < 600
    zen3 = next(b for b in cold_builds(ROOT) if b.commit)
    history = ROOT / "book" / "data" / "build_times" / "history"
    training = json.loads((history / f"{zen3.commit}-zen3-fp32-training.json").read_text())
    chapters = json.loads((history / f"{zen3.commit}-zen3-fp32.json").read_text())
    plan = [Job(j.name, print, j.after, training[j.name]["seconds"]) for j in book_jobs("laptop") if j.name in training]
    trained_and_executed = expected_wall_seconds(plan, 2) + chapters["wall_seconds"]
    # the whole build adds setting up .venv and rendering to the two recorded steps, so it lasts a little longer
    assert trained_and_executed / 60 <= zen3.minutes <= trained_and_executed / 60 + 15


def test_a_build_of_an_older_plan_is_predicted_with_todays_models(tmp_path):
    from motionlab.build.book_models import book_jobs
    from motionlab.build.plan import expected_wall_seconds

    history = tmp_path / "book" / "data" / "build_times" / "history"
    history.mkdir(parents=True)
    plan = book_jobs("laptop", precision="fp32")
    # a CPU exactly twice as slow as the estimates, which trained every model but the x-prediction lever
    trained = {job.name: {"seconds": 2 * job.estimate_s} for job in plan if job.name != "discord/rvq-xpred"}
    (history / "abc1234-zen3-fp32-training.json").write_text(json.dumps(trained))
    build = ColdBuild("AMD EPYC Zen 3, AVX2 only", "fp32", 60.0, commit="abc1234")
    change = plan_change(build, tmp_path)
    assert change is not None and change.added == ("discord/rvq-xpred",)
    doubled = [replace(job, estimate_s=2 * job.estimate_s) for job in plan]
    grown = expected_wall_seconds(doubled, 2) - expected_wall_seconds([j for j in doubled if j.name in trained], 2)
    assert change.minutes == pytest.approx(60.0 + grown / 60) and grown > 0
    assert build_phrase(build, tmp_path) == (
        f"about 60 min on an AMD EPYC Zen 3, AVX2 only (fp32) without discord/rvq-xpred "
        f"({round(change.minutes)}+ min with it, predicted)"
    )
    trained["discord/rvq-xpred"] = {"seconds": 1.0}  # today's plan: quoted as measured
    (history / "abc1234-zen3-fp32-training.json").write_text(json.dumps(trained))
    assert plan_change(build, tmp_path) is None and build_phrase(build, tmp_path) == build.phrase()
    assert plan_change(ColdBuild("a CPU", "fp32", 60.0), tmp_path) is None  # no commit: no per-model record to read


def test_a_build_reads_as_the_pages_quote_it(tmp_path):
    build = ColdBuild("AMD EPYC Zen 3, AVX2 only", "fp32", 43.8)
    assert build.phrase() == "about 44 min on an AMD EPYC Zen 3, AVX2 only (fp32)"
    assert cold_builds(tmp_path) == [] and cold_build_line(tmp_path) == ""  # no record: nothing is claimed


def test_the_intro_says_where_to_start_and_what_comes_after():
    assert "## Start here" in INTRO
    flat = " ".join(INTRO.split())
    assert "01 → 02 → 03 → 04 → 05 → 06" in flat and "01 → 02 → 06 → 07 → 08 → 09" in flat
    assert "**After the book you can:**" in INTRO
    assert '.venv/bin/motionlab generate "a person waves" --profile smoke --out wave.html' in INTRO
    assert "| read (min) | cold / warm (min) |" in INTRO


def test_the_picture_tool_spreads_frames_and_refuses_smoke_motions(tmp_path, capsys):
    spec = importlib.util.spec_from_file_location("front_picture", ROOT / "tools" / "front_picture.py")
    front_picture = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(front_picture)
    assert front_picture.frame_indices(120, 6) == [0, 24, 48, 71, 95, 119]
    assert front_picture.frame_indices(3, 6) == [0, 1, 2]
    import numpy as np

    motion = tmp_path / "wave.npy"
    np.save(motion, np.zeros((40, 263), dtype=np.float32))
    (tmp_path / "wave.npy.json").write_text(json.dumps({"text": "a person waves", "profile": "smoke", "seed": "0"}))
    assert front_picture.main([str(motion), "--out", str(tmp_path / "front.png")]) == 2
    assert "only shows that the code runs" in capsys.readouterr().err and not (tmp_path / "front.png").exists()
