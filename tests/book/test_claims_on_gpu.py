"""Table E's speed claims judged on the GPU benchmark's recorded times, beside the chapter's CPU numbers."""

from __future__ import annotations

import json

from motionlab.report.gpu import newest_gpu_run, read_gpu_run, table_e_results
from motionlab.report.render import claims_table
from motionlab.report.store import FAILS, HOLDS

SLOW, FAST = "Decoding time grows with the number of steps", "At 16 steps the flow decoder is about as fast"


def gpu_run(tmp_path, sixteen: float = 0.13, ff: float = 0.0033):
    records = [
        {"section": "machine", "device": "Test GPU", "torch": "2.11", "cuda": "13", "commit": "abc1234"}
        | {"date": "2026-12-04", "matmul_tflops": {"bf16": 700.0}},
        {"section": "decode", "decoder": "motionlab", "precision": "fp32", "batch": 32, "points": 2}
        | {"frames": 196, "seconds_median": 0.023},
        {"section": "decode", "decoder": "motionlab", "precision": "fp32", "batch": 32, "points": 16}
        | {"frames": 196, "seconds_median": sixteen},
        {"section": "decode", "decoder": "feed-forward", "precision": "fp32", "batch": 32, "points": 0}
        | {"frames": 196, "seconds_median": ff},
        {"section": "decode", "decoder": "motionlab", "precision": "bf16", "batch": 1, "points": 16}
        | {"frames": 196, "seconds_median": 9.0},  # another batch and precision: not Table E's
    ]
    path = tmp_path / "run.json"
    path.write_text(json.dumps(records))
    return read_gpu_run(path)


def test_table_e_keys_come_from_the_batch_32_fp32_decodes(tmp_path):
    times = table_e_results(gpu_run(tmp_path))
    assert {k: r.value for k, r in times.items()} == {
        "discord/time_steps2": 0.023,
        "discord/time_steps16": 0.13,
        "discord/time_ff": 0.0033,
    }
    assert all(r.ci is None and r.unit == "s" and "Test GPU" in r.note for r in times.values())
    assert table_e_results(gpu_run(tmp_path), precision="bf16") == {}  # no batch-32 bf16 decode was timed


def test_only_the_speed_claims_get_a_gpu_line_and_it_never_moves_a_verdict(tmp_path):
    run = gpu_run(tmp_path, sixteen=0.0040)  # 16 steps within 50% of the feed-forward decoder: holds on this GPU
    rows = {
        row.statement: row for row in claims_table("laptop", recorded={}, gpu=run, spread=None, budget=None, scale=None)
    }
    with_gpu = {s: row.scale for s, row in rows.items() if "On a GPU" in row.scale}
    assert [s for s in with_gpu if s.startswith(SLOW)] and [s for s in with_gpu if s.startswith(FAST)]
    assert len(with_gpu) == 2
    fast = next(line for s, line in with_gpu.items() if s.startswith(FAST))
    assert fast.endswith(HOLDS) and "Test GPU, fp32, batch 32" in fast
    assert next(row for s, row in rows.items() if s.startswith(FAST)).verdict != HOLDS  # nothing recorded here
    slow_gpu = claims_table(
        "laptop", recorded={}, gpu=gpu_run(tmp_path, sixteen=0.13), spread=None, budget=None, scale=None
    )
    assert any(row.scale.endswith(FAILS) for row in slow_gpu if row.statement.startswith(FAST))
    without = claims_table("laptop", recorded={}, gpu=None, spread=None, budget=None, scale=None)
    assert not any("On a GPU" in row.scale for row in without)


def test_the_book_reads_its_newest_recorded_gpu_run():
    run = newest_gpu_run()
    assert run is not None and run.path.parent.name == "gpu"
    assert set(table_e_results(run)) == {"discord/time_steps2", "discord/time_steps16", "discord/time_ff"}
