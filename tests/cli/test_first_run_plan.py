"""First use: every command that would train says what it will train, in which order and for how long."""

from __future__ import annotations

import pytest

from motionlab import cli
from motionlab.build.book_models import ESTIMATES_S, book_jobs, jobs_for
from motionlab.train.cache import NotCached, check_may_train


@pytest.fixture
def empty_home(tmp_path, monkeypatch):
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))
    return tmp_path / "home"


def test_generate_on_an_empty_cache_announces_every_model_in_order(empty_home, capsys):
    cli._announce_training("laptop", ["t2m/dynamic", "discord/vq"])
    err = capsys.readouterr().err
    assert err.startswith("note: training 4 models first: about")
    assert err.index("data") < err.index("tokenizer/vq") < err.index("discord/vq") < err.index("t2m/dynamic")
    expected = (
        ESTIMATES_S["laptop"]["data"]
        + ESTIMATES_S["laptop"]["tokenizer"]
        + ESTIMATES_S["laptop"]["discord_short"]  # discord/vq: the short budget
        + ESTIMATES_S["laptop"]["t2m"]
    ) / 60
    assert f"first: about {expected:.1f} min (" in err and "add --profile smoke" in err
    assert err.count(f"{expected:.1f} min") == 1  # one worker: one number, not the same one twice
    assert not list(empty_home.rglob("*.npy")), "announcing must not generate or train anything"


def test_nothing_is_announced_when_everything_is_cached(empty_home, capsys, monkeypatch):
    monkeypatch.setattr("motionlab.build.book_models.is_cached", lambda run: True)
    cli._announce_training("smoke", ["t2m/dynamic"])
    assert capsys.readouterr().err == ""


def test_evaluation_models_follow_the_task_and_decoder():
    from motionlab.evaluation import ReconstructionConfig, TextToMotionConfig

    assert cli._evaluation_models("reconstruction", ReconstructionConfig()) == [
        "tokenizer/rvq",
        "evaluator",
        "discord/rvq",
    ]
    assert cli._evaluation_models("reconstruction", ReconstructionConfig(decoder="vq")) == ["tokenizer/vq", "evaluator"]
    assert cli._evaluation_models("t2m", TextToMotionConfig(decoder="discord")) == [
        "t2m/dynamic",
        "evaluator",
        "discord/vq",
    ]


def test_jobs_for_adds_what_a_model_needs_and_rejects_unknown_names():
    assert [j.name for j in jobs_for(["discord/rvq"], "smoke")] == ["data", "tokenizer/rvq", "discord/rvq"]
    with pytest.raises(ValueError, match="unknown models"):
        jobs_for(["discord/xyz"], "smoke")
    full = {j.name for j in book_jobs("full")}
    assert {"t2m/distance-l2", "t2m/distance-cosine"} <= full  # chapter 08's full-profile ablation is in the plan
    assert not any(name.startswith("t2m/distance") for name in (j.name for j in book_jobs("laptop")))


def test_no_train_mode_refuses_to_train(monkeypatch):
    monkeypatch.setenv("MOTIONLAB_NO_TRAIN", "1")
    with pytest.raises(NotCached, match="motionlab train book"):
        check_may_train("model 'x'")


def test_a_failing_probe_does_not_stop_the_command(empty_home, capsys, monkeypatch):
    monkeypatch.setattr("motionlab.data.load_dataset", lambda *a, **k: None)  # a broken dataset: the command says so
    cli._announce_training("smoke", ["tokenizer/rvq"])
    assert capsys.readouterr().err == ""


def test_the_command_uses_the_dataset_its_plan_probe_loaded(empty_home, capsys, monkeypatch):
    loads = []
    monkeypatch.setattr("motionlab.data.load_dataset", lambda *a, **k: loads.append(object()) or loads[-1])
    with cli._probe_then_run():
        cli._announce_training("smoke", ["tokenizer/rvq"])  # probes "data" (loads it), then fails: silent
        assert cli._command_dataset(None, "smoke") is loads[0] and len(loads) == 1
    with cli._probe_then_run():  # a new command reads the data again (the cache folder may have changed)
        assert cli._command_dataset(None, "smoke") is loads[1] and len(loads) == 2
    assert capsys.readouterr().err == ""


def test_reusing_the_probe_still_announces_every_missing_model(empty_home, capsys):
    with cli._probe_then_run():
        cli._announce_training("smoke", ["tokenizer/rvq", "evaluator", "discord/rvq"])
    err = capsys.readouterr().err
    assert err.startswith("note: training 4 models first: about") and "discord/rvq" in err
    assert not list(empty_home.rglob("*.npy")), "announcing must not generate or train anything"
