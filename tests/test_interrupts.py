import signal

import pytest

from motionlab.interrupts import DeferredInterrupt


def deliver(signum: int) -> None:
    """Send ``signum`` to this process. Where deferring it fails, the KeyboardInterrupt it raises fails this test
    instead of stopping the whole pytest run (which a KeyboardInterrupt reaching pytest does)."""
    try:
        signal.raise_signal(signum)
    except KeyboardInterrupt:
        pytest.fail(f"{signal.Signals(signum).name} was not deferred: it interrupted the program")


def test_only_the_chosen_signals_are_deferred_and_the_handlers_come_back():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with DeferredInterrupt(signals=(signal.SIGINT,)) as ctrl_c:
        assert signal.getsignal(signal.SIGTERM) is before[signal.SIGTERM]  # not listening to SIGTERM
        deliver(signal.SIGINT)  # noted, not raised
        assert ctrl_c.requested == signal.SIGINT
        assert signal.getsignal(signal.SIGINT) is before[signal.SIGINT]  # a second Ctrl-C would act at once
    assert {s: signal.getsignal(s) for s in before} == before


def test_nothing_is_noted_without_a_signal_and_a_disabled_one_changes_nothing():
    with DeferredInterrupt() as quiet:
        pass
    assert quiet.requested is None
    handler = signal.getsignal(signal.SIGINT)
    with DeferredInterrupt(enabled=False):
        assert signal.getsignal(signal.SIGINT) is handler
