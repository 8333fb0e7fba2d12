"""The stamp committed experiment records carry."""

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
