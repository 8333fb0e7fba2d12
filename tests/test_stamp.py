"""The stamp committed experiment records carry."""

from motionlab.build.stamp import commit, machine_stamp


def test_machine_stamp_names_cpu_precision_threads_and_commit():
    stamp = machine_stamp()
    assert set(stamp) == {"cpu", "machine", "precision", "torch_threads", "commit"}
    assert stamp["precision"] in ("fp32", "bf16") and stamp["torch_threads"] >= 1
    assert stamp["commit"] == commit()


def test_commit_is_none_outside_a_checkout(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert commit() is None
