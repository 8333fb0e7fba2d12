"""Worker processes of the book's parallel jobs (training plan, chapter execution): what they inherit, how they end."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Collection, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, wait
from contextlib import contextmanager

from ..interrupts import DeferredInterrupt

# The thread pools of the native libraries under torch and numpy (OpenMP, OpenBLAS, MKL), read once at import.
NATIVE_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def elapsed_stamp(seconds: float) -> str:
    """``[mm:ss]`` since a pool started: the prefix of every progress line the pools print."""
    return f"[{int(seconds // 60):3d}:{int(seconds % 60):02d}]"


@contextmanager
def native_threads_for_children(threads: int) -> Iterator[None]:
    """Inside the block, child processes start with ``threads`` OpenMP/BLAS threads (values the user set win).

    Why: ``torch.set_num_threads`` does not reach numpy's OpenBLAS, which starts one thread per core in every
    process. Two chapters executing side by side on 2 cores then oversubscribe them; a 512-dim FID (a matrix
    square root) took 4x the wall time it takes with one BLAS thread per process (measured on the 2-core
    reference machine). Spawned workers copy the environment when they start, so the block must cover them.
    """
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be a positive int, got {threads!r}")
    added = [name for name in NATIVE_THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = str(threads)
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


def interrupt_when_orphaned(poll_s: float = 2.0, grace_s: float = 60.0) -> threading.Thread:
    """Start a daemon thread that ends this worker once its parent process is gone.

    Why: a pool worker outlives a parent killed by a signal it cannot catch, and a chapter runner's worker then
    goes on executing (and restarting) its chapter in a kernel nobody waits for. The worker is first interrupted
    like Ctrl-C, so its own cleanup (shutting down its kernel) runs; ``grace_s`` later it exits, because an idle
    pool worker would otherwise wait forever for its next task.
    """
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll_s)
        os.kill(os.getpid(), signal.SIGINT)  # a real signal: it also wakes a main thread blocked in a wait
        time.sleep(grace_s)
        os._exit(1)

    thread = threading.Thread(target=watch, name="exit-with-parent", daemon=True)
    thread.start()
    return thread


def completed_until_ctrl_c(futures: Collection[Future], poll_s: float = 1.0) -> Iterator[Future]:
    """Each of ``futures`` as it completes, like :func:`concurrent.futures.as_completed`, but a Ctrl-C meanwhile is
    raised as ``KeyboardInterrupt`` here, between two results, and never inside the wait, where it can break the
    wait's lock (see :mod:`motionlab.interrupts`). A Ctrl-C reaches the interrupted loop within ``poll_s``."""
    left = set(futures)
    with DeferredInterrupt(signals=(signal.SIGINT,)) as ctrl_c:
        while left and not ctrl_c.requested:
            done, left = wait(left, timeout=poll_s, return_when=FIRST_COMPLETED)
            for future in done:
                if ctrl_c.requested:
                    break
                yield future
    if ctrl_c.requested:
        raise KeyboardInterrupt("interrupted while waiting for the workers")
