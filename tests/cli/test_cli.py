import argparse
import json
import re
import shlex
import subprocess
import sys

import numpy as np

from motionlab.cli import build_parser, main
from motionlab.io import read_bvh
from motionlab.representation import Normalizer


def test_data_check_reports_missing_pieces(tmp_path, capsys):
    (tmp_path / "new_joint_vecs").mkdir()
    assert main(["data", "check", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "missing texts" in err and "missing Mean.npy" in err and "missing split file train.txt" in err


def test_data_check_accepts_a_complete_folder(tmp_path, capsys):
    for sub in ("new_joint_vecs", "texts"):
        (tmp_path / sub).mkdir()
    feats = np.zeros((50, 263), dtype=np.float32)
    for split, clip_id in (("train", "a"), ("val", "b"), ("test", "c")):
        np.save(tmp_path / "new_joint_vecs" / f"{clip_id}.npy", feats)
        (tmp_path / "texts" / f"{clip_id}.txt").write_text("a person stands#a/DET person/NOUN stand/VERB#0.0#0.0\n")
        (tmp_path / f"{split}.txt").write_text(clip_id + "\n")
    Normalizer(np.zeros(263), np.ones(263)).save(tmp_path)
    assert main(["data", "check", str(tmp_path)]) == 0
    assert "complete" in capsys.readouterr().out


def test_module_entry_point_and_help():
    out = subprocess.run([sys.executable, "-m", "motionlab", "--help"], capture_output=True, text=True)
    assert out.returncode == 0 and "data" in out.stdout
    bad = subprocess.run([sys.executable, "-m", "motionlab", "data", "check"], capture_output=True, text=True)
    assert bad.returncode == 2 and "path" in bad.stderr


def test_make_embedded_writes_a_checked_dataset(tmp_path, capsys):
    out = tmp_path / "embedded"
    assert main(["data", "make-embedded", "--out", str(out), "--clips", "42", "--seed", "3"]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert main(["data", "check", str(out)]) == 0
    assert main(["data", "make-embedded", "--out", str(out), "--clips", "42"]) == 2  # never overwrites
    assert "already exists" in capsys.readouterr().err
    assert main(["data", "make-embedded", "--out", str(tmp_path / "tiny"), "--clips", "5"]) == 2  # too few clips
    assert not (tmp_path / "tiny").exists()


def test_train_tokenizer_then_load_from_cache(tmp_path, isolated_cache, capsys):
    data = tmp_path / "data"
    assert main(["data", "make-embedded", "--out", str(data), "--clips", "42"]) == 0
    assert main(["train", "vq", "--profile", "smoke", "--data", str(data), "--device", "cpu"]) == 0
    assert "trained and cached" in capsys.readouterr().out
    assert list((isolated_cache / "models" / "vq" / "smoke").iterdir())  # the artefact is in the cache
    assert main(["train", "vq", "--profile", "smoke", "--data", str(tmp_path / "missing")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_convert_features_to_bvh_html_and_back(tmp_path, capsys):
    from motionlab.data.embedded import generate_clip
    from motionlab.representation import joints_to_features

    feats = joints_to_features(generate_clip("wave", np.random.default_rng(0)).joints).astype(np.float32)
    np.save(tmp_path / "wave.npy", feats)
    assert main(["convert", str(tmp_path / "wave.npy"), str(tmp_path / "wave.bvh")]) == 0
    assert main(["convert", str(tmp_path / "wave.npy"), str(tmp_path / "wave.html")]) == 0
    assert main(["convert", str(tmp_path / "wave.bvh"), str(tmp_path / "back.npy"), "--mapping", "t2m"]) == 0
    back = np.load(tmp_path / "back.npy")
    assert back.shape[1] == 263 and abs(len(back) - len(feats)) <= 1
    assert "http" not in (tmp_path / "wave.html").read_text().lower().replace("http-equiv", "")
    assert main(["convert", str(tmp_path / "wave.npy"), str(tmp_path / "wave.bvh")]) == 2  # exists
    assert main(["convert", str(tmp_path / "wave.npy"), str(tmp_path / "wave.gif")]) == 2
    assert "unknown extension" in capsys.readouterr().err


# The CMU takes: "The data used in this project was obtained from mocap.cs.cmu.edu.
# The database was created with funding from NSF EIA-0196217." (see ../shared/data/cmu-bvh/README.md)
def test_convert_a_cmu_take(shared_data, tmp_path):
    out, take = tmp_path / "001417.npy", shared_data / "cmu-bvh" / "131_02.bvh"
    assert main(["convert", str(take), str(out), "--start", "10", "--end", "208"]) == 0
    assert np.load(out).shape == (197, 263)


def test_generate_single_and_multi_action(tmp_path, isolated_cache, capsys):
    data = tmp_path / "data"
    assert main(["data", "make-embedded", "--out", str(data), "--clips", "42"]) == 0
    common = ["--profile", "smoke", "--data", str(data), "--device", "cpu"]
    out = tmp_path / "wave.npy"
    assert main(["generate", "a person waves", "--length", "40", "--out", str(out), *common]) == 0
    assert np.load(out).shape == (40, 263)
    printed = capsys.readouterr()
    assert printed.out.splitlines()[-1] == str(out)  # the path alone on stdout, for scripts
    assert f"motionlab convert {out} wave.html" in printed.err and "only shows that the code runs" in printed.err
    two = tmp_path / "two.bvh"
    texts = ["a person walks", "a person jumps"]
    assert main(["generate", *texts, "--length", "40", "32", "--seed", "3", "--out", str(two), *common]) == 0
    assert two.read_text().startswith("HIERARCHY")  # no comment before HIERARCHY: BVH readers stop there
    assert read_bvh(two).n_frames > 0  # nothing after the frames either: the file parses as before
    assert "into Blender" in capsys.readouterr().err
    made = json.loads((tmp_path / "two.bvh.json").read_text())
    assert made["text"] == "a person walks / a person jumps" and made["profile"] == "smoke" and made["seed"] == "3"
    assert made["models"] == "t2m/dynamic, tokenizer/vq" and made["lengths"] == "40 32"
    assert made["code"].startswith(("commit ", "motionlab "))
    starts = [segment["start_frame"] for segment in made["segments"]]  # where each action begins, for a reader
    assert [segment["text"] for segment in made["segments"]] == texts and starts[0] == 0 and starts[1] > 0
    page = tmp_path / "wave.html"
    assert main(["generate", "a person waves", "--length", "40", "--out", str(page), *common]) == 0
    assert f"open {page} in a browser" in capsys.readouterr().err
    html = page.read_text()
    payload = json.loads(re.search(r'id="motion-data">(.*?)</script>', html, flags=re.S).group(1))
    assert payload["provenance"]["text"] == "a person waves" and payload["provenance"]["seed"] == "0"
    assert "<dt>profile</dt><dd>smoke</dd>" in html and "<dt>models</dt>" in html
    assert main(["generate", "a person waves", "--length", "42", "--out", str(tmp_path / "bad.npy"), *common]) == 2
    assert "multiples of 4" in capsys.readouterr().err and not (tmp_path / "bad.npy").exists()
    assert main(["generate", "a", "b", "--length", "40", "40", "40", "--out", str(tmp_path / "x.npy"), *common]) == 2


def test_train_every_model_kind(tmp_path, isolated_cache, capsys):
    data = tmp_path / "data"
    # the evaluator needs at least 32 training clips
    assert main(["data", "make-embedded", "--out", str(data), "--clips", "120"]) == 0
    for kind in ("evaluator", "discord", "diffusion"):
        assert main(["train", kind, "--profile", "smoke", "--data", str(data), "--device", "cpu"]) == 0
        assert f"{kind} (smoke" in capsys.readouterr().out
    cached = {p.name for p in (isolated_cache / "models").iterdir()}
    assert {"text_motion_evaluator", "discord", "rvq", "text_to_motion", "vq"} <= cached


def test_a_busy_machine_gets_the_threads_its_other_programs_leave(monkeypatch, capsys):
    """Without --threads or $MOTIONLAB_THREADS, a command on a busy CPU runs torch on the free cores (at least one)
    and says so; on an idle one it keeps torch's choice and says nothing."""
    import os

    import torch

    from motionlab.settings import threads_for_load

    monkeypatch.delenv("MOTIONLAB_THREADS", raising=False)
    monkeypatch.setattr(os, "cpu_count", lambda: 16)
    for load, threads in ((0.0, None), (0.4, None), (4.0, 12), (15.5, 1), (40.0, 1)):
        assert threads_for_load(load) == threads, load
    assert threads_for_load(None) is None  # a load nobody can read: torch's choice
    from argparse import Namespace

    from motionlab.cli import _settings

    def settle(command: str, **options) -> int:
        run = dict(threads=None, precision=None, force_precision=False, deterministic=None, compile=None)
        monkeypatch.delenv("MOTIONLAB_THREADS", raising=False)
        _settings(Namespace(command=command, profile="smoke", **run, **options))
        return torch.get_num_threads()

    before = torch.get_num_threads()
    try:
        monkeypatch.setattr(os, "cpu_count", lambda: 2)
        monkeypatch.setattr(os, "getloadavg", lambda: (3.9, 3.9, 3.9))
        torch.set_num_threads(2)
        assert settle("train") == 1 and "load 3.9 on 2 cores): 1 torch thread" in capsys.readouterr().err
        torch.set_num_threads(2)
        assert settle("book") == 2 and not capsys.readouterr().err  # the chapters' kernels keep their one thread
        assert settle("train", model="book") == 2 and not capsys.readouterr().err  # its workers: one thread each
        monkeypatch.setattr(os, "getloadavg", lambda: (0.1, 0.1, 0.1))
        assert settle("generate") == 2 and not capsys.readouterr().err  # idle: torch's own choice
        monkeypatch.setattr(os, "getloadavg", lambda: (3.9, 3.9, 3.9))
        assert main(["--threads", "2", "generate", "--list-words", "--profile", "smoke"]) == 0  # an explicit choice
        assert torch.get_num_threads() == 2 and "torch thread" not in capsys.readouterr().err
    finally:
        torch.set_num_threads(before)


def test_threads_option_sets_torch_threads(monkeypatch, capsys):
    import torch

    before = torch.get_num_threads()
    try:
        assert main(["--threads", "1", "data", "check", "/nonexistent/folder"]) == 1
        assert torch.get_num_threads() == 1
        assert main(["--threads", "0", "data", "check", "/nonexistent/folder"]) == 2
        assert "--threads must be a positive int" in capsys.readouterr().err
        assert main(["--threads", "100000", "data", "check", "/nonexistent/folder"]) == 2  # torch crashed past 32,766
        assert "at most 4096" in capsys.readouterr().err
        monkeypatch.setenv("MOTIONLAB_THREADS", "two")
        assert main(["data", "check", "/nonexistent/folder"]) == 2
        assert "MOTIONLAB_THREADS" in capsys.readouterr().err
    finally:
        torch.set_num_threads(before)


def _subcommand_parsers(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    """Every subcommand's parser under ``parser``, with the words that reach it (``("evaluate", "t2m")``)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield (*path, name), child
                yield from _subcommand_parsers(child, (*path, name))


def test_every_subcommand_help_has_examples_that_parse():
    parser = build_parser()
    parsers = list(_subcommand_parsers(parser))
    assert len(parsers) >= 16  # data (3), train, book (1), generate, convert, evaluate (3), pretrained (2)
    for words, sub in parsers:
        text = sub.format_help()
        assert "\nexamples:\n" in text, f"motionlab {' '.join(words)} --help shows no examples"
        examples = [line.split("  # ")[0].split() for line in sub.epilog.splitlines()[1:]]
        assert examples and all(e[0] == "motionlab" for e in examples)
        for example in examples:
            command = [w.strip('"') for w in shlex.split(" ".join(example))[1:]]
            assert tuple(command[: len(words)]) == words, f"an example of {words} runs {command}"
            parser.parse_args(command)  # argparse exits on an option that no longer exists


def test_every_option_says_its_default():
    for words, sub in _subcommand_parsers(build_parser()):
        formatter = sub._get_formatter()
        for action in sub._actions:
            flag = isinstance(action, (argparse._StoreTrueAction, argparse._HelpAction, argparse._SubParsersAction))
            if not action.option_strings or flag or action.required:
                continue
            text = formatter._get_help_string(action)
            assert "default" in text, f"motionlab {' '.join(words)} {action.option_strings[0]}: no default in its help"
