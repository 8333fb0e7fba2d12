"""The command examples of the README and of the book's command-line page run as written, in smoke size.

Every command line of their ``bash`` blocks is parsed; those that can run here run in order (a command both
pages show runs once), in a
temporary folder with a temporary ``$MOTIONLAB_HOME``, with ``--profile`` forced to ``smoke`` (and
``$MOTIONLAB_PROFILE=smoke`` for the commands that name none). The embedded smoke dataset is shrunk to 240
clips (still enough test clips for R-precision's batches of 32) so the models of the whole chain train in a
few minutes. Excluded, each for a stated reason, are the commands in :data:`EXCLUDED`.
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import pytest

from motionlab.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
# the README keeps a short block; the book's page on the command line has every command the README used to show
DOCS = (README, ROOT / "book" / "command_line.md")

# The start of the command (after ".venv/bin/") -> why it does not run in the test suite.
EXCLUDED = {
    "make setup": "creates the .venv this test runs in",
    "make book": "builds the whole site at the laptop profile (over an hour)",
    "make test": "runs this very test suite",
    "motionlab evaluate t2m --repeats 20 --multimodality": "MultiModality of 20 repeats takes about 75 minutes "
    "even in smoke; the README says so (tests/cli/test_evaluate.py runs the same task small)",
    "torchrun": "starts 4 processes for 4 GPUs and reads a real dataset at /data/HumanML3D",
    "motionlab data from-bvh mocap/": "needs the reader's own folder of BVH takes and captions "
    "(tests/data/test_from_bvh.py runs the command on takes it writes and on the CMU takes)",
    "motionlab train vq --data mydata": "trains on the dataset the from-bvh example writes "
    "(tests/data/test_from_bvh.py trains on a converted folder)",
    "motionlab pretrained": "needs the files the papers released, which cannot be downloaded here "
    "(tests/pretrained/ checks and converts folders in their layouts)",
    "motionlab --precision fp32 evaluate reconstruction --data /data/HumanML3D": "needs HumanML3D and the released "
    "checkpoints (tests/pretrained/test_pretrained_evaluate.py runs the command on folders in their layouts)",
    "motionlab evaluate reconstruction --data /data/HumanML3D": "needs HumanML3D and the released T2M-GPT VQ-VAE "
    "(tests/pretrained/test_pretrained_evaluate.py runs it on a folder in its layout)",
}


def readme_commands(docs: tuple[Path, ...] = DOCS) -> list[str]:
    """Every line of the ``bash`` blocks of ``docs``, without its trailing comment, each command once."""
    blocks = [b for doc in docs for b in re.findall(r"```bash\n(.*?)```", doc.read_text(encoding="utf-8"), flags=re.S)]
    lines = [line.split("  #")[0].strip() for block in blocks for line in block.splitlines()]
    return list(dict.fromkeys(line for line in lines if line and not line.startswith("#")))


def excluded(command: str) -> str | None:
    bare = command.removeprefix(".venv/bin/")
    return next((why for start, why in EXCLUDED.items() if bare.startswith(start)), None)


def test_every_command_uses_the_venv_and_parses():
    commands = readme_commands()
    assert len(commands) >= 10
    for command in commands:
        words = shlex.split(command)
        if words[0] == "make":
            continue
        assert words[0].startswith(".venv/bin/"), f"{command!r}: a fresh clone has these tools only in .venv/bin"
        if words[0].endswith("torchrun"):
            words = words[words.index("motionlab") :]  # ... -m motionlab ARGS
        argv = words[1:]
        if "--help" in argv:
            with pytest.raises(SystemExit) as shown:
                build_parser().parse_args(argv)
            assert shown.value.code == 0
            continue
        build_parser().parse_args(argv)  # option names and values as argparse sees them
    for start in EXCLUDED:  # every exclusion still names a README command
        assert any(c.removeprefix(".venv/bin/").startswith(start) for c in commands), start


def test_readme_commands_run_in_smoke(tmp_path, monkeypatch, request, capsys):
    from motionlab.data.embedded import embedded_path
    from motionlab.sizes import RUN

    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))
    monkeypatch.setenv("MOTIONLAB_PROFILE", "smoke")
    monkeypatch.setitem(RUN["smoke"], "embedded_clips", 240)
    monkeypatch.chdir(tmp_path)
    try:  # the README's `take.bvh`: a CMU take from ../shared/data when it is there
        shutil.copy(request.getfixturevalue("shared_data") / "cmu-bvh" / "131_02.bvh", tmp_path / "take.bvh")
    except pytest.skip.Exception:
        pass
    ran = []
    for command in readme_commands():
        if excluded(command) or not command.startswith(".venv/bin/motionlab ") or "--help" in command:
            continue  # --help: the parse test above shows it
        if "take.bvh" in command and not (tmp_path / "take.bvh").exists():
            continue  # no CMU take on this machine
        argv = shlex.split(command)[1:]
        if "--profile" in argv:
            argv[argv.index("--profile") + 1] = "smoke"
        if argv[:2] == ["data", "check"]:  # the README's placeholder path: check the dataset just generated
            argv[2] = str(embedded_path("smoke"))
        assert main(argv) == 0, f"{command!r} failed: {capsys.readouterr().err}"
        ran.append(argv[0])
    assert ran.count("evaluate") == 6 and {"data", "train", "generate"} <= set(ran)
    outputs = ("wave.html", "walk-jump.html", "wave-discord.bvh", "wave.bvh", "two.html", "table1.json")
    outputs += ("wave-back.html", "wave-back.npy")  # the BVHs motionlab wrote, read back with no --mapping
    for output in outputs + (("take.npy", "take.html") if (tmp_path / "take.bvh").exists() else ()):
        assert (tmp_path / output).is_file(), output
    assert "<dt>profile</dt><dd>smoke</dd>" in (tmp_path / "wave.html").read_text()  # the taste records its making
    assert (tmp_path / "wave-discord.bvh.json").is_file()


def test_the_taste_comes_first_and_runs_in_seconds(tmp_path, monkeypatch, capsys):
    """The README's first command after setup, as written: a smoke motion, opened in a browser."""
    from motionlab.sizes import RUN

    head = README.read_text(encoding="utf-8").splitlines()[:40]
    taste = '.venv/bin/motionlab generate "a person waves" --profile smoke --out wave.html'
    assert any(line.startswith(taste) for line in head), "the taste must be in the README's first 40 lines"
    assert any(line.startswith("make setup") for line in head) and any(
        "Open `wave.html` in a browser" in line for line in head
    )
    monkeypatch.setenv("MOTIONLAB_HOME", str(tmp_path / "home"))
    monkeypatch.setitem(RUN["smoke"], "embedded_clips", 120)  # the smoke chain on fewer clips: same code, faster
    monkeypatch.chdir(tmp_path)
    assert main(shlex.split(taste)[1:]) == 0
    printed = capsys.readouterr()
    assert "open wave.html in a browser" in printed.err and "only shows that the code runs" in printed.err
    assert "note: training " in printed.err and "models first: about" in printed.err
    page = (tmp_path / "wave.html").read_text()
    assert "<dt>text</dt><dd>a person waves</dd>" in page and "http" not in page.lower().replace("http-equiv", "")
