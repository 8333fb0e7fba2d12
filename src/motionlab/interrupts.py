"""Ctrl-C at a point of the program's choosing: a signal handler that only takes note.

Python raises ``KeyboardInterrupt`` between any two bytecodes of the main thread, including inside the lock
handling of :mod:`threading` while a ``concurrent.futures.wait`` blocks; there it can leave a condition's lock
released twice, and the program then stops with ``RuntimeError: release unlocked lock`` instead of the interrupt.
A training loop has a second reason to defer: the step under way should finish and be checkpointed. The training
loop and the loops that wait on worker processes enter :class:`DeferredInterrupt` and look at
:attr:`~DeferredInterrupt.requested` where stopping is safe.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Sequence
from typing import Any

__all__ = ["DeferredInterrupt"]


class DeferredInterrupt:
    """While entered (and ``enabled``), the first of ``signals`` only sets :attr:`requested` to its number: the
    loop decides where to stop. The handler that was there before comes back at once, so a second signal of the same
    kind acts wherever the program is. Off the main thread, where signals cannot be handled, and for a signal the
    process ignores or whose handler Python did not install, nothing changes."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self, enabled: bool = True, signals: Sequence[int] = SIGNALS):
        self.requested: int | None = None
        self._enabled = enabled
        self._signals = tuple(signals)
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> DeferredInterrupt:
        if self._enabled and threading.current_thread() is threading.main_thread():
            for signum in self._signals:
                previous = signal.getsignal(signum)
                # None: a handler set outside Python, which could not be put back; SIG_IGN: the process ignores the
                # signal (Ctrl-C in a shell's background job), and a loop inside it must not start to listen
                if previous not in (None, signal.SIG_IGN):
                    self._previous[signum] = previous
                    signal.signal(signum, self._request)
        return self

    def _request(self, signum: int, frame) -> None:
        if self.requested is None:
            self.requested = signum
        signal.signal(signum, self._previous.pop(signum))

    def __exit__(self, *exc) -> None:
        for signum, previous in self._previous.items():
            signal.signal(signum, previous)
        self._previous = {}
