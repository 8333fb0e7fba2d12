"""What the chapter-parity tests (``test_evaluate_matches_chapter0*.py``) share: a chapter's code cells, and its
printed ``motionlab evaluate ...`` command run in-process."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

from motionlab import cli


def _chapter_code(path: Path) -> str:
    # the book's tooling is not everywhere the library runs (a GPU image has torch, not nbformat): skip, not fail
    nbformat = pytest.importorskip("nbformat")
    return "\n".join(c.source for c in nbformat.read(path, as_version=4).cells if c.cell_type == "code")


@pytest.fixture
def chapter_code():
    """``chapter_code(path)``: the code cells of a notebook, joined."""
    return _chapter_code


@pytest.fixture
def run_command_line(tmp_path, capsys, monkeypatch):
    """``run_command_line(config)``: the command the chapter prints (``config.command_line("smoke")``), checked to
    parse back into ``config`` and run in-process in fp32 with ``--json``; returns ``(argv, stdout, json table)``."""

    def run(config):
        monkeypatch.setenv("MOTIONLAB_PRECISION", "fp32")
        out = tmp_path / "table.json"
        argv = shlex.split(config.command_line("smoke"))[1:] + ["--json", str(out)]
        args = cli.build_parser().parse_args(argv)
        assert cli._evaluation_config(args, args.repeats) == config  # the command line is the chapter's config
        assert cli.main(argv) == 0
        return argv, capsys.readouterr().out, json.loads(out.read_text())

    return run
