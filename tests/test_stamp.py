"""The stamp committed experiment records carry."""

import json
import subprocess

import pytest

from motionlab.build.stamp import commit, machine_stamp


def test_machine_stamp_names_cpu_precision_threads_and_commit():
    stamp = machine_stamp()
    assert set(stamp) == {"cpu", "machine", "precision", "torch_threads", "commit"}
    assert stamp["precision"] in ("fp32", "bf16") and stamp["torch_threads"] >= 1
    head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    if not head:
        pytest.skip("not run from a git checkout")
    assert stamp["commit"] and head.startswith(stamp["commit"])  # the checkout's HEAD, as a short hash


def test_commit_is_none_outside_a_checkout(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert commit() is None


def test_a_record_is_measured_once(tmp_path, capsys):
    from motionlab.build.stamp import record_once

    calls = []

    def measure() -> dict:
        calls.append(1)
        return {"value": len(calls)}

    path = tmp_path / "point.json"
    assert record_once(path, "point", measure, "scoring") is True
    assert json.loads(path.read_text()) == {"value": 1} and path.read_text().endswith("\n")
    assert record_once(path, "point", measure) is False and len(calls) == 1  # a rerun skips it without measuring
    err = capsys.readouterr().err
    assert "point: scoring" in err and "point: wrote" in err and "point: recorded already" in err
