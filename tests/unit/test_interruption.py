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


@pytest.mark.parametrize("becomes", [ImportError("initialization failed"),
                                     OSError(5, "Input/output error"), ValueError("NaN")])
def test_a_signal_whose_exception_became_another_still_ends_as_the_signal(capsys, becomes):
    """SIGTERM during the sampling's first import of a C extension came out of the import as
    "ImportError: initialization failed" and the command reported an internal error, exit 1
    (seen in CI, tests/integration/test_faults.py). Whatever ends a command after a signal
    came is the signal's: one line, exit 143."""
    from drumroll.cli.main import run_cli

    def command(args):
        try:
            os.kill(os.getpid(), signal.SIGTERM)  # the handler raises Terminated here
        except KeyboardInterrupt:
            raise becomes from None

    def make_parser():
        parser = argparse.ArgumentParser(prog="drumroll")
        parser.set_defaults(func=command)
        return parser

    assert run_cli(make_parser, []) == 143
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["drumroll: terminated; no partial output was kept"]


def test_an_error_without_a_signal_is_still_reported_as_itself(capsys):
    """The same exceptions with no signal: an internal error, exit 1 (a stale signal of an
    earlier command does not carry over: install() clears it)."""
    from drumroll.cli.main import run_cli

    def make_parser():
        parser = argparse.ArgumentParser(prog="drumroll")
        parser.set_defaults(func=lambda args: (_ for _ in ()).throw(ImportError("nope")))
        return parser

    assert run_cli(make_parser, []) == 1
    assert "internal error" in capsys.readouterr().err
