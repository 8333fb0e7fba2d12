"""The recorded GPU runs that chapter 98 shows: readable, and projecting what the GPU note measured."""

from __future__ import annotations

import json

import pytest

from motionlab.book import repository_path
from motionlab.report import gpu


@pytest.fixture(scope="module")
def first_run():
    runs = gpu.load_gpu_runs(repository_path("book", "data", "gpu"))
    assert runs, "book/data/gpu holds the first GPU run"
    return runs[0]


def test_the_first_run_projects_the_notes_hours(first_run):
    assert first_run.machine["device"] == "NVIDIA H200" and first_run.peak_tflops == 777.0
    steps = gpu.full_schedule_steps()
    assert steps["discord"] == 481_896  # DisCoRD's 200 epochs at batch 768
    hours = {v: steps["discord"] * first_run.step_ms("discord", v) / 3.6e6 for v in ("library train_step", "module")}
    assert hours["library train_step"] == pytest.approx(20.5, abs=0.05)
    assert hours["module"] == pytest.approx(7.4, abs=0.05)
    table = gpu.projection_table(first_run)
    assert "20.5 h" in table and "3.9 h" in table and "not measured" in table


def test_the_tables_show_the_shares_and_the_table_e_grid(first_run):
    steps = gpu.step_table(first_run)
    assert "| DisCoRD decoder | bf16 | module, compiled | 768 | 29.4 | 7.21 | 31.6% |" in steps
    decode = gpu.decode_table(first_run)
    assert "batch 32, 16 points" in decode and "| official + torchdiffeq | fp32 |" in decode
    assert gpu.table1_decode_seconds(first_run) == pytest.approx(137 * 20 * 0.190)  # 4,384 clips in 137 batches


def test_a_run_needs_one_machine_record(tmp_path):
    path = tmp_path / "run.json"
    path.write_text(json.dumps([{"section": "train"}]))
    with pytest.raises(ValueError, match="one machine record"):
        gpu.read_gpu_run(path)
    assert gpu.load_gpu_runs(tmp_path / "absent") == []


def _in_history(commit: str) -> bool:
    import subprocess

    return subprocess.run(["git", "cat-file", "-e", f"{commit}^{{commit}}"], capture_output=True).returncode == 0


def test_a_run_recorded_before_the_step_got_faster_says_so(first_run):
    """The first run (commit 473e6c8) timed the library's step before the host reads left it: chapter 98 and the
    scale plan label its train_step times; a run at a commit with every change in its history is not labelled."""
    if not all(_in_history(c) for c, _ in gpu.TRAIN_STEP_CHANGES) or not _in_history("473e6c8"):
        pytest.skip("a shallow clone: git cannot place the changes")
    assert first_run.predates() == list(gpu.TRAIN_STEP_CHANGES)
    assert first_run.train_step_caveat().startswith("**Measured before** training steps stopped reading")
    newer = gpu.GPURun(first_run.path, first_run.machine | {"commit": gpu.TRAIN_STEP_CHANGES[-1][0]})
    assert newer.predates() == [] and newer.train_step_caveat() is None
    unplaced = gpu.GPURun(first_run.path, first_run.machine | {"commit": None})
    assert unplaced.predates() == list(gpu.TRAIN_STEP_CHANGES)  # where it cannot be checked, the caveat stays
