"""Fuzzing the command line's options (issue 14, section 3): no argument list ends in a
traceback or an exit status other than 0 (done) or 2 (the user's to fix, one line).

Each example is a subcommand with its positional argument and options, drawn from the
parser itself (so that an option added later is fuzzed too), each option given a value from
a pool of right and wrong ones: numbers at and beyond their limits, words, empty strings,
existing, missing and unwritable paths, suffixes no writer knows. They run in-process on a
fresh copy of a folder of small inputs (a ball's onsets, a quick config, a short recording,
a runs file), as a user would type them there.

The fast test never lets ``estimate`` sample (its outputs exist, and ``--force`` is not in
its pool); the slow one does, with ``--force`` and fresh outputs.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from configs import BALL_CONFIG
from drumroll.cli.main import build_parser, main
from paths import DATA
from tests.unit.onsets.test_formats import plausible_csv_files

#: A ball's config that samples in a second: few walkers and steps, no evidence.
QUICK = BALL_CONFIG.replace("workers = 1\n", "workers = 1\nwalkers = 8\nmax_steps = 100\n")


@pytest.fixture(scope="module")
def template():
    """The folder each example starts from (copied afresh for each)."""
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        times = 0.3 + np.concatenate([[0.0], np.cumsum(0.6 * 0.7 ** np.arange(1, 12))])
        (folder / "ball.txt").write_text("\n".join(f"{t:.7f}" for t in times) + "\n")
        (folder / "ball.csv").write_text("time_s;sigma_s\n" + "".join(
            f"{t:.7f};0.0001\n" for t in times))
        (folder / "garbage.csv").write_text("a;b\n1;2\n")
        (folder / "empty.txt").write_text("")
        (folder / "quick.toml").write_text(QUICK)
        (folder / "broken.toml").write_text("model = \n")
        simulate = (DATA / "table1_d110.toml").read_text()
        (folder / "sim.toml").write_text(simulate.replace("sample_rate = 44100",
                                                          "sample_rate = 8000"))
        shutil.copy(DATA / "pingpong.wav", folder / "short.wav")
        (folder / "notaudio.wav").write_text("RIFF? no\n")
        shutil.copy(DATA / "table1_d110.truth.json", folder / "truth.json")
        (folder / "array.json").write_text("[1, 2]")
        (folder / "runs.toml").write_text('base = "quick.toml"\n[[run]]\nlabel = "a"\n'
                                          'source = "ball.txt"\n')
        (folder / "exists.csv").write_text("mine\n")
        for stem in ("done", "ball-estimate", "short-estimate", "garbage-estimate",
                     "empty-estimate", "notaudio-estimate", "missing-estimate"):
            (folder / stem).mkdir()
            (folder / stem / "summary.json").write_text("{}\n")
        (folder / "done" / "calibration.json").write_text("{}\n")
        yield folder


#: Values for options of a number, at and beyond their limits, and not numbers at all.
NUMBERS = ["-1", "-5", "0.5", "1e9", "1e400", "nan", "inf", "-inf", "", "abc", "9" * 25,
           "１", "0x10", "1_0", " 7", "20001"]
#: Files to read: found and not, of the wrong kind, not files.
INPUTS = ["ball.txt", "ball.csv", "garbage.csv", "empty.txt", "short.wav", "notaudio.wav",
          "quick.toml", "broken.toml", "sim.toml", "runs.toml", "missing.txt", ".", "",
          "truth.json", "array.json", "/dev/null"]
#: Places to write: existing, folders, missing folders, unwritable, odd suffixes.
OUTPUTS = ["o.xyz", "exists.csv", "done", ".", "missing/o.csv", "/proc/o.png", "", "ball.txt",
           "o"]
#: What each argument is given, by its ``dest`` (and subcommand, where they differ): values
#: that may work, then values that should not. Hypothesis tries each list about as often.
POOLS: dict[str, tuple[list[str], list[str]]] = {
    "predict.config": (["quick.toml", "sim.toml"], INPUTS),
    "simulate.config": (["sim.toml"], INPUTS),
    "audio": (["short.wav"], INPUTS), "source": (["ball.txt", "ball.csv", "short.wav"], INPUTS),
    "runs": (["runs.toml"], INPUTS), "prior": (["quick.toml"], INPUTS),
    "truth": (["truth.json"], ["array.json", "missing.json", "ball.txt", "o.json", "."]),
    "simulate.truth": (["t.json", "o.truth.json"], OUTPUTS),
    "format": (["markdown", "html", "csv", "latex", "json"], ["md", "", "xml"]),
    "onsets.output": (["o.csv", "o.txt"], OUTPUTS), "labels": (["o.lab", "o.txt"], OUTPUTS),
    "simulate.output": (["o.wav", "o.flac", "o.ogg"], ["o.mp3", *OUTPUTS]),
    "table.output": (["o.md", "o.html", "o.csv", "o.tex", "o.json"], OUTPUTS),
    "plot": (["o.png", "o.pdf"], OUTPUTS),
    "out": (["fresh"], ["done", "ball.txt", "missing/deeper", "/proc/x", ""]),
    "cache_dir": (["cache"], ["ball.txt", "/proc/c", ""]),
    "flights": (["1", "3"], NUMBERS), "draws": (["2", "50"], NUMBERS),
    "seed": (["0", "7"], NUMBERS), "roll": (["0", "1"], NUMBERS),
    "stream": (["0", "1"], NUMBERS), "workers": (["1", "2"], NUMBERS),
    "highpass": (["100", "3000"], NUMBERS), "threshold": (["3", "8"], NUMBERS),
    # simulate --count: a few recordings, or a count refused (a large one would only take
    # long: one recording each)
    "count": (["1", "2"], ["-1", "0", "0.5", "", "abc", "1e9", "１", "0x10"]),
    "calibrate.config": (["quick.toml"], INPUTS), "calibrate.n": (["1", "2"], NUMBERS),
    "calibrate.onsets": (["4", "6"], NUMBERS),
}
#: Options left out: --dask waits ten seconds for a scheduler that is not there.
LEFT_OUT = {"dask", "help", "version"}


def subcommands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


SUBCOMMANDS = subcommands()


def values(command: str, action: argparse.Action, slow: bool) -> st.SearchStrategy[str]:
    """The pool of an argument: its own (good or bad, half and half), else a generic one."""
    good, bad = POOLS.get(f"{command}.{action.dest}", POOLS.get(action.dest, ([], [])))
    if not good:  # an argument added since: numbers, or files
        bad = NUMBERS if action.type is not None else [*INPUTS, *OUTPUTS]
    if command == "estimate" and action.dest == "out" and not slow:
        good = []  # the fast test never samples: every output folder is refused
    if command == "calibrate" and action.dest == "out" and not slow:
        good, bad = [], ["done", "ball.txt", "missing/deeper", "/proc/x"]  # likewise
    return st.one_of(*(st.sampled_from(pool) for pool in (good, bad) if pool))


@st.composite
def argument_lists(draw, slow: bool = False) -> list[str]:
    """A subcommand, its positional argument and a few of its options, each with a value
    from its pool (the flags alone for switches); now and then a stray word."""
    command = draw(st.sampled_from(sorted(SUBCOMMANDS)))
    actions = [a for a in SUBCOMMANDS[command]._actions if a.dest not in LEFT_OUT]
    argv = [command]
    for action in actions:
        if not action.option_strings or action.required:
            argv += action.option_strings[:1]
            argv.append(draw(values(command, action, slow)))
    options = [a for a in actions if a.option_strings and not a.required
               and (slow or a.dest != "force")]
    for action in draw(st.lists(st.sampled_from(options), max_size=3, unique_by=id)):
        argv.append(draw(st.sampled_from(action.option_strings)))
        if action.nargs != 0:
            argv.append(draw(values(command, action, slow)))
    if command in ("estimate", "table", "calibrate") and "-q" not in argv:
        argv.append("-q")
    if command in ("estimate", "calibrate") and not slow and "-o" not in argv \
            and "--out" not in argv:
        argv += ["-o", "done"]  # the fast test never samples
    if command == "calibrate" and "--n" not in argv:
        argv += ["--n", "2"]  # a few quick fits, not the default 200
    if draw(st.integers(0, 9)) == 9:
        argv.insert(draw(st.integers(1, len(argv))), draw(st.sampled_from(
            ["--bogus", "-x", "extra", "--", "--debug"])))
    return argv


def run_in_copy(template: Path, argv: list[str], capsys) -> None:
    """Run ``drumroll *argv`` in a fresh copy of ``template``: exit 0 or 2, no traceback,
    an error in one line."""
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name) / "w"
        shutil.copytree(template, folder)
        cwd = Path.cwd()
        os.chdir(folder)
        try:
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse: usage errors (2) and --help (0)
                code = exc.code
            except Exception as exc:  # --debug lets an internal error through
                pytest.fail(f"drumroll {' '.join(argv)}: {exc!r}\n{capsys.readouterr().err}")
        finally:
            os.chdir(cwd)
    err = capsys.readouterr().err
    event(f"exit {code}")
    assert code in (0, 2), f"drumroll {' '.join(argv)} exited {code}:\n{err}"
    assert "Traceback" not in err, f"drumroll {' '.join(argv)}:\n{err}"
    errors = [line for line in err.splitlines() if ": error: " in line]
    assert code == 0 or len(errors) == 1, err


FUZZ = settings(max_examples=80, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                         HealthCheck.too_slow])


@FUZZ
@given(argument_lists())
def test_no_option_list_ends_in_a_traceback(template, capsys, argv):
    run_in_copy(template, argv, capsys)


@pytest.mark.slow
@settings(FUZZ, max_examples=40)
@given(argument_lists(slow=True))
def test_no_option_list_ends_in_a_traceback_when_the_commands_run(template, capsys, argv):
    run_in_copy(template, argv, capsys)


@pytest.mark.slow
@settings(FUZZ, max_examples=25)
@given(plausible_csv_files())
def test_no_onset_list_ends_estimate_in_a_traceback(template, capsys, text):
    """Onset lists that parse but may be no roll (times repeated, negated, in microseconds,
    1e308 among them, shuffled; bad timing errors; bounces out of order) fitted from the
    command line: a result, or one line before any sampling."""
    (template / "fuzzed.csv").write_text(text)
    try:
        run_in_copy(template, ["estimate", "fuzzed.csv", "--prior", "quick.toml", "-o", "out",
                               "-q"], capsys)
    finally:
        (template / "fuzzed.csv").unlink()
