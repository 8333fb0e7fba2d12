"""Outputs are never lost and inputs are judged before any work: every refusal here happens before a model
is trained or a dataset generated (the isolated cache stays empty), and every failure is one line."""

from __future__ import annotations

import numpy as np
import pytest

from motionlab.cli import main
from motionlab.representation import Normalizer

SMOKE = ["--profile", "smoke", "--device", "cpu"]


def nothing_trained(cache) -> bool:
    return not (cache / "models").exists() and not (cache / "data").exists()


def one_error_line(err: str, *needles: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def test_generate_never_overwrites_without_force(tmp_path, isolated_cache, capsys):
    out = tmp_path / "wave.npy"
    out.write_bytes(b"precious")
    assert main(["generate", "a person waves", "--out", str(out), *SMOKE]) == 2
    one_error_line(capsys.readouterr().err, "exists; pass --force")
    assert out.read_bytes() == b"precious" and nothing_trained(isolated_cache)


@pytest.mark.parametrize("command", ["generate", "convert"])
def test_an_output_that_is_a_folder_is_refused_before_work(command, tmp_path, isolated_cache, capsys):
    folder = tmp_path / "dir.bvh"
    folder.mkdir()
    src = tmp_path / "in.npy"
    np.save(src, np.zeros((10, 263), np.float32))
    argv = (
        ["generate", "a person waves", "--out", str(folder), *SMOKE]
        if command == "generate"
        else ["convert", str(src), str(folder)]
    )
    assert main(argv) == 2
    one_error_line(capsys.readouterr().err, "is a folder")
    assert nothing_trained(isolated_cache)


@pytest.mark.parametrize(
    "options, message",
    [
        (["--length", "100000"], "longest motion the model was trained on, 196 frames"),
        (["--length", "42"], "multiples of 4"),
        (["--T-s", "5"], "needs two or more texts"),
        (["--out", "x.gif"], "unknown extension"),
    ],
)
def test_generate_options_are_judged_before_work(options, message, tmp_path, isolated_cache, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = ["generate", "a person waves", *SMOKE, "--out", "wave.npy", *options]
    assert main(argv) == 2
    one_error_line(capsys.readouterr().err, message)
    assert nothing_trained(isolated_cache) and not (tmp_path / "wave.npy").exists()


def test_a_switch_step_beyond_the_models_steps_is_refused_before_training(tmp_path, isolated_cache, capsys):
    argv = ["generate", "a person waves", "a person sits", *SMOKE, "--out", str(tmp_path / "w.npy"), "--T-s", "1000"]
    assert main(argv) == 2  # it was found only after training the models
    one_error_line(capsys.readouterr().err, "--T-s must be in [0, T=100]")
    assert nothing_trained(isolated_cache)


@pytest.mark.parametrize("seed", ["-1", "99999999999999999999", "one"])
def test_a_seed_torch_cannot_take_is_refused_when_the_options_are_read(seed, tmp_path, isolated_cache, capsys):
    with pytest.raises(SystemExit) as refused:  # argparse's own error: usage line, then the reason
        main(["generate", "a person waves", *SMOKE, "--out", str(tmp_path / "w.npy"), "--seed", seed])
    assert refused.value.code == 2 and "argument --seed: must be" in capsys.readouterr().err
    assert nothing_trained(isolated_cache)


def test_make_embedded_refuses_zero_clips(tmp_path, isolated_cache, capsys):
    assert main(["data", "make-embedded", "--profile", "smoke", "--out", str(tmp_path / "d"), "--clips", "0"]) == 2
    one_error_line(capsys.readouterr().err, "n_clips must be an integer >= 42")
    assert not (tmp_path / "d").exists()


def test_make_embedded_clips_without_out_is_rejected(isolated_cache, capsys):
    assert main(["data", "make-embedded", "--profile", "smoke", "--clips", "60"]) == 2
    one_error_line(capsys.readouterr().err, "--clips needs --out")
    assert nothing_trained(isolated_cache)


def test_evaluate_sizes_are_bounded_by_memory(tmp_path, isolated_cache, capsys, monkeypatch):
    import motionlab.evaluation as evaluation

    monkeypatch.setattr(evaluation, "available_memory", lambda: 4 * 2**30)
    assert main(["evaluate", "multi", "--instances", "100000", *SMOKE]) == 2
    one_error_line(capsys.readouterr().err, "--instances 100000", "GiB", "4.0 GiB available")
    assert main(["evaluate", "t2m", "--multimodality", "--mm-repeats", "100000", *SMOKE]) == 2
    one_error_line(capsys.readouterr().err, "--mm-repeats 100000")
    assert nothing_trained(isolated_cache)


def test_unwritable_destinations_and_cache_fail_before_work(tmp_path, isolated_cache, capsys, monkeypatch):
    import os

    src = tmp_path / "in.npy"
    np.save(src, np.zeros((10, 263), np.float32))
    locked = tmp_path / "locked"
    locked.mkdir()
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if str(p) == str(locked) else real_access(p, mode))
    assert main(["convert", str(src), str(locked / "out.bvh")]) == 2  # root ignores chmod: pretend instead
    one_error_line(capsys.readouterr().err, "cannot write to the folder")
    assert main(["generate", "a person waves", "--out", str(locked / "wave.npy"), *SMOKE]) == 2
    one_error_line(capsys.readouterr().err, "cannot write to the folder")
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    monkeypatch.setenv("MOTIONLAB_HOME", str(blocker / "home"))  # a cache that cannot be created
    assert main(["train", "vq", *SMOKE]) == 2
    one_error_line(capsys.readouterr().err, "cache")


def test_ctrl_c_during_training_is_one_line_saying_how_to_resume(tmp_path, isolated_cache, capsys, monkeypatch):
    import motionlab.cli as cli

    def interrupted_training(*args, **kwargs):
        work = isolated_cache / "models" / "rvq" / "smoke" / "abc123.work"
        (work / "step_00001500").mkdir(parents=True)
        (work / "step_00001500" / "meta.json").write_text("{}")
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_trained_model", interrupted_training)
    monkeypatch.setattr("motionlab.data.load_dataset", lambda *a, **k: None)
    assert main(["train", "rvq", *SMOKE]) == 130
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "'rvq' (smoke)" in err and "same command resumes" in err and "step 1,500" in err


def test_warnings_are_one_line(shared_data, tmp_path, capsys):
    take = shared_data / "cmu-bvh" / "131_02.bvh"
    assert main(["convert", str(take), str(tmp_path / "flat.npy"), "--up", "z", "--end", "40"]) == 0
    err = capsys.readouterr().err
    warning = [line for line in err.splitlines() if line.startswith("warning: ")]
    assert len(warning) == 1 and "--up y" in warning[0] and "MotionWarning" not in err


def _dataset(root, mean=None, std=None, clip=None):
    for sub in ("new_joint_vecs", "texts"):
        (root / sub).mkdir()
    for split, clip_id in (("train", "a"), ("val", "b"), ("test", "c")):
        feats = np.zeros((50, 263), dtype=np.float32) if clip is None or clip_id != "c" else clip
        np.save(root / "new_joint_vecs" / f"{clip_id}.npy", feats)
        (root / "texts" / f"{clip_id}.txt").write_text("a person stands#a/DET person/NOUN stand/VERB#0.0#0.0\n")
        (root / f"{split}.txt").write_text(clip_id + "\n")
    Normalizer(np.zeros(263), np.ones(263)).save(root)
    if mean is not None:
        np.save(root / "Mean.npy", mean)
    if std is not None:
        np.save(root / "Std.npy", std)


@pytest.mark.parametrize(
    "fault, message",
    [
        ({"mean": np.full(263, np.nan, np.float32)}, "Mean.npy contains 263 NaN or inf"),
        ({"std": np.zeros(263, np.float32)}, "Std.npy has 263 zero or negative"),
        ({"clip": np.full((50, 263), np.nan, np.float32)}, "new_joint_vecs/c.npy contains NaN"),
    ],
)
def test_data_check_checks_statistics_and_values(fault, message, tmp_path, capsys):
    _dataset(tmp_path, **fault)
    assert main(["data", "check", str(tmp_path)]) == 1
    assert message in capsys.readouterr().err


def test_data_check_reports_an_unreadable_clip(tmp_path, capsys):
    _dataset(tmp_path)
    path = tmp_path / "new_joint_vecs" / "b.npy"
    path.write_bytes(path.read_bytes()[:500])
    assert main(["data", "check", str(tmp_path)]) == 1
    assert "b.npy cannot be read" in capsys.readouterr().err
