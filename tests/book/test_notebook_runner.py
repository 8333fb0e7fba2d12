"""The chapter executor: a stalled kernel is restarted, a busy one is left alone, a failing cell fails."""

from __future__ import annotations

import gc
import logging

import nbformat
import pytest

from motionlab.build.notebook_runner import execute_chapter, execute_chapters, stage_site, timings_record

pytest.importorskip("nbclient")


def write_notebook(path, *sources: str):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(src) for src in sources]
    for i, cell in enumerate(nb.cells):
        cell.id = f"cell-{i}"
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(nb, path)
    return path


def test_a_stalled_kernel_is_restarted_and_the_chapter_completes(tmp_path):
    marker = tmp_path / "first-attempt-done"
    # First attempt: the cell neither prints nor computes (like a lost execute request); second: it finishes.
    source = write_notebook(
        tmp_path / "stall.ipynb",
        "x = 1",
        f"import pathlib, time\nm = pathlib.Path({str(marker)!r})\nif not m.exists():\n    m.touch()\n"
        "    time.sleep(600)\nprint('done', x)",
    )
    events = []
    run = execute_chapter(source, tmp_path / "out" / "stall.ipynb", stall_s=3, poll_s=0.5, log=events.append)
    assert run.status == "ok" and run.attempts == 2
    assert "ChapterStalled" in run.events[0] and "cell-1" in run.events[0]
    assert any("restarting" in e for e in events)
    executed = nbformat.read(tmp_path / "out" / "stall.ipynb", as_version=4)
    assert "done 1" in executed.cells[1].outputs[0]["text"]
    assert set(run.cell_seconds) == {"cell-0", "cell-1"}


def test_a_busy_silent_cell_is_not_mistaken_for_a_stall(tmp_path):
    source = write_notebook(
        tmp_path / "busy.ipynb", "import time\nt = time.process_time()\nwhile time.process_time() - t < 4:\n    pass"
    )
    run = execute_chapter(source, tmp_path / "busy-out.ipynb", stall_s=2, poll_s=0.5, log=lambda _: None)
    assert run.status == "ok" and run.attempts == 1 and run.events == []


def test_a_stall_every_time_gives_up_after_the_attempts(tmp_path):
    source = write_notebook(tmp_path / "hang.ipynb", "import time\ntime.sleep(600)")
    run = execute_chapter(source, tmp_path / "hang-out.ipynb", stall_s=2, poll_s=0.5, attempts=2, log=lambda _: None)
    assert run.status == "failed" and run.attempts == 2 and "stalled 2 times" in run.error


def test_a_failing_cell_fails_the_chapter_with_its_error(tmp_path):
    source = write_notebook(tmp_path / "bad.ipynb", "raise ValueError('chapter assert: numbers moved')")
    [run] = execute_chapters([source], tmp_path / "out", jobs=1, out=open(tmp_path / "log.txt", "w"))
    assert run.status == "failed" and "numbers moved" in run.error and run.attempts == 1


def test_stage_site_keeps_sources_and_swaps_in_executed_chapters(tmp_path):
    repo = tmp_path / "repo"
    (repo / "book").mkdir(parents=True)
    (repo / "book" / "intro.md").write_text("# hi\n")
    (repo / "_config.yml").write_text("title: t\nexecute:\n  execute_notebooks: force\n")
    executed = tmp_path / "executed"
    executed.mkdir()
    write_notebook(executed / "01_x.ipynb", "1")
    stage = stage_site(repo, executed, tmp_path / "stage")
    import yaml

    config = yaml.safe_load((stage / "_config.yml").read_text())
    assert config["execute"] == {"execute_notebooks": "force", "exclude_patterns": ["notebooks/*"]}
    assert (stage / "notebooks" / "01_x.ipynb").is_file() and (stage / "book" / "intro.md").is_file()
    record = timings_record([], "smoke", 1.0)
    assert record == {"profile": "smoke", "wall_seconds": 1.0}


def test_chapters_marked_last_start_after_all_others(tmp_path):
    marker = tmp_path / "recorded"
    first = write_notebook(
        tmp_path / "a.ipynb", f"import time, pathlib\ntime.sleep(2)\npathlib.Path({str(marker)!r}).touch()"
    )
    summary = write_notebook(tmp_path / "z.ipynb", f"import pathlib\nassert pathlib.Path({str(marker)!r}).exists()")
    runs = execute_chapters([summary, first], tmp_path / "out", jobs=2, last={"z"}, out=open(tmp_path / "log", "w"))
    assert [r.name for r in runs] == ["z", "a"] and all(r.status == "ok" for r in runs)


def test_an_interact_cell_keeps_its_output_in_the_cell(tmp_path):
    pytest.importorskip("ipywidgets")
    source = write_notebook(
        tmp_path / "widget.ipynb",
        "import ipywidgets as widgets\n"
        "widgets.interact(lambda x: print(f'value {x}'), x=widgets.IntSlider(value=3, max=9));",
    )
    run = execute_chapter(source, tmp_path / "widget-out.ipynb", stall_s=30, poll_s=0.5, log=lambda _: None)
    assert run.status == "ok"
    outputs = nbformat.read(tmp_path / "widget-out.ipynb", as_version=4).cells[0].outputs
    assert any("value 3" in out.get("text", "") for out in outputs)  # not only inside the widget's state


def test_the_summary_chapter_runs_after_the_others():
    from pathlib import Path

    from motionlab.build.notebook_runner import runs_last

    notebooks = Path(__file__).resolve().parents[2] / "notebooks"
    assert [p.stem for p in sorted(notebooks.glob("*.ipynb")) if runs_last(p)] == [
        "99_what_reproduces",
        "s6_judging_verdicts",
        "s7_departures",
    ]


def test_an_unchanged_chapter_is_kept_and_a_changed_one_executes_again(tmp_path):
    counter = tmp_path / "executions"
    count = (
        f"import pathlib\np = pathlib.Path({str(counter)!r})\np.write_text(p.read_text() + 'x' if p.exists() else 'x')"
    )
    chapter = write_notebook(tmp_path / "a.ipynb", count)
    summary = write_notebook(tmp_path / "z.ipynb", "1 + 1")
    out, log = tmp_path / "out", open(tmp_path / "log", "w")

    def build(fingerprint="lib-1", **kw):
        runs = execute_chapters([chapter, summary], out, jobs=1, last={"z"}, fingerprint=fingerprint, out=log, **kw)
        return runs, timings_record(runs, "smoke", 1.0)

    runs, record = build()
    assert counter.read_text() == "x" and not any(r.reused for r in runs) and record["a"]["fingerprint"]
    runs, record = build(previous=record)  # nothing changed: nothing executes, the timings are carried over
    assert counter.read_text() == "x" and all(r.reused and r.status == "ok" for r in runs)
    assert record["a"]["seconds"] > 0 and record["a"]["cells"]
    runs, record = build("lib-2", previous=record)  # the library or the models changed
    assert counter.read_text() == "xx" and not any(r.reused for r in runs)  # the summary follows an executed chapter
    write_notebook(chapter, count, "2 + 2")  # the notebook changed
    runs, _ = build("lib-2", previous=record)
    assert counter.read_text() == "xxx" and [r.reused for r in runs] == [False, False]
    (out / "a.ipynb").unlink()  # the executed notebook is gone
    runs, _ = build("lib-2", previous=timings_record(runs, "smoke", 1.0))
    assert counter.read_text() == "xxxx" and [r.reused for r in runs] == [False, False]


def test_the_fingerprint_follows_the_profile_and_the_model_cache(tmp_path):
    from motionlab.build.notebook_runner import build_fingerprint

    model = tmp_path / "models" / "vq" / "smoke" / "abc" / "model.safetensors"
    model.parent.mkdir(parents=True)
    model.write_bytes(b"weights")
    first = build_fingerprint("smoke", tmp_path)
    assert build_fingerprint("smoke", tmp_path) == first
    assert build_fingerprint("laptop", tmp_path) != first
    model.write_bytes(b"retrained weights")
    assert build_fingerprint("smoke", tmp_path) != first


def test_a_stall_leaves_no_unread_error_behind(tmp_path, caplog):
    # An abandoned run's error, logged whenever the garbage collector finds it, once landed inside another test's
    # ast.parse and broke it (Python 3.11 parses source while formatting a traceback).
    source = write_notebook(tmp_path / "hang.ipynb", "import time\ntime.sleep(600)")
    with caplog.at_level(logging.ERROR, logger="asyncio"):
        run = execute_chapter(source, tmp_path / "out.ipynb", stall_s=2, poll_s=0.5, attempts=1, log=lambda _: None)
        gc.collect()
    assert run.status == "failed"
    assert not [r.getMessage() for r in caplog.records if "never retrieved" in r.getMessage()]
