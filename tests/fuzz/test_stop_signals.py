"""Ctrl-C and SIGTERM during a campaign (fuzz/running/stop_signals.py): the first raises KeyboardInterrupt
(once), a second kills; a block that must not be cut (a message on a pipe) gets the interrupt at
its end; after ``hold`` a first signal is only counted. Real signals to this process."""
from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from buildhat_conformance.fuzz.running.stop_signals import StopSignals

pytestmark = pytest.mark.skipif(threading.current_thread() is not threading.main_thread(),
                                reason="signal handlers are the main thread's")


def _signal(sig: int = signal.SIGINT) -> None:
    os.kill(os.getpid(), sig)
    time.sleep(0.05)            # the handler runs in this (main) thread at the next chance


def test_the_first_signal_interrupts_once_and_the_second_kills(capfd):
    killed, actions = [], []
    before = signal.getsignal(signal.SIGINT)
    with StopSignals(say="stopping", kill=lambda: killed.append(True)) as stops:
        stops.at_kill(lambda: actions.append("workers"))
        with pytest.raises(KeyboardInterrupt):
            _signal(signal.SIGTERM)
        assert stops.stopped and not killed
        _signal()                       # cleaning up: not interrupted again, the process is killed
        assert killed == [True] and actions == ["workers"]
    assert signal.getsignal(signal.SIGINT) is before
    assert capfd.readouterr().err.count("stopping") == 1


def test_a_signal_inside_a_deferring_block_comes_at_its_end():
    done = []
    with StopSignals(kill=lambda: None) as stops:
        with pytest.raises(KeyboardInterrupt):
            with stops.deferring():
                _signal()
                done.append("the whole message")
        assert done == ["the whole message"]
        with stops.deferring():         # after the first signal: nothing more is raised
            pass


def test_after_hold_a_first_signal_is_only_counted():
    killed = []
    with StopSignals(kill=lambda: killed.append(True)) as stops:
        stops.hold()
        _signal()
        assert stops.received == 1 and not killed
        _signal()
        assert killed == [True]
