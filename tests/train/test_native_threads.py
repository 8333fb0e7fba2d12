"""Child processes get one BLAS/OpenMP thread each unless the user chose otherwise."""

import os
import signal
import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import pytest

from motionlab.build.workers import NATIVE_THREAD_VARIABLES, completed_until_ctrl_c, native_threads_for_children


def _child_env() -> dict[str, str]:
    code = f"import os; print(' '.join(os.environ.get(v, '-') for v in {NATIVE_THREAD_VARIABLES!r}))"
    values = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    return dict(zip(NATIVE_THREAD_VARIABLES, values))


def test_children_start_with_the_given_threads_and_the_environment_is_restored(monkeypatch):
    for name in NATIVE_THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    with native_threads_for_children(1):
        assert _child_env() == {name: "1" for name in NATIVE_THREAD_VARIABLES}
    assert not any(name in os.environ for name in NATIVE_THREAD_VARIABLES)


def test_a_value_the_user_set_is_kept(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    with native_threads_for_children(1):
        env = _child_env()
    assert env["OMP_NUM_THREADS"] == "3" and env["OPENBLAS_NUM_THREADS"] == "1"
    assert os.environ["OMP_NUM_THREADS"] == "3"


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_rejects_a_bad_thread_count(bad):
    with pytest.raises(ValueError, match="positive int"):
        with native_threads_for_children(bad):
            pass


_ORPHANING_PARENT = """
import sys, time
from concurrent.futures import ProcessPoolExecutor
import multiprocessing
from motionlab.build.workers import interrupt_when_orphaned

def work(path):
    import os
    open(path, "w").write(str(os.getpid()))
    try:
        time.sleep(60)
    except KeyboardInterrupt:
        open(path + ".interrupted", "w").write("yes")
        raise

if __name__ == "__main__":
    pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                               initializer=interrupt_when_orphaned, initargs=(0.1, 1.0))
    pool.submit(work, sys.argv[1])
    time.sleep(60)
"""


def test_a_worker_whose_parent_is_killed_is_interrupted(tmp_path):
    import signal
    import time

    script = tmp_path / "parent.py"
    script.write_text(_ORPHANING_PARENT)
    marker = tmp_path / "worker.pid"
    parent = subprocess.Popen([sys.executable, str(script), str(marker)], cwd=tmp_path)
    try:
        deadline = time.monotonic() + 60
        while not marker.exists() or not marker.read_text():
            assert time.monotonic() < deadline, "the worker never started"
            time.sleep(0.1)
        worker = int(marker.read_text())
        os.kill(parent.pid, signal.SIGKILL)  # a signal the parent cannot catch: no cleanup of its pool
        parent.wait()
        deadline = time.monotonic() + 20
        while not (tmp_path / "worker.pid.interrupted").exists():
            assert time.monotonic() < deadline, "the orphaned worker went on running"
            time.sleep(0.1)
    finally:
        parent.kill()
    deadline = time.monotonic() + 20
    while _alive(worker):
        assert time.monotonic() < deadline, "the orphaned worker did not exit"
        time.sleep(0.1)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    status = open(f"/proc/{pid}/stat").read().split()[2] if os.path.exists(f"/proc/{pid}/stat") else "X"
    return status not in ("Z", "X")


def test_elapsed_stamp_is_minutes_and_seconds():
    from motionlab.build.workers import elapsed_stamp

    assert elapsed_stamp(0) == "[  0:00]"
    assert elapsed_stamp(61.9) == "[  1:01]"
    assert elapsed_stamp(3600 + 5) == "[ 60:05]"


def test_completed_until_ctrl_c_yields_every_result_and_stops_between_two_on_ctrl_c():
    handler, gate = signal.getsignal(signal.SIGINT), threading.Event()
    with ThreadPoolExecutor(2) as pool:
        powers = [pool.submit(pow, 2, n) for n in range(4)]
        assert sorted(f.result() for f in completed_until_ctrl_c(powers)) == [1, 2, 4, 8]
        quick, held = pool.submit(int, 1), pool.submit(gate.wait)
        seen = []
        try:
            with pytest.raises(KeyboardInterrupt, match="waiting for the workers"):
                for future in completed_until_ctrl_c([quick, held], poll_s=0.05):
                    seen.append(future)
                    signal.raise_signal(signal.SIGINT)  # noted while the caller handles a result, raised next
            assert seen == [quick] and not held.done()
        finally:
            gate.set()
    assert signal.getsignal(signal.SIGINT) is handler
