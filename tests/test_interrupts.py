import signal

from motionlab.interrupts import DeferredInterrupt


def test_only_the_chosen_signals_are_deferred_and_the_handlers_come_back():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with DeferredInterrupt(signals=(signal.SIGINT,)) as ctrl_c:
        assert signal.getsignal(signal.SIGTERM) is before[signal.SIGTERM]  # not listening to SIGTERM
        signal.raise_signal(signal.SIGINT)  # noted, not raised
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
