"""The scale study (issue 47): a multiple of the laptop budget changes only the training budgets; the experiment runs
end to end at the smoke profile, stops between points and continues; its records read back into the claims table,
and a record of other configs is set aside."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from motionlab import sizes
from motionlab.evaluation.scale import check_point, point_changes, point_configs, scaled_budgets, training_steps
from motionlab.report.gpu import load_gpu_runs
from motionlab.report.render import claims_table
from motionlab.report.scale import FOLDER, load_scale_study, scale_study_note, scale_verdicts, study_scale
from motionlab.report.spread import embedded_data_folder
from motionlab.results import CLAIMS
from motionlab.studies.scale import (
    Point,
    Rates,
    auto_batch_factor,
    measured_rates,
    plan_lines,
    plan_point,
    point_seconds,
)

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "experiments" / "scale.py"


def _script():
    """experiments/scale.py as a module (for its argument checks, without a subprocess)."""
    spec = importlib.util.spec_from_file_location("scale_experiment", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _run(*args: str, home: Path, **variables: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "MOTIONLAB_HOME": str(home), "PYTHONPATH": str(REPO / "src"), **variables}
    env.pop("MOTIONLAB_PROFILE", None)
    command = [sys.executable, str(SCRIPT), *args]
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=900, cwd=REPO)
    assert done.returncode == 0, done.stderr[-3000:]
    return done


# ----------------------------------------------------------------------------------------- the multiples alone
def test_a_multiple_scales_steps_batch_and_warmup_and_nothing_else():
    before = {name: dict(getattr(sizes, name)["laptop"]) for name in ("TOKENIZER", "DENOISER", "EVALUATOR")}
    laptop = point_configs("discord", 1, 1, "laptop")["models"]
    scaled = point_configs("discord", 10, 8, "laptop")["models"]
    for name in ("tokenizer/rvq", "discord/rvq"):
        (steps, batch), (steps10, batch10) = training_steps(laptop[name]), training_steps(scaled[name])
        assert batch10 == 8 * batch and steps10 * batch10 == pytest.approx(10 * steps * batch, rel=1e-3)
    assert scaled["discord/rvq"]["warmup_steps"] == round(laptop["discord/rvq"]["warmup_steps"] / 8)  # same samples
    assert scaled["discord/rvq"]["width"] == laptop["discord/rvq"]["width"]  # the laptop's widths
    assert scaled["evaluator"] == laptop["evaluator"]  # one evaluator for every point
    t2m = point_configs("m2d2m", 30, 1, "laptop")["models"]["t2m/dynamic"]
    assert t2m["transformer"]["train_steps"] == 30 * 800 and t2m["warmup_steps"] == 100
    assert {name: dict(getattr(sizes, name)["laptop"]) for name in before} == before  # restored after the block
    assert sizes.DISCORD_VQ["laptop"] is sizes.DISCORD_ABLATION["laptop"]  # shared entries stay shared


def test_bad_points_are_refused():
    with pytest.raises(ValueError, match="power of two"):
        check_point(10, 3)
    with pytest.raises(ValueError, match="> 0"):
        check_point(0, 1)
    with pytest.raises(ValueError, match="sets none"), scaled_budgets(10, 1, "full"):
        pass
    with pytest.raises(ValueError, match="group must be one of"):
        point_configs("vq", 10)


def test_the_batch_grows_on_a_gpu_up_to_the_benchmarked_batch():
    (run,) = load_gpu_runs(REPO / "book" / "data" / "gpu")[-1:]
    assert auto_batch_factor(10, "discord", "laptop", "cpu", run) == 1
    assert auto_batch_factor(10, "discord", "laptop", "cuda", run) == 8  # the RVQ step was timed at 256 = 8 × 32
    assert auto_batch_factor(10, "m2d2m", "laptop", "cuda", run) == 2  # the text-to-motion step at 64 = 2 × 32
    assert auto_batch_factor(1, "m2d2m", "laptop", "cuda", run) == 1  # never fewer steps than the laptop's
    planned = {m.name: m for m in plan_point(Point("m2d2m", 10, 2), "laptop", Rates("bf16", run))}
    assert planned["t2m/dynamic"].steps == 4000 and planned["t2m/dynamic"].seconds == pytest.approx(4000 * 0.0982)
    assert planned["tokenizer/vq"].seconds is None and "no bf16 rate for it" in planned["tokenizer/vq"].why


def test_a_gpu_plan_counts_the_compile_time_where_the_run_compiles(monkeypatch):
    (run,) = load_gpu_runs(REPO / "book" / "data" / "gpu")[-1:]
    compile_s, step_ms = run.compile_seconds("discord"), run.step_ms("discord", "library train_step")
    monkeypatch.delenv("MOTIONLAB_COMPILE", raising=False)  # auto: DisCoRD's U-Net compiles on CUDA, nothing else
    planned = {m.name: m for m in plan_point(Point("discord", 10, 8), "laptop", Rates("bf16", run))}
    decoder = planned["discord/rvq"]
    assert decoder.seconds == pytest.approx(decoder.steps * step_ms / 1e3 + compile_s)
    assert decoder.why.endswith(f"; {compile_s:.0f} s of it compiling")
    assert "compiling" not in planned["tokenizer/rvq"].why
    measured = Rates("bf16", run, {("discord/rvq", decoder.batch): (10.0, "discord-x3")})
    (_, again) = plan_point(Point("discord", 10, 8), "laptop", measured)  # a point recorded here timed its compile
    assert again.seconds == pytest.approx(again.steps * 0.01) and "compiling" not in again.why
    monkeypatch.setenv("MOTIONLAB_COMPILE", "off")
    (_, off) = plan_point(Point("discord", 10, 8), "laptop", Rates("bf16", run))
    assert off.seconds == pytest.approx(off.steps * step_ms / 1e3)
    monkeypatch.setenv("MOTIONLAB_COMPILE", "on")
    rvq = plan_point(Point("discord", 10, 8), "laptop", Rates("bf16", run))[0]
    assert rvq.name == "tokenizer/rvq" and "did not measure" in rvq.why  # compiled, never timed compiling


def test_a_point_measured_here_predicts_the_next_better_than_the_benchmark():
    (run,) = load_gpu_runs(REPO / "book" / "data" / "gpu")[-1:]
    measured = {
        "group": "m2d2m",
        "multiple": 10.0,
        "device_type": "cuda",
        "precision": "bf16",
        "models": {
            "tokenizer/vq": {
                "steps": 10000,
                "batch": 64,
                "sittings": [{"steps": [0, 10000], "seconds": 50.0, "device": "cuda"}],
            },
            "t2m/dynamic": {"steps": 4000, "batch": 64, "sittings": []},  # trained before sittings were kept: untimed
        },
        "seconds": {"scoring": 90.0},
    }
    rates = measured_rates([measured], "cuda", "bf16", run)
    assert measured_rates([measured], "cuda", "fp32", run).steps == {}  # another precision is another machine
    planned = {m.name: m for m in plan_point(Point("m2d2m", 30, 2), "laptop", rates)}
    tokenizer = planned["tokenizer/vq"]
    assert tokenizer.seconds == pytest.approx(30000 * 0.005) and "measured in m2d2m-x10" in tokenizer.why
    assert planned["t2m/dynamic"].seconds == pytest.approx(12000 * 0.0982)  # still the benchmark's bound
    expected = sum(m.seconds for m in planned.values()) + 90.0
    assert point_seconds(Point("m2d2m", 30, 2), "laptop", rates) == pytest.approx(expected)


def test_a_model_trained_run_by_run_is_timed_over_its_sittings_on_that_device():
    """A model resumed over several runs times all of its steps, not the last run's; a sitting on another device or
    of unknown length (a checkpoint from before sittings were kept) times nothing."""
    sittings = [
        {"steps": [0, 1000], "seconds": None},
        {"steps": [1000, 4000], "seconds": 30.0, "device": "cuda"},
        {"steps": [4000, 5000], "seconds": 90.0, "device": "cpu"},
        {"steps": [5000, 10000], "seconds": 50.0, "device": "cuda"},
    ]
    record = {
        "group": "m2d2m",
        "multiple": 10.0,
        "device_type": "cuda",
        "precision": "bf16",
        "models": {
            "tokenizer/vq": {"steps": 10000, "batch": 64, "sittings": sittings},
            "t2m/dynamic": {
                "steps": 4000,
                "batch": 64,
                "sittings": [{"steps": [0, 4000], "seconds": 8.0, "device": "cuda"}],
            },
        },
        "seconds": {"scoring": 90.0},
    }
    steps = measured_rates([record], "cuda", "bf16").steps
    assert steps["tokenizer/vq", 64][0] == pytest.approx(1e3 * 80.0 / 8000)
    assert steps["t2m/dynamic", 64][0] == pytest.approx(2.0)
    assert measured_rates([record | {"device_type": "cpu"}], "cpu", "bf16").steps["tokenizer/vq", 64][0] == 90.0


def test_a_plan_counts_what_the_cache_trained_and_a_shared_model_once():
    """A model the cache has finished costs nothing, one with a checkpoint only its steps after it, and the RVQ that
    DisCoRD's point and the projection point share is planned once, by the point that trains it first."""
    from motionlab.studies.carry import config_key
    from motionlab.studies.scale import _configs

    rates = Rates("bf16", None, {("tokenizer/rvq", 32): (2.0, "x"), ("discord/rvq", 32): (4.0, "x")})
    rvq, decoder = (config_key(_configs(Point("discord", 100), "laptop")[n]) for n in ("tokenizer/rvq", "discord/rvq"))
    fresh = {m.name: m for m in plan_point(Point("discord", 100), "laptop", rates)}
    assert fresh["discord/rvq"].done == 0 and fresh["discord/rvq"].seconds == pytest.approx(400_000 * 4e-3)
    resumed = {m.name: m for m in plan_point(Point("discord", 100), "laptop", rates, {decoder: 100_000, rvq: math.inf})}
    assert resumed["tokenizer/rvq"].done == 200_000 and resumed["discord/rvq"].done == 100_000
    assert resumed["discord/rvq"].seconds == pytest.approx(300_000 * 4e-3)
    assert point_seconds(Point("discord", 100), "laptop", rates, {decoder: 100_000, rvq: math.inf}) == pytest.approx(
        300_000 * 4e-3
    )

    points = [Point("discord", 100), Point("projection", 100)]
    lines = "\n".join(plan_lines(points, "laptop", rates, progress={decoder: 100_000}))
    assert (
        "tokenizer/rvq: 200,000 steps × batch 32: 6.67 min (2 ms measured in x)" in lines
    )  # trained by discord-x100 ...
    assert "tokenizer/rvq: 200,000 steps × batch 32: trained by discord-x100 first" in lines  # ... not again
    assert "20.00 min for the 300,000 steps after the checkpoint at 100,000" in lines
    lines = "\n".join(plan_lines(points[1:], "laptop", rates, progress={rvq: math.inf}))
    assert "tokenizer/rvq: 200,000 steps × batch 32: in the cache" in lines


def test_bad_arguments_are_clear_errors(capsys):
    script = _script()
    for args, message in (
        (["--multiples", "0"], "--multiples must be > 0"),
        (["--batch-factor", "3"], "power of two"),
        (["--minutes", "-1"], "--minutes must be > 0"),
        (["--device", "tpu"], "--device must be"),
        (["--gpu-record", "/nonexistent.json"], "no such file"),
        (["--profile", "full"], "sets none"),
        (["--profile", "huge"], "--profile huge"),
    ):
        with pytest.raises(SystemExit) as exit_:
            script.main(args)
        assert exit_.value.code == 2 and message in capsys.readouterr().err


def test_the_book_holds_no_smoke_record_and_says_when_nothing_was_measured():
    """book/data/scale/ holds results only, never a smoke run's; without a GPU point the book says so, with the
    command a GPU run needs."""
    folder = REPO / "book" / "data" / "scale"
    for path in folder.rglob("*.json"):
        assert json.loads(path.read_text()).get("profile") != "smoke", path
    note = scale_study_note(None)
    assert "not yet measured on a GPU" in note and "experiments/scale.py --device cuda" in note


def test_the_recorded_points_measured_the_books_models_and_evaluations():
    """Every point under book/data/scale/ was trained and scored as the code would now; a change to a studied model
    or its evaluation fails here until the point is measured again."""
    study = load_scale_study("laptop")
    committed = list(embedded_data_folder(FOLDER).glob("*-x*.json"))
    assert study is not None and committed, "no scale record is committed for the current embedded data"
    assert not study.set_aside, "\n".join(study.set_aside)
    assert len(study.records) == len(committed)  # every committed file was read, none filtered out


# ----------------------------------------------------------------------------------- the smoke pipeline, end to end
@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """``--smoke`` run twice: first with a budget too small for more than one point (it stops), then to the end."""
    home, out = tmp_path_factory.mktemp("home"), tmp_path_factory.mktemp("scale")
    first = _run("--smoke", "--minutes", "0.001", "--out", str(out), home=home)
    first_files = sorted(p.name for p in out.glob("*.json"))
    second = _run("--smoke", "--out", str(out), home=home)
    return {"home": home, "out": out, "first": first, "first_files": first_files, "second": second}


def test_a_run_stops_between_points_and_the_next_continues(smoke):
    assert smoke["first_files"] == ["discord-x0.5.json"]  # the first pending point, then out of time
    assert "stopping: 5 point(s) left" in smoke["first"].stdout and "run again to continue" in smoke["first"].stdout
    assert "discord-x0.5: recorded already" in smoke["second"].stderr  # not retrained, not rescored
    assert "all 6 point(s) recorded" in smoke["second"].stdout
    names = sorted(p.name for p in smoke["out"].glob("*.json"))
    assert names == [f"{g}-x{m}.json" for g in ("discord", "m2d2m", "projection") for m in ("0.5", "1")]


def test_every_run_prints_its_plan_first(smoke):
    plan = smoke["first"].stdout.splitlines()
    assert plan[0].startswith("scale study plan, profile smoke") and "no GPU benchmark" in plan[1]  # a CPU run
    assert any("t2m/dynamic: 150 steps × batch 16: not predicted" in line for line in plan)
    # planned for a bare GPU machine in bf16 (possible without one): the benchmark's measured step times
    out, bare = str(smoke["home"] / "none"), smoke["home"] / "bare"
    gpu = _run("--smoke", "--plan", "--device", "cuda", "--out", out, home=bare, MOTIONLAB_PRECISION="bf16")
    gpu = gpu.stdout
    assert "the GPU benchmark 2026-12-04-h200-note.json (NVIDIA H200)" in gpu.splitlines()[1]
    assert any("t2m/dynamic: 150 steps × batch 16" in line and "98.2 ms" in line for line in gpu.splitlines())
    assert any("tokenizer/vq" in line and "not predicted" in line for line in gpu.splitlines())
    # the second run predicted from the point the first one measured on this CPU
    assert "tokenizer/rvq: 40 steps × batch 8" in smoke["second"].stdout
    assert "measured in discord-x0.5" in smoke["second"].stdout
    again = _run("--smoke", "--plan", "--out", str(smoke["out"]), home=smoke["home"]).stdout
    assert "discord-x0.5 (batch ×1): recorded" in again and "to do: ~0.0 min" in again


def test_a_record_carries_the_machine_and_its_configs(smoke):
    record = json.loads((smoke["out"] / "m2d2m-x1.json").read_text())
    assert {"device", "precision", "torch", "commit", "data", "configs", "values", "tables"} <= set(record)
    assert record["device_type"] == "cpu" and record["multiple"] == 1.0 and record["batch_factor"] == 1
    assert record["models"]["t2m/dynamic"] == record["models"]["t2m/dynamic"] | {"steps": 150, "batch": 16}
    assert set(record["models"]["t2m/dynamic"]) == {"steps", "batch", "sittings"}  # the rest derives from sittings
    (sitting,) = record["models"]["t2m/dynamic"]["sittings"]  # a fresh cache: trained in one process, this one
    assert sitting["steps"] == [0, 150] and sitting["device"] == "cpu" and sitting["seconds"] > 0
    assert point_changes(record, "smoke") == []


def test_the_records_read_back_into_the_claims_table(smoke, tmp_path, monkeypatch):
    from motionlab import results

    monkeypatch.setenv(results.RESULTS_ENV, str(tmp_path / "results"))
    study = load_scale_study("smoke", smoke["out"])
    assert study.multiples == [0.5, 1.0] and not study.set_aside
    table = claims_table("smoke", scale=study, budget=None, spread=None, gpu=None)  # the scale study alone
    lines = {row.rule: row.scale for row in table}
    sjpe = lines["discord/sjpe_rf < discord/sjpe_ff"]
    assert sjpe.startswith("By training samples (scale study, laptop widths, ") and "0.5×: " in sjpe
    assert lines["projection/heldout_mse_stacked < projection/heldout_mse_repeat_linear"]
    assert lines["transitions/fid_dynamic < transitions/fid_uniform"] and lines["tps/jerk_tps < tps/jerk_independent"]
    assert lines["tps/jerk_gt_concat > tps/jerk_gt_single"] == ""  # real motions only: no budget moves them
    assert lines["discord/time_steps2 < discord/time_steps16"] == ""  # the study times nothing
    assert "not yet measured on a GPU" in scale_study_note(study)  # smoke ran on the CPU
    assert "By training samples" in table.html() and "By training samples" in table.to_markdown()
    verdicts = scale_verdicts(table.rows, study)
    assert verdicts.columns == ("this build", "0.5×", "1×")
    row = verdicts.rows["DisCoRD: Reconstruction FID improves with the flow decoder."]
    assert row["this build"] == "not yet measured" and row["1×"] in ("holds", "does not hold", "inconclusive")
    with pytest.raises(TypeError, match="scale must be a ScaleStudy"):
        claims_table("smoke", scale=5, budget=None, spread=None)


def test_a_record_scored_by_another_evaluation_is_set_aside(smoke, tmp_path):
    """The same models scored another way (here: more sampling seeds) are another measurement: a point records its
    evaluations' configs as well as its models', and the reader compares both."""
    folder = tmp_path / "scale"
    folder.mkdir()
    record = json.loads((smoke["out"] / "discord-x1.json").read_text())
    evaluation = record["configs"]["evaluations"]["reconstruction"]
    evaluation["repeats"] += 1
    (folder / "discord-x1.json").write_text(json.dumps(record))
    with pytest.warns(UserWarning, match="every record in"):
        study = load_scale_study("smoke", folder)
    assert study.set_aside and "evaluations.reconstruction.repeats" in study.set_aside[0]


def test_a_record_of_other_configs_is_set_aside(smoke, tmp_path):
    folder = tmp_path / "scale"
    folder.mkdir()
    for path in smoke["out"].glob("discord-*.json"):
        (folder / path.name).write_text(path.read_text())
    record = json.loads((folder / "discord-x1.json").read_text())
    record["configs"]["models"]["discord/rvq"]["width"] *= 2  # trained wider than the code's smoke decoder
    (folder / "discord-x1.json").write_text(json.dumps(record))
    study = load_scale_study("smoke", folder)
    assert study.multiples == [0.5] and len(study.set_aside) == 1
    assert study.set_aside[0].startswith("discord-x1.json") and "models.discord/rvq.width" in study.set_aside[0]
    claim = next(c for c in CLAIMS if c.rule.describe() == "discord/fid_rf < discord/fid_ff")
    assert sorted(study_scale(claim, study).verdicts) == [0.5]  # the stale point joins no verdict
    (folder / "discord-x0.5.json").write_text(json.dumps({**record, "multiple": 0.5}))
    with pytest.warns(UserWarning, match="every record in"):
        assert load_scale_study("smoke", folder).records == {}


# ------------------------------------------------------------------------------ the model cache carried between runs
def _artefact(root: Path, family: str, key: str, config: dict, size: int = 10) -> Path:
    folder = root / "models" / family / "laptop" / key
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps({"name": family, "config": config}))
    (folder / "model.safetensors").write_bytes(bytes(size))
    return folder


def test_the_carried_cache_holds_what_pending_points_need_and_newest_checkpoints(tmp_path, monkeypatch):
    from motionlab.studies import carry

    cache = tmp_path / "cache"
    _artefact(cache, "rvq", "aaa", {"steps": 10, "shape": (1, 2)})  # a pending point loads it (tuples as lists)
    _artefact(cache, "vq", "bbb", {"steps": 20})  # only finished points used it
    work = cache / "models" / "discord" / "laptop" / "ccc.work"
    for step in (100, 200):
        (work / f"step_{step:08d}").mkdir(parents=True)
        (work / f"step_{step:08d}" / "model.safetensors").write_bytes(bytes([step % 256]) * 4)
    (work / "config.json").write_text(json.dumps({"name": "discord", "config": {"steps": 400}}))  # what it trains
    (cache / "models" / "vq" / "laptop" / ".ddd.tmp-1234").mkdir()  # a half-written artefact
    folders = carry.carried_folders(cache, [{"steps": 10, "shape": [1, 2]}])
    assert [f.name for f in folders] == ["ccc.work", "aaa"]
    assert carry.find_artefact(cache, {"steps": 20}).name == "bbb" and carry.find_artefact(cache, {"x": 1}) is None
    progress = carry.cached_progress(cache)  # a finished model: all its steps; one in progress: its checkpoint's
    assert progress == {carry.config_key(c): n for c, n in (({"steps": 400}, 200), ({"steps": 10, "shape": [1, 2]},
                        math.inf), ({"steps": 20}, math.inf))}  # fmt: skip
    bf16 = cache / "models" / "vq" / "laptop" / "eee"  # the same config trained in another precision
    bf16.mkdir()
    (bf16 / "config.json").write_text(json.dumps({"config": {"steps": 30}, "extra": {"precision": "bf16"}}))
    assert carry.config_key({"steps": 30}) in carry.cached_progress(cache, "bf16")
    assert carry.config_key({"steps": 30}) not in carry.cached_progress(cache, "fp32")
    assert carry.find_artefact(cache, {"steps": 30}, "bf16") == bf16
    assert carry.find_artefact(cache, {"steps": 30}, "fp32") is None
    shutil.rmtree(bf16)

    out = tmp_path / "out"
    parts, line = carry.pack_cache(cache, folders, out)
    assert [p.name for p in parts] == ["scale-cache.tgz.00"] and line.startswith("carried 2 model folder(s) in 1 part")
    fresh = tmp_path / "fresh"
    _artefact(fresh, "rvq", "aaa", {"steps": 10}, size=3)  # already finished here: kept as it is
    assert carry.unpack_cache(out, fresh) == ["models/discord/laptop/ccc.work"]
    assert (fresh / "models" / "rvq" / "laptop" / "aaa" / "model.safetensors").read_bytes() == bytes(3)
    unpacked_work = sorted(p.name for p in (fresh / "models" / "discord" / "laptop" / "ccc.work").iterdir())
    assert unpacked_work == ["config.json", "step_00000200"]  # the newest checkpoint and what it trains
    assert carry.unpack_cache(tmp_path / "nothing", fresh) == []

    small = carry.pack_cache(cache, folders, tmp_path / "small", max_parts=99, part_bytes=64)[0]
    assert len(small) > 1 and all(p.stat().st_size <= 64 for p in small)  # a job's own per-file output limit
    with pytest.raises(ValueError, match="part_bytes"):
        carry.pack_cache(cache, folders, out, part_bytes=0)
    monkeypatch.setattr(carry, "PART_BYTES", 64)  # the default part: an archive too large for one output file
    parts, line = carry.pack_cache(cache, folders, out, max_parts=1)
    assert parts == [] and "not carried" in line and not list(out.iterdir())  # the old parts are gone too
    assert len(carry.pack_cache(cache, folders, out, max_parts=99)[0]) > 1  # cut into parts, joined on unpacking
    assert carry.unpack_cache(out, tmp_path / "again") == ["models/discord/laptop/ccc.work", "models/rvq/laptop/aaa"]


def test_a_run_carries_the_models_the_next_lease_loads(tmp_path):
    """Two leases of the smoke pipeline on two bare machines (two empty homes): the first records one point and
    carries out the tokenizer and evaluator the next point needs; the second carries them in and only loads them."""
    out, carried = tmp_path / "records", tmp_path / "carried"
    first = _run(
        "--smoke", "--groups", "discord", "projection", "--multiples", "0.5", "--minutes", "0.001",
        "--out", str(out), "--carry-out", str(carried), home=tmp_path / "first",
    )  # fmt: skip
    assert sorted(p.name for p in out.glob("*.json")) == ["discord-x0.5.json"]
    packed = first.stdout.splitlines()[-1]  # the tokenizer, the evaluator, and the smoke decoder (its config is
    assert packed.startswith("carried 3 model folder(s)")  # chapter 04's stacked one's at the smoke profile)
    assert all(f"{family}/smoke/" in packed for family in ("rvq", "text_motion_evaluator", "discord"))
    second = _run(
        "--smoke", "--groups", "discord", "projection", "--multiples", "0.5",
        "--out", str(out), "--carry-in", str(carried), home=tmp_path / "second",
    )  # fmt: skip
    assert "projection-x0.5: loading tokenizer/rvq" in second.stderr
    loaded = {line.split(": loading ")[1] for line in second.stderr.splitlines() if ": loading " in line}
    trained = {line.split(": training ")[1] for line in second.stderr.splitlines() if ": training " in line}
    assert loaded == {"tokenizer/rvq", "discord/rvq-stacked"} and trained == {
        "discord/rvq-repeat",
        "discord/rvq-transposed",
    }
    record = json.loads((out / "projection-x0.5.json").read_text())
    assert all(record["models"][name]["sittings"] for name in loaded | trained)  # a loaded model keeps its time


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="POSIX signals")
def test_a_machines_time_limit_stops_a_run_like_ctrl_c_and_the_carry_is_still_packed(tmp_path):
    """A SIGTERM (what a machine's time limit sends when the lease's own SIGINT came too late) ends the run as
    "interrupted", and the models the next run needs are packed on the way out."""
    out, carried = tmp_path / "records", tmp_path / "carried"
    env = {**os.environ, "MOTIONLAB_HOME": str(tmp_path / "home"), "PYTHONPATH": str(REPO / "src")}
    env.pop("MOTIONLAB_PROFILE", None)
    command = [sys.executable, str(SCRIPT), "--smoke", "--groups", "discord", "--multiples", "0.5"]
    command += ["--out", str(out), "--carry-out", str(carried)]
    proc = subprocess.Popen(command, env=env, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stderr:  # under way: the tokenizer is trained, the decoder's training begins
            if "training discord/rvq" in line:
                break
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        proc.kill()
    assert proc.returncode == 130, stderr[-3000:]
    assert "interrupted: 1 point(s) left (discord-x0.5)" in stdout
    packed = stdout.splitlines()[-1]
    assert packed.startswith("carried ") and "rvq/smoke/" in packed and list(carried.glob("scale-cache.tgz.*"))
    assert not list(out.glob("*.json"))
