"""A newcomer's first hour (issue 63): what the models know, the version, one's own BVH back, messages in the
words of the options, results that print as their table, a light install."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import motionlab
from motionlab.cli import build_parser, main, model_vocabulary
from motionlab.data import MotionDataset
from motionlab.io import read_bvh
from motionlab.io.bvh_export import helper_joints
from motionlab.representation import T2M
from motionlab.text import action_families

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def small_data(tmp_path, isolated_cache, capsys) -> Path:
    """A 42-clip embedded dataset in its own folder, with an empty model cache."""
    data = tmp_path / "data"
    assert main(["data", "make-embedded", "--out", str(data), "--clips", "42"]) == 0
    capsys.readouterr()
    return data


def test_version_prints_the_package_version():
    out = subprocess.run([sys.executable, "-m", "motionlab", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == f"motionlab {motionlab.__version__}"
    assert re.fullmatch(r"\d+\.\d+\.\d+", motionlab.__version__)


def test_unknown_words_are_named_before_any_training(small_data, monkeypatch, capsys):
    import motionlab.diffusion.pipeline as pipeline

    def no_model(*args, **kwargs):
        raise RuntimeError("the model was asked for")

    monkeypatch.setattr(pipeline, "text_to_motion_for_dataset", no_model)
    texts = ["a person plays the guitar while dancing salsa", "xyzzy plugh", "a person walks"]
    argv = ["generate", *texts, "--length", "40", "--profile", "smoke", "--data", str(small_data), "--out", "x.npy"]
    with pytest.raises(RuntimeError, match="was asked for"):
        main(argv)
    err = capsys.readouterr().err
    partly = next(line for line in err.splitlines() if "guitar" in line)
    assert partly.startswith("warning: 'a person plays the guitar")
    for word in ("plays", "guitar", "dancing", "salsa"):
        assert word in partly.split("<unk>:")[1]
    assert "warning: 'xyzzy plugh': the model knows none of its words" in err
    assert "'a person walks'" not in err  # every word known: no warning
    assert f"motionlab generate --list-words --profile smoke --data {small_data}" in err


def test_list_words_lists_the_families_and_the_vocabulary(small_data, capsys):
    assert main(["generate", "--list-words", "--profile", "smoke"]) == 0
    out = capsys.readouterr().out
    families = action_families()
    assert f"actions ({len(families)} families of the embedded data): {', '.join(families)}" in out
    assert re.search(r"words the smoke text-to-motion model knows \(\d+;", out) and "<unk>" not in out
    assert main(["generate", "--list-words", "--profile", "smoke", "--data", str(small_data), "a person xyzzy"]) == 0
    printed = capsys.readouterr()
    vocabulary = model_vocabulary(MotionDataset(small_data), "smoke")
    listed = printed.out.split("unknown):\n", 1)[1].split()
    assert listed == sorted(w for w in vocabulary.tokens if not w.startswith("<")) and "person" in listed
    assert "xyzzy" in printed.err and "families of the embedded data" not in printed.out
    assert main(["generate", "--list-words", "--out", "x.html"]) == 2
    assert "leave out --out" in capsys.readouterr().err


def test_generate_bvh_reads_back_without_a_mapping(small_data, tmp_path, capsys):
    """The round trip of the issue: generate -> x.bvh, which an independent reader (bvhio) reads with the rig we
    meant, and which `convert` and `data from-bvh` read back with no --mapping; the warning vocabulary is the
    trained model's."""
    bvhio = pytest.importorskip("bvhio")
    common = ["--profile", "smoke", "--data", str(small_data), "--device", "cpu"]
    out = tmp_path / "guitar.bvh"
    assert main(["generate", "a person plays the guitar", "--length", "48", "--out", str(out), *common]) == 0
    printed = capsys.readouterr()
    assert printed.out.splitlines()[-1] == str(out)
    assert "guitar" in printed.err.split("<unk>:")[1] and "plays" in printed.err.split("<unk>:")[1]

    # the warning's vocabulary is the one the model was trained with
    from motionlab.diffusion.pipeline import text_to_motion_for_dataset

    dataset = MotionDataset(small_data)
    pipe = text_to_motion_for_dataset(dataset, "smoke", progress=False, device="cpu")
    assert model_vocabulary(dataset, "smoke").tokens == pipe.text_encoder.vocab.tokens

    # bvhio: the joints (22 t2m + the documented helpers, no end sites), frames and frame time we wrote
    ours = read_bvh(out)
    theirs = bvhio.readAsBvh(str(out))
    names = [joint.Name for joint, _, _ in theirs.Root.layout()]
    assert names == [j.name for j in ours.joints if not j.end_site]
    assert len(names) == len(T2M.joint_names) + len(helper_joints()) == 28
    assert set(names) - set(T2M.joint_names) == set(helper_joints())
    assert theirs.FrameCount == ours.n_frames == 48 and theirs.FrameTime == pytest.approx(0.05)
    assert all(len(joint.Keyframes) == 48 for joint, _, _ in theirs.Root.layout())

    # back through convert and data from-bvh, no --mapping
    back = tmp_path / "back.npy"
    assert main(["convert", str(out), str(back)]) == 0
    assert np.load(back).shape == (47, 263)
    takes = tmp_path / "takes"
    takes.mkdir()
    for name in ("play_guitar.bvh", "guitar_again.bvh"):
        shutil.copy(out, takes / name)
    assert main(["data", "from-bvh", str(takes), "--out", str(tmp_path / "mine")]) == 0
    summary = capsys.readouterr().out
    assert "2 clips" in summary and "rigs: t2m (2 clips)" in summary


def test_lengths_and_json_are_refused_in_the_words_of_the_options(small_data, tmp_path, capsys):
    common = ["--profile", "smoke", "--data", str(small_data), "--out", str(tmp_path / "x.npy")]
    for length in ("-40", "42", "0"):
        assert main(["generate", "a person waves", "--length", length, *common]) == 2
        err = capsys.readouterr().err
        assert f"--length {length}: lengths are positive multiples of 4 frames" in err
        assert "lengths_in_frames" not in err
    assert main(["generate", "--profile", "smoke", "--out", str(tmp_path / "x.npy")]) == 2
    assert "give one or more texts" in capsys.readouterr().err
    assert main(["generate", "a person waves", "--profile", "smoke"]) == 2
    assert "--out is required" in capsys.readouterr().err
    table = tmp_path / "table.json"
    table.write_text("{}")
    assert main(["evaluate", "reconstruction", "--profile", "smoke", "--json", str(table)]) == 2
    err = capsys.readouterr().err
    assert f"--json {table} exists; pass --force to replace it" in err and "force=True" not in err


def test_data_check_says_what_is_missing_and_what_texts_hold(tmp_path, capsys):
    assert main(["data", "check", str(tmp_path / "nowhere")]) == 1
    assert f"error: {tmp_path / 'nowhere'} does not exist" in capsys.readouterr().err
    (tmp_path / "file.txt").write_text("x")
    assert main(["data", "check", str(tmp_path / "file.txt")]) == 1
    assert "is a file, not the dataset's folder" in capsys.readouterr().err
    (tmp_path / "new_joint_vecs").mkdir()
    assert main(["data", "check", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "missing texts" in err and "problem" in err and "problem(s)" not in err
    assert "caption#word/POS word/POS ...#start#end" in err
    example = next(line.strip() for line in err.splitlines() if line.startswith("  a person waves"))
    from motionlab.data.humanml3d import parse_caption_line

    caption = parse_caption_line(example)  # the example line parses as the loader reads it
    assert caption.text == "a person waves with the left hand" and caption.tokens[1] == "person/NOUN"


def test_evaluation_tables_print_as_their_table():
    from motionlab.estimate import Estimate
    from motionlab.evaluation.table import EvaluationTable

    table = EvaluationTable(
        task="reconstruction",
        profile="smoke",
        data="embedded-smoke",
        split="test",
        repeats=2,
        seed=0,
        config={},
        counts={"clips": 8},
        metrics=("mpjpe",),
        rows={"DisCoRD": {"mpjpe": Estimate.from_values([0.1, 0.2])}},
    )
    printed = str(table)
    assert printed.splitlines()[0] == table.header() and printed.endswith(table.to_markdown())
    assert "| DisCoRD |" in printed and "Estimate(" not in printed and "rows=" not in printed
    assert table._repr_markdown_() == table.to_markdown()
    assert "rows=" in repr(table)  # the full record stays available


def test_readme_and_command_page_say_what_the_models_know_and_how_to_install():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    page = (ROOT / "book" / "command_line.md").read_text(encoding="utf-8")
    for doc in (readme, page):
        named = [family for family in action_families() if family in doc]
        assert len(named) >= 10, named
        assert "--list-words" in doc and "source .venv/bin/activate" in doc
    assert "`pip install -e .`" in readme and "pip install -e '.[dev]'" in readme
    for helper in helper_joints():  # the export's helper joints are documented where a user looks
        assert helper in page and helper in sys.modules["motionlab.io.bvh_export"].__doc__
    assert "source .venv/bin/activate" in build_parser().epilog  # --help's bare `motionlab` examples


def test_the_base_install_leaves_out_the_book_and_test_tools():
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    base = {re.split(r"[<>=!~\[; ]", dep, maxsplit=1)[0].lower() for dep in project["dependencies"]}
    tools = {"jupyter-book", "jupyterlab", "selenium", "pytest", "ruff", "nbval", "papermill", "ipykernel"}
    assert base and not base & tools, base & tools
    extras = project["optional-dependencies"]
    assert {"jupyter-book", "selenium", "ruff"} <= {
        re.split(r"[<>=!~\[; ]", dep, maxsplit=1)[0].lower() for name in ("book", "test") for dep in extras[name]
    }
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert f"its {['no', 'one', 'two', 'three', 'four', 'five', 'six', 'seven', 'eight'][len(base)]}" in readme


BLOCKED = ("jupyter_book", "selenium", "pytest", "ruff", "nbval", "papermill", "IPython", "ipywidgets", "nbformat")


def test_the_command_line_runs_without_the_book_and_test_tools(tmp_path):
    """What `pip install -e .` gives: the command line and the library's main modules import with the book's and
    the tests' packages unavailable."""
    script = f"""
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {BLOCKED!r}:
            raise ImportError(f"{{name}} is not installed (blocked)")
sys.meta_path.insert(0, Block())
import motionlab.cli, motionlab.io, motionlab.data, motionlab.evaluation, motionlab.models, motionlab.text
motionlab.cli.build_parser().format_help()
sys.exit(motionlab.cli.main(["data", "check", {str(tmp_path)!r}]))
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 1 and "missing texts" in out.stderr, out.stderr[-2000:]


def test_the_command_page_joint_map_example_reads(tmp_path):
    from motionlab.io.bvh_import import read_joint_map

    page = (ROOT / "book" / "command_line.md").read_text(encoding="utf-8")
    example = re.search(r"```json\n(.*?)```", page, flags=re.S).group(1)
    (tmp_path / "my-rig.json").write_text(example)
    joints, scale, up = read_joint_map(tmp_path / "my-rig.json")
    assert sorted(joints) == sorted(T2M.joint_names) and scale == 0.01 and up == "y"
    assert json.loads(example)["joints"]["pelvis"] == "Hips"
