"""The command line's handling of what the libraries say (drumroll.cli.main.run_cli): their
log records, numpy's floating-point warnings, errors in destructors."""

from __future__ import annotations

import argparse
import gc

import emcee
import numpy as np

from drumroll.cli.main import run_cli


def command(work):
    """A parser whose command runs ``work`` (what a subcommand's ``run`` is to run_cli)."""
    def make() -> argparse.ArgumentParser:
        parser = argparse.ArgumentParser(prog="drumroll")
        parser.set_defaults(func=lambda args: work() or 0)
        return parser

    return make


def short_chains() -> None:
    """emcee's autocorrelation time of a chain too short for it, as nine runs of a table
    would ask it: emcee logs a warning of several lines each time."""
    chain = np.random.default_rng(0).standard_normal((100, 8, 3)).cumsum(axis=0)
    for _ in range(9):
        emcee.autocorr.integrated_time(chain, quiet=True)


def test_library_log_warnings_are_not_shown_and_debug_shows_one_line(capsys):
    assert run_cli(command(short_chains), []) == 0
    assert capsys.readouterr().err == ""
    assert run_cli(command(short_chains), ["--debug"]) == 0
    [line] = capsys.readouterr().err.splitlines()
    assert line.startswith("drumroll: warning: emcee.autocorr: The chain is shorter than 50 "
                           "times the integrated autocorrelation time")


def overflow() -> None:
    np.exp(np.array([1000.0]))


def overflow_twice() -> None:  # (Python reports a warning once per place: other places)
    np.exp(np.array([1000.0]))
    np.exp(np.array([2000.0]))


def test_floating_point_warnings_only_with_debug(capsys):
    assert run_cli(command(overflow), []) == 0
    assert capsys.readouterr().err == ""
    assert run_cli(command(overflow_twice), ["--debug"]) == 0
    lines = capsys.readouterr().err.splitlines()  # with where each came from
    assert len(lines) == 2 and all(line.startswith(
        "drumroll: warning: overflow encountered in exp (RuntimeWarning, ") for line in lines)


class _Leaky:
    def __del__(self):
        raise ValueError("closing failed\nsecond line")


def cleanup_error() -> None:
    _Leaky()
    gc.collect()


def test_an_error_in_a_destructor_is_one_line(capsys):
    assert run_cli(command(cleanup_error), []) == 0
    assert capsys.readouterr().err == ("drumroll: warning: an error while cleaning up was "
                                       "ignored (ValueError: closing failed second line)\n")
