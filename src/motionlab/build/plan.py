"""Train a set of models that depend on one another, several at a time, each in its own process.

A :class:`Job` names a model, the jobs it needs first (``after``), a picklable function that trains it
(or loads it when cached) and the expected seconds. :func:`run_plan` skips what is already cached, starts
every job whose inputs are ready in a worker process (up to ``jobs`` at once, one torch thread each: on a
2-core machine two 1-thread processes are faster and better behaved than one 2-thread process), prints
one progress line per model and returns a table of times.

Nothing here knows about motion: :mod:`motionlab.build.book_models` lists the book's models. Interrupting a
plan is safe: each model publishes its cache folder by one atomic rename when it is done (see
:mod:`motionlab.train.cache`), so a second run skips what finished and retrains (or resumes) the rest.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, TextIO

from ..interrupts import DeferredInterrupt
from ..settings import cpu_load
from ..train.progress import add_progress_hook, disable_bars
from .workers import elapsed_stamp, interrupt_when_orphaned, native_threads_for_children

_REPORT_EVERY_S = 2.0  # how often a worker forwards its step count


@dataclass(frozen=True)
class Job:
    """One model to train: ``run()`` trains it or loads it; ``is_cached()`` says whether it may be skipped."""

    name: str
    run: Callable[[], Any]
    after: tuple[str, ...] = ()
    estimate_s: float = 0.0  # expected training seconds on one core of the reference machine
    is_cached: Callable[[], bool] | None = None
    # Seconds spent compiling the job's networks before it trains (0: nothing compiled; None: compiled, not measured).
    compile_s: float | None = 0.0

    @property
    def expected_s(self) -> float:
        """Training plus (measured) compiling seconds."""
        return self.estimate_s + (self.compile_s or 0.0)


@dataclass
class JobResult:
    name: str
    status: str  # "cached" | "trained" | "failed" | "skipped" (an input failed) | "interrupted"
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    estimate_s: float = 0.0
    error: str = ""


@dataclass
class _Running:
    job: Job
    started: float
    pool: ProcessPoolExecutor  # the job's own one-worker pool (see _Scheduler)
    step: int = 0
    total: int = 0
    last_line: float = field(default=0.0)


def check_plan(jobs: Sequence[Job]) -> None:
    """Names unique, every ``after`` known and earlier in the list (so the list is a valid order)."""
    seen: set[str] = set()
    for job in jobs:
        if job.name in seen:
            raise ValueError(f"job {job.name!r} appears twice in the plan")
        missing = [dep for dep in job.after if dep not in seen]
        if missing:
            raise ValueError(f"job {job.name!r} needs {missing}, which are not listed before it")
        seen.add(job.name)


def missing_jobs(jobs: Sequence[Job]) -> list[Job]:
    """The jobs whose models are not in the cache yet, in plan order."""
    return [job for job in jobs if job.is_cached is None or not job.is_cached()]


def format_minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min"


def plan_line(jobs: Sequence[Job], workers: int = 1) -> str:
    """One sentence saying what will be trained and roughly how long it takes (``""`` when nothing is missing)."""
    return _describe(missing_jobs(jobs), workers)


def load_slowdown(workers: int = 1) -> tuple[float, float, int]:
    """How many times longer than on an idle machine ``workers`` one-thread processes take now, with the load and
    the cores it is read from: the other tasks that want a core now (:func:`motionlab.settings.cpu_load`) share the
    cores with them (1.0 where the load cannot be read, or the cores are enough for all)."""
    cores = os.cpu_count() or 1
    load = cpu_load()
    if load is None:
        return 1.0, 0.0, cores
    return max(1.0, (load + workers) / cores), load, cores


def _describe(todo: Sequence[Job], workers: int) -> str:
    """The plan line for jobs already known to be missing (each cache check loads models: done once).

    It leads with what a reader waits for, the wall time, and gives the CPU minutes only when they differ from it
    (several workers), e.g. ``training 3 models first: about 0.5 min (fp32, ...): data, tokenizer/vq, t2m/dynamic``.
    Jobs that compile their networks first count the compile time in it and are named after the list.
    """
    if not todo:
        return ""
    total = sum(job.expected_s for job in todo)
    wall = expected_wall_seconds(todo, workers)
    names = ", ".join(job.name for job in todo)
    when = f"about {format_minutes(wall)}"
    if workers > 1:
        when += f" with {workers} workers, {format_minutes(total)} of CPU"
    slower, load, cores = load_slowdown(workers)
    if slower >= 1.25:  # the estimate is for an idle machine: say what the load seen now makes of it
        when += f", up to {format_minutes(wall * slower)} at this machine's load now ({load:.1f} on {cores} cores)"
    from ..precision import explain_precision
    from ..train.device import get_device

    precision, why = explain_precision(None, get_device(None))
    count = f"{len(todo)} model{'s' if len(todo) != 1 else ''}"
    line = f"training {count} first: {when} ({precision}, {why}; at the pace of the slowest CPU measured): {names}"
    return line + _compiling(todo)


def _compiling(todo: Sequence[Job]) -> str:
    """What the plan line adds for jobs that compile first, e.g. ``"; 0.9 min of it compiling discord/rvq, discord/vq;
    the compiled kernels are cached for the next run"``; ``""`` when nothing compiles."""
    measured = [job for job in todo if job.compile_s]
    unmeasured = [job.name for job in todo if job.compile_s is None]
    if not measured and not unmeasured:
        return ""
    parts = []
    if measured:
        seconds = sum(job.compile_s for job in measured)
        parts.append(f"{format_minutes(seconds)} of it compiling {', '.join(job.name for job in measured)}")
    if unmeasured:
        verb = "compiles" if len(unmeasured) == 1 else "compile"
        parts.append(f"{', '.join(unmeasured)} also {verb} first, for a time not measured")
    return "; " + "; ".join(parts) + "; the compiled kernels are cached for the next run"


def expected_wall_seconds(jobs: Sequence[Job], workers: int) -> float:
    """Wall time of a greedy schedule of ``jobs`` on ``workers`` workers, from their estimates."""
    names = {job.name for job in jobs}
    finish: dict[str, float] = {}
    free = [0.0] * max(1, workers)
    for job in jobs:  # plan order is a valid order; greedy list scheduling
        ready = max((finish[d] for d in job.after if d in names), default=0.0)
        slot = min(range(len(free)), key=free.__getitem__)
        start = max(free[slot], ready)
        finish[job.name] = free[slot] = start + job.expected_s
    return max(finish.values(), default=0.0)


# -- worker side ---------------------------------------------------------------------------------------------------
_queue: Any = None


def _init_worker(queue: Any, threads: int) -> None:
    """Runs once in each worker process: one torch thread, no progress bars, steps forwarded to the parent."""
    global _queue
    _queue = queue
    interrupt_when_orphaned()  # a job whose plan is gone stops (its checkpoints stay) instead of training on
    disable_bars()
    import torch

    torch.set_num_threads(threads)


def _run_job(name: str, run: Callable[[], Any]) -> float:
    """Run one job in this worker; returns its CPU seconds (the parent times the wall clock)."""
    last = [0.0]

    def forward(_desc: str, step: int, total: int) -> None:
        now = time.monotonic()
        if now - last[0] >= _REPORT_EVERY_S or step == total:
            last[0] = now
            _queue.put((name, step, total))

    add_progress_hook(forward)
    cpu = time.process_time()
    run()
    return time.process_time() - cpu


# -- parent side ---------------------------------------------------------------------------------------------------
def run_plan(
    jobs: Sequence[Job],
    workers: int = 2,
    *,
    threads: int = 1,
    out: TextIO | None = None,
    line_every_s: float = 30.0,
) -> list[JobResult]:
    """Train every job that is not cached, ``workers`` at a time; returns one :class:`JobResult` per job.

    Prints a line when a model starts, every ``line_every_s`` while it trains (step, elapsed, estimated
    remaining) and when it ends. A failed job fails the jobs after it (``skipped``); the others go on.
    On Ctrl-C the workers stop, finished models stay cached, and ``KeyboardInterrupt`` is re-raised.
    """
    check_plan(jobs)
    if workers < 1 or threads < 1:
        raise ValueError(f"workers and threads must be >= 1, got workers={workers}, threads={threads}")
    results = {job.name: JobResult(job.name, "cached", estimate_s=job.expected_s) for job in jobs}
    pending = missing_jobs(jobs)
    for job in pending:
        results[job.name].status = "pending"
    if pending:
        out = out or sys.stdout
        print(_describe(pending, workers), file=out, flush=True)
        # Workers are spawned lazily and inherit the environment: one OpenMP thread each.
        with _environment(OMP_NUM_THREADS=str(threads)):
            _Scheduler(results, workers, threads, out, line_every_s).run(pending)
    return [results[job.name] for job in jobs]


class _Scheduler:
    """Starts jobs whose inputs are done, collects results and progress, prints the lines.

    Each job runs in a fresh process of its own one-worker pool (a model's memory is returned when it ends). Not one
    pool with ``max_tasks_per_child=1``: CPython 3.11–3.14 replaces such a worker from its manager thread even while
    the pool shuts down, so a Ctrl-C could leave a just-spawned worker that no sentinel reaches, and the interpreter
    then waits for it at exit (python/cpython#119592; measured here: the manager thread died with a ``KeyError``).
    """

    def __init__(self, results: dict[str, JobResult], workers: int, threads: int, out: TextIO, line_every_s: float):
        self.results, self.workers, self.threads, self.out = results, workers, threads, out
        self.line_every_s = line_every_s
        self.done = {name for name, r in results.items() if r.status == "cached"}
        self.running: dict[Future, _Running] = {}
        self.t0 = time.monotonic()
        self.context = multiprocessing.get_context("spawn")  # no inherited torch threads or locks
        self.queue = self.context.Queue()

    def submit(self, job: Job) -> None:
        pool = ProcessPoolExecutor(
            max_workers=1, mp_context=self.context, initializer=_init_worker, initargs=(self.queue, self.threads)
        )
        self.running[pool.submit(_run_job, job.name, job.run)] = _Running(job, time.monotonic(), pool)

    def say(self, text: str) -> None:
        print(f"{elapsed_stamp(time.monotonic() - self.t0)} {text}", file=self.out, flush=True)

    def run(self, pending: list[Job]) -> None:
        with native_threads_for_children(self.threads):
            self._run(pending)

    def _run(self, pending: list[Job]) -> None:
        try:
            # A Ctrl-C raised inside wait() can break the lock of the condition it waits on (see
            # motionlab.interrupts): the signal is only noted, and the loop stops at its next turn.
            with DeferredInterrupt(signals=(signal.SIGINT,)) as ctrl_c:
                while (pending or self.running) and not ctrl_c.requested:
                    self.start_ready(pending)
                    if self.running:
                        finished, _ = wait(list(self.running), timeout=1.0, return_when=FIRST_COMPLETED)
                        if ctrl_c.requested:  # the workers had it too: what they ended with is not a result
                            break
                        _drain(self.queue, self.running)
                        for future in finished:
                            self.collect(future)
                        self.report_progress()
            if ctrl_c.requested:
                raise KeyboardInterrupt("the plan was interrupted; finished models stay cached")
        except KeyboardInterrupt:
            for state in self.running.values():
                self.results[state.job.name].status = "interrupted"
            raise
        finally:
            # the workers had the same SIGINT (one process group): each job stops, its pool joins its one worker
            for state in self.running.values():
                state.pool.shutdown(wait=True, cancel_futures=True)

    def start_ready(self, pending: list[Job]) -> None:
        for job in list(pending):
            failed_inputs = [d for d in job.after if self.results[d].status in ("failed", "skipped")]
            if failed_inputs:
                pending.remove(job)
                self.results[job.name].status = "skipped"
                self.results[job.name].error = f"needs {', '.join(failed_inputs)}"
                self.say(f"{job.name}: skipped (it needs {', '.join(failed_inputs)}, which failed)")
            elif len(self.running) < self.workers and all(d in self.done for d in job.after):
                pending.remove(job)
                self.submit(job)
                self.say(f"{job.name}: started (expected {format_minutes(job.expected_s)})")

    def collect(self, future: Future) -> None:
        state = self.running.pop(future)
        state.pool.shutdown(wait=True)  # its worker has nothing left to run: it exits at once
        result = self.results[state.job.name]
        result.seconds = time.monotonic() - state.started
        try:
            result.cpu_seconds = future.result()
        except KeyboardInterrupt:  # the worker alone was interrupted (its own Ctrl-C): so is the plan
            result.status = "interrupted"
            raise
        except Exception as error:  # noqa: BLE001 - reported in the table; the jobs after it are skipped
            result.status, result.error = "failed", f"{type(error).__name__}: {error}"
            self.say(f"{state.job.name}: FAILED after {format_minutes(result.seconds)}: {result.error}")
            return
        result.status = "trained"
        self.done.add(state.job.name)
        self.say(f"{state.job.name}: done in {format_minutes(result.seconds)}")

    def report_progress(self) -> None:
        now = time.monotonic()
        for state in self.running.values():
            if now - state.last_line >= self.line_every_s and now - state.started >= self.line_every_s:
                state.last_line = now
                self.say(_progress_text(state, now))


@contextmanager
def _environment(**values: str) -> Iterator[None]:
    saved = {key: os.environ.get(key) for key in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _drain(queue: Any, running: dict[Future, _Running]) -> None:
    by_name = {state.job.name: state for state in running.values()}
    while not queue.empty():
        try:
            name, step, total = queue.get_nowait()
        except Exception:  # noqa: BLE001 - an empty or closed queue just means no news
            return
        if name in by_name:
            by_name[name].step, by_name[name].total = step, total


def _progress_text(state: _Running, now: float) -> str:
    elapsed = now - state.started
    if state.total and state.step:
        left = elapsed / state.step * (state.total - state.step)
        return (
            f"{state.job.name}: step {state.step:,}/{state.total:,}, {format_minutes(elapsed)} elapsed, "
            f"~{format_minutes(left)} left"
        )
    left = max(state.job.expected_s - elapsed, 0.0)
    return f"{state.job.name}: preparing, {format_minutes(elapsed)} elapsed, ~{format_minutes(left)} left (estimate)"


def results_table(results: Sequence[JobResult]) -> str:
    """The final table: one row per model with its status, wall and CPU time and the estimate."""
    lines = [f"{'model':<34} {'status':<11} {'wall':>9} {'CPU':>9} {'expected':>9}"]
    for r in results:
        timed = r.status in ("trained", "failed")
        wall = format_minutes(r.seconds) if timed else "-"
        cpu = format_minutes(r.cpu_seconds) if r.status == "trained" else "-"
        lines.append(
            f"{r.name:<34} {r.status:<11} {wall:>9} {cpu:>9} {format_minutes(r.estimate_s):>9}"
            + (f"  {r.error}" if r.error else "")
        )
    trained = [r for r in results if r.status == "trained"]
    if trained:
        lines.append(f"{len(trained)} trained, {format_minutes(sum(r.cpu_seconds for r in trained))} of CPU in all")
    return "\n".join(lines)


__all__ = [
    "Job",
    "JobResult",
    "check_plan",
    "expected_wall_seconds",
    "missing_jobs",
    "plan_line",
    "results_table",
    "run_plan",
]
