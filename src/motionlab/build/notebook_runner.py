"""Execute the book's chapters, several at a time, with a watchdog that restarts a chapter whose kernel hangs.

Why not let Jupyter Book execute them: it runs one notebook at a time, and a kernel that stops answering
costs its whole per-cell timeout (an hour) before anything fails. Seen here (ipykernel 6.31, pyzmq 27,
nbclient 0.11, a busy 2-core machine): at a ``widgets.interact`` cell the kernel sits idle in its event
loop and the client waits for a reply that never comes, both at 0% CPU. Every stall measured was at a cell
whose output goes into an ``Output`` widget; nbclient hands such outputs to a hook that sends them back to
the kernel as comm messages on the shell channel (unawaited) while it waits on that channel for the cell's
reply. Without the hook no stall was seen (numbers at ``register_output_hook`` below), so:

- **no Output-widget hook**: an interact cell's outputs stay ordinary cell outputs (what a static page
  shows anyway);
- **watchdog**: while a cell runs, the kernel must either send messages or use CPU (its own or its child
  processes'). Silent *and* idle for ``stall_s`` seconds means stalled: the kernel is killed and the
  chapter re-executed from the top in a fresh kernel (models come from the cache, so this is cheap),
  up to ``attempts`` times; every restart is reported and kept in the timings file;
- **per-cell timeout** as a backstop against a busy endless loop: a generous multiple of the cell's
  time in the last recorded run (matched by cell id), or ``default_cell_timeout_s`` for new cells.

A chapter whose cell raises fails (its error is printed) and the build exits non-zero, like Jupyter Book's
strict mode. Executed notebooks go to ``out_dir``; :func:`stage_site` puts them beside a copy of the book's
sources so that Jupyter Book renders them without executing again.
"""

from __future__ import annotations

import asyncio
import atexit
import hashlib
import json
import multiprocessing
import shutil
import sys
import time
from collections.abc import Collection, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..profiles import env_threads
from .workers import completed_until_ctrl_c, elapsed_stamp, interrupt_when_orphaned, native_threads_for_children

STALL_S = 180.0  # silent and idle this long while a cell runs: the kernel is stalled
ATTEMPTS = 3
DEFAULT_CELL_TIMEOUT_S = 3600.0
TIMEOUT_FACTOR, TIMEOUT_FLOOR_S = 10.0, 600.0  # per-cell backstop: max(floor, factor x last recorded time)
_IDLE_CPU_FRACTION = 0.01  # below 1% of one core over the stall window counts as idle


@dataclass
class ChapterRun:
    """How one chapter's execution went."""

    name: str
    status: str = "pending"  # "ok" | "failed"
    seconds: float = 0.0
    attempts: int = 0
    events: list[str] = field(default_factory=list)  # stalls, timeouts, restarts
    error: str = ""
    cell_seconds: dict[str, float] = field(default_factory=dict)  # cell id -> seconds (last attempt)
    fingerprint: str = ""  # of everything its outputs depend on (see build_fingerprint)
    reused: bool = False  # up to date: the earlier execution was kept


class ChapterStalled(RuntimeError):
    """The kernel neither answered nor worked while a cell ran."""


# -- one chapter ---------------------------------------------------------------------------------------------------
def _process_cpu_seconds(pid: int | None) -> float | None:
    """CPU seconds used so far by process ``pid`` and all its children (None if it cannot be read)."""
    if pid is None:
        return None
    import psutil

    try:
        proc = psutil.Process(pid)
        total = sum(proc.cpu_times()[:2])
        for child in proc.children(recursive=True):
            try:
                total += sum(child.cpu_times()[:2])
            except psutil.Error:
                continue
        return total
    except psutil.Error:
        return None


def _make_client(nb, cwd: Path, previous: dict[str, float], default_timeout_s: float):
    from nbclient import NotebookClient

    def cell_timeout(cell) -> int:
        last = previous.get(cell.get("id", ""))
        return int(max(TIMEOUT_FLOOR_S, TIMEOUT_FACTOR * last) if last is not None else default_timeout_s)

    class WatchedClient(NotebookClient):
        """Records when the current cell started and when the kernel last said anything; leaves the outputs of
        ``Output`` widgets (``widgets.interact``) in the cell instead of sending them back to the kernel."""

        last_message = time.monotonic()
        running_cell: str | None = None

        def process_message(self, msg, cell, cell_index):  # every IOPub message of a running cell
            self.last_message = time.monotonic()
            return super().process_message(msg, cell, cell_index)

        # nbclient routes what a cell prints inside an Output widget to a hook that sends each output back to
        # the kernel as a comm message on the shell channel, without awaiting the send, while the client waits
        # on that same channel for the cell's reply. Measured here (chapters 02, 04, 06, 09 in smoke, the two variants
        # side by side on a loaded 2-core machine, 60 s stall limit): with the hook 8 of 18 runs stalled, each at a
        # widget cell (06: 5 of 7, 09: 3 of 4); without it 0 of 18.
        # Without the hook the interact plots are ordinary cell outputs, which a static page shows anyway.
        def register_output_hook(self, msg_id, hook) -> None:
            return None

        def remove_output_hook(self, msg_id, hook) -> None:
            return None

    client = WatchedClient(
        nb,
        kernel_name="python3",
        timeout_func=cell_timeout,
        allow_errors=False,
        resources={"metadata": {"path": str(cwd)}},
        record_timing=True,
    )

    def started(cell, cell_index, **_):
        client.running_cell, client.last_message = cell.get("id", str(cell_index)), time.monotonic()

    def finished(cell, cell_index, **_):
        client.running_cell = None

    client.on_cell_execute, client.on_cell_executed = started, finished
    return client


async def _watch(client, stall_s: float, poll_s: float) -> None:
    """Return (raising ChapterStalled) when the running cell's kernel is silent and idle for ``stall_s``."""
    window: list[tuple[float, float]] = []  # (time, kernel CPU seconds)
    while True:
        await asyncio.sleep(poll_s)
        pid = getattr(getattr(client.km, "provisioner", None), "pid", None) if client.km is not None else None
        cpu, now = _process_cpu_seconds(pid), time.monotonic()
        if client.running_cell is None or cpu is None:
            window.clear()
            continue
        window.append((now, cpu))
        window[:] = [(t, c) for t, c in window if now - t <= stall_s + poll_s]
        silent = now - client.last_message >= stall_s
        span = now - window[0][0]
        idle = span >= stall_s and (cpu - window[0][1]) < _IDLE_CPU_FRACTION * span
        if silent and idle:
            raise ChapterStalled(
                f"cell {client.running_cell}: no message and no CPU from the kernel for "
                f"{now - client.last_message:.0f} s"
            )


async def _execute_once(client, stall_s: float, poll_s: float) -> None:
    run = asyncio.ensure_future(client.async_execute())
    watch = asyncio.ensure_future(_watch(client, stall_s, poll_s))
    try:
        done, _ = await asyncio.wait({run, watch}, return_when=asyncio.FIRST_COMPLETED)
        if watch in done:
            run.cancel()  # nbclient's own cleanup runs as the cancellation unwinds
            await asyncio.wait({run}, timeout=60)
            if run.done() and not run.cancelled():
                # Read the abandoned run's own error (a dead kernel): left unread, the garbage collector logs it
                # later from inside whatever code is running then.
                run.exception()
            watch.result()  # raises ChapterStalled
        run.result()  # raises the cell's error
    finally:
        watch.cancel()
        if client.km is not None:  # a kernel left behind by a stall
            try:
                await client._async_cleanup_kernel()
            except Exception:  # noqa: BLE001 - the kernel may already be gone
                pass
        atexit.unregister(client._cleanup_kernel)


def execute_chapter(
    source: str | Path,
    out_path: str | Path,
    *,
    previous: dict[str, float] | None = None,
    stall_s: float = STALL_S,
    attempts: int = ATTEMPTS,
    default_cell_timeout_s: float = DEFAULT_CELL_TIMEOUT_S,
    poll_s: float = 5.0,
    log=print,
) -> ChapterRun:
    """Execute notebook ``source`` (cwd = its folder) into ``out_path``, restarting it if its kernel stalls."""
    import nbformat
    from nbclient.exceptions import CellExecutionError, CellTimeoutError, DeadKernelError

    source, out_path = Path(source), Path(out_path)
    run = ChapterRun(source.stem)
    start = time.perf_counter()
    for attempt in range(1, attempts + 1):
        run.attempts = attempt
        nb = nbformat.read(source, as_version=4)
        client = _make_client(nb, source.parent.resolve(), previous or {}, default_cell_timeout_s)
        try:
            asyncio.run(_execute_once(client, stall_s, poll_s))
        except (ChapterStalled, CellTimeoutError, DeadKernelError) as hang:
            event = f"attempt {attempt}: {type(hang).__name__}: {str(hang).strip().splitlines()[0]}"
            run.events.append(event)
            log(f"{run.name}: {event}" + ("; restarting in a fresh kernel" if attempt < attempts else "; giving up"))
            continue
        except CellExecutionError as error:
            run.status, run.error = "failed", str(error)
            break
        run.status = "ok"
        break
    else:
        run.status, run.error = "failed", f"stalled {attempts} times: " + "; ".join(run.events)
    run.seconds = time.perf_counter() - start
    run.cell_seconds = _cell_seconds(nb)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, out_path)
    return run


def _cell_seconds(nb) -> dict[str, float]:
    from datetime import datetime

    seconds = {}
    for cell in nb.cells:
        timing = cell.get("metadata", {}).get("execution", {})
        begin, end = timing.get("iopub.execute_input"), timing.get("shell.execute_reply")
        if cell.cell_type == "code" and begin and end:
            parse = lambda s: datetime.fromisoformat(s.replace("Z", "+00:00"))  # noqa: E731
            seconds[cell.get("id", "")] = (parse(end) - parse(begin)).total_seconds()
    return seconds


# -- the book ------------------------------------------------------------------------------------------------------
def build_fingerprint(profile: str, home: str | Path) -> str:
    """A digest of what every chapter's outputs depend on besides its own source.

    The library's files (unlike Jupyter Book's cache, which ignores them), the profile, the precision the run
    resolves to (its models are other artefacts), and the model cache of that profile (names, sizes and
    modification times: a retrained model changes it). A chapter whose notebook and this digest are unchanged
    since it last executed successfully gives the same outputs again.
    """
    from ..precision import network_precision
    from ..train.device import get_device

    digest = hashlib.sha256(f"{profile}:{network_precision(get_device(None))}".encode())
    package = Path(__file__).resolve().parent.parent  # all of motionlab, not only build/
    for path in sorted(package.rglob("*")):
        if path.is_file() and "__pycache__" not in path.parts:
            digest.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes())
    home = Path(home)
    for path in sorted([*home.glob(f"models/*/{profile}/**/*"), *home.glob("data/**/*")]):
        if path.is_file():
            stat = path.stat()
            digest.update(f"{path.relative_to(home)}:{stat.st_size}:{stat.st_mtime_ns}".encode())
    return digest.hexdigest()


def _chapter_fingerprint(source: Path, fingerprint: str) -> str:
    return hashlib.sha256(fingerprint.encode() + source.read_bytes()).hexdigest()


def _execute_star(args: tuple) -> ChapterRun:
    source, out_path, previous, stall_s, attempts = args
    return execute_chapter(
        source,
        out_path,
        previous=previous,
        stall_s=stall_s,
        attempts=attempts,
        log=lambda text: print(text, flush=True),
    )


def runs_last(source: str | Path) -> bool:
    """Whether a chapter asks to run after all others (notebook metadata ``motionlab.run_last``)."""
    metadata = json.loads(Path(source).read_text()).get("metadata", {})
    return bool(metadata.get("motionlab", {}).get("run_last", False))


def load_timings(path: str | Path) -> dict[str, Any]:
    """A timings file written by :func:`execute_chapters` (``{}`` if there is none)."""
    path = Path(path)
    return json.loads(path.read_text()) if path.is_file() else {}


def execute_chapters(
    sources: Sequence[str | Path],
    out_dir: str | Path,
    *,
    jobs: int = 2,
    previous: dict[str, Any] | None = None,
    last: Collection[str] = (),
    stall_s: float = STALL_S,
    attempts: int = ATTEMPTS,
    fingerprint: str | None = None,
    out=None,
) -> list[ChapterRun]:
    """Execute ``sources`` into ``out_dir`` (same file names), ``jobs`` at a time, longest first.

    ``previous`` is an earlier timings file (chapter -> {"seconds", "cells", ...}): it orders the chapters and
    sets the per-cell timeouts. Chapters named in ``last`` start only when all the others have ended (e.g. a
    summary that reads what the others recorded). With a ``fingerprint`` (:func:`build_fingerprint`), a chapter
    whose notebook and fingerprint match its last successful execution, whose output is still in ``out_dir``,
    is kept instead of executed again (a ``last`` chapter only if no other chapter executed). Prints one line
    per chapter as it ends.
    """
    out = out or sys.stdout
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    previous = previous or {}
    out_dir, t0, runs = Path(out_dir), time.monotonic(), []

    def task(src: Path) -> tuple:
        return src, out_dir / src.name, previous.get(src.stem, {}).get("cells", {}), stall_s, attempts

    def longest_first(paths) -> list[Path]:  # unknown chapters count as long
        return sorted(paths, key=lambda p: -previous.get(p.stem, {}).get("seconds", 1e9))

    def up_to_date(src: Path) -> ChapterRun | None:
        before = previous.get(src.stem, {})
        if fingerprint is None or not (out_dir / src.name).is_file() or before.get("status") != "ok":
            return None
        mark = _chapter_fingerprint(src, fingerprint)
        if before.get("fingerprint") != mark:
            return None
        return ChapterRun(
            src.stem,
            "ok",
            float(before.get("seconds", 0.0)),
            int(before.get("attempts", 1)),
            cell_seconds=dict(before.get("cells", {})),
            fingerprint=mark,
            reused=True,
        )

    def report(run: ChapterRun) -> None:
        runs.append(run)
        stamp = f"{elapsed_stamp(time.monotonic() - t0)} {run.name}:"
        if run.reused:
            print(
                f"{stamp} up to date (notebook, library and models unchanged since it last ran)", file=out, flush=True
            )
            return
        note = f" after {run.attempts} attempts" if run.attempts > 1 else ""
        print(f"{stamp} {run.status} in {run.seconds / 60:.1f} min{note}", file=out, flush=True)
        if run.status != "ok":
            print(run.error, file=out, flush=True)

    paths = [Path(s) for s in sources]
    phases = [longest_first(p for p in paths if p.stem not in last), longest_first(p for p in paths if p.stem in last)]
    context = multiprocessing.get_context("spawn")
    with (
        native_threads_for_children(env_threads() or 1),
        ProcessPoolExecutor(jobs, mp_context=context, initializer=interrupt_when_orphaned) as pool,
    ):
        for phase in phases:
            executed = any(not r.reused for r in runs)
            kept = {src: up_to_date(src) for src in phase if not (executed and src.stem in last)}
            for run in filter(None, kept.values()):
                report(run)
            todo = [src for src in phase if kept.get(src) is None]
            # fingerprinted before they run: a notebook edited meanwhile must not look up to date next time
            marks = {src: _chapter_fingerprint(src, fingerprint) if fingerprint else "" for src in todo}
            futures = {pool.submit(_execute_star, task(src)): src for src in todo}
            for future in completed_until_ctrl_c(futures):
                run = future.result()
                run.fingerprint = marks[futures[future]]
                report(run)
    order = {p.stem: i for i, p in enumerate(paths)}
    return sorted(runs, key=lambda r: order[r.name])


def timings_record(runs: Sequence[ChapterRun], profile: str, wall_seconds: float) -> dict[str, Any]:
    """The timings file's content: per chapter its seconds, attempts, events and per-cell seconds."""
    return {
        "profile": profile,
        "wall_seconds": wall_seconds,
        **{
            r.name: {
                "seconds": r.seconds,
                "attempts": r.attempts,
                "events": r.events,
                "cells": r.cell_seconds,
                "status": r.status,
                "fingerprint": r.fingerprint,
            }
            for r in runs
        },
    }


def runs_table(runs: Sequence[ChapterRun]) -> str:
    lines = [f"{'chapter':<28} {'status':<7} {'minutes':>8} {'attempts':>9}"]
    for r in runs:
        lines.append(f"{r.name:<28} {r.status:<7} {r.seconds / 60:>8.1f} {r.attempts:>9}")
    return "\n".join(lines)


# -- rendering without executing again -----------------------------------------------------------------------------
def stage_site(repo: str | Path, executed_dir: str | Path, stage: str | Path) -> Path:
    """A copy of the book's sources in ``stage`` whose chapters are the executed notebooks of ``executed_dir``.

    The copied ``_config.yml`` tells Jupyter Book not to execute ``notebooks/*`` again (other pages, e.g.
    MyST pages with code, still execute). Returns the staged ``_config.yml``'s folder.
    """
    import yaml

    repo, executed_dir, stage = Path(repo), Path(executed_dir), Path(stage)
    if stage.exists():
        shutil.rmtree(stage)
    stage.mkdir(parents=True)
    shutil.copytree(repo / "book", stage / "book")
    shutil.copytree(executed_dir, stage / "notebooks")
    config = yaml.safe_load((repo / "_config.yml").read_text())
    config.setdefault("execute", {})["exclude_patterns"] = ["notebooks/*"]
    (stage / "_config.yml").write_text(yaml.safe_dump(config, sort_keys=False))
    vendor = repo / "_build" / "vendor"
    if vendor.is_dir():  # html_static_path is relative to the config's folder
        (stage / "_build").mkdir()
        (stage / "_build" / "vendor").symlink_to(vendor.resolve(), target_is_directory=True)
    return stage


__all__ = [
    "ATTEMPTS",
    "STALL_S",
    "ChapterRun",
    "ChapterStalled",
    "execute_chapter",
    "execute_chapters",
    "load_timings",
    "runs_last",
    "runs_table",
    "stage_site",
    "timings_record",
]
