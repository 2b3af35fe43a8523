"""A signal whose exception Python swallows is still acted on (drumroll.interruption).

The case seen in the suite under load: SIGTERM arrived while a garbage collection ran a
weakref callback during the writing; Python printed the Terminated exception as "ignored" and
the command finished with exit 0 and its outputs in place."""

from __future__ import annotations

import argparse
import gc
import os
import signal

import pytest

from drumroll import interruption

# Python reports the swallowed exception itself ("Exception ignored in ... __del__"): that is
# the case under test, not a fault of the test.
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")


class _SignalledWhileCollected:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)  # delivered here: inside __del__


def test_a_signal_swallowed_in_a_destructor_is_raised_at_the_next_check():
    previous = interruption.install()
    try:
        obj = _SignalledWhileCollected()
        del obj  # the handler's exception is printed as ignored, not raised
        gc.collect()
        with pytest.raises(interruption.Terminated):
            interruption.raise_if_interrupted()
        interruption.raise_if_interrupted()  # acted on once
    finally:
        interruption.restore(previous)
    assert signal.getsignal(signal.SIGTERM) == previous[signal.SIGTERM]


def test_a_swallowed_sigterm_ends_the_command_with_143(capsys):
    from drumroll.cli.main import run_cli

    def command(args):
        obj = _SignalledWhileCollected()
        del obj  # swallowed: the command itself returns 0
        return 0

    def make_parser():
        parser = argparse.ArgumentParser(prog="drumroll")
        parser.set_defaults(func=command)
        return parser

    assert run_cli(make_parser, []) == 143
    assert capsys.readouterr().err.strip().endswith("terminated; no partial output was kept")
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_hang_up_ends_the_command_as_sigterm_does_with_129(capsys):
    """SIGHUP (a closed terminal, a dropped SSH session) is handled, not left to kill the
    command outright with its staging and workers behind: one line, exit 128 + 1."""
    from drumroll.cli.main import run_cli

    def make_parser():
        parser = argparse.ArgumentParser(prog="drumroll")
        parser.set_defaults(func=lambda args: os.kill(os.getpid(), signal.SIGHUP))
        return parser

    assert run_cli(make_parser, []) == 128 + signal.SIGHUP
    assert capsys.readouterr().err.strip().endswith("hung up; no partial output was kept")
