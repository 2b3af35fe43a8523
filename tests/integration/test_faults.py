"""What a user sees when something goes wrong after the input parsed: one line, the right exit
status, no traceback (``--debug`` shows one)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import drumroll.pipeline
from configs import BALL_CONFIG
from drumroll.cli.main import main
from paths import DATA


def _roll(path, times):
    path.write_text("time_s\n" + "\n".join(repr(float(t)) for t in times) + "\n")
    return path


@pytest.fixture
def ball(tmp_path):
    config = tmp_path / "ball.toml"
    config.write_text(BALL_CONFIG)
    flights = 0.2 * 0.9 ** np.arange(15)
    times = np.concatenate([[0.5], 0.5 + np.cumsum(flights)])
    return config, times


def test_onsets_no_prior_allows_are_one_line_exit_2(tmp_path, capsys, ball):
    # A roll with a last "onset" at 1e308 s: every flight the priors allow gives it zero
    # probability (it used to end in a ValueError traceback, exit 1).
    config, times = ball
    onsets = _roll(tmp_path / "huge.csv", [*times, 1e308])
    code = main(["estimate", str(onsets), "--prior", str(config), "-o", str(tmp_path / "o"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.startswith("drumroll: error: powerlaw: no parameter value drawn from the priors")
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_an_internal_fault_is_one_line_exit_1_and_debug_shows_it(tmp_path, capsys, ball,
                                                                   monkeypatch):
    # A fault injected where a bug of ours would be (no input reaches it: each one found is
    # fixed): the command says it is ours, in one line, and --debug gives the traceback.
    config, times = ball
    onsets = _roll(tmp_path / "roll.csv", times)

    def broken(*args, **kwargs):
        raise ZeroDivisionError("float division by zero\nsecond line")

    monkeypatch.setattr(drumroll.pipeline, "estimate", broken)
    command = ["estimate", str(onsets), "--prior", str(config), "-o", str(tmp_path / "o"), "-q"]
    assert main(command) == 1
    err = capsys.readouterr().err
    assert err.startswith("drumroll: internal error (a bug in drumroll")
    assert "ZeroDivisionError: float division by zero second line" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    with pytest.raises(ZeroDivisionError):
        main([*command, "--debug"])


@pytest.mark.parametrize(("stage", "signum", "how"), [
    ("sampling", signal.SIGTERM, "terminated"), ("writing", signal.SIGTERM, "terminated"),
    ("sampling", signal.SIGHUP, "hung up")])
def test_sigterm_stops_everything_and_keeps_nothing_half_written(tmp_path, stage, signum, how):
    """SIGTERM, as a process manager or `kill` sends it, in the middle of the sampling (two
    worker processes) or of the writing (figure workers, a staged posterior.nc), or SIGHUP, as
    a closed terminal sends it: one line, exit 128 + the signal, no process of the command
    left running, no output folder or staging left."""
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "drumroll", "estimate", str(DATA / "table2_h80.flac"),
         "--prior", str(DATA / "table2_h80.toml"), "-o", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if line.startswith(stage):
            break
    time.sleep(0.3)
    proc.send_signal(signum)
    rest = proc.stderr.read()
    assert proc.wait(timeout=60) == 128 + signum, "".join(lines) + rest
    assert rest.strip().splitlines()[-1] == f"drumroll: {how}; no partial output was kept"
    assert "Traceback" not in rest
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:  # the workers end with their parent
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        pytest.fail("processes of the command still run after it ended")
    assert not out.exists()


@pytest.mark.parametrize(("rows", "message"), [
    ("time_s\n-0.5\n0.5\n0.7\n0.88\n1.04\n", "onset time -0.5 s is negative"),
    ("time_s,sigma_s\n0.5,0.0001\n0.7,-0.001\n0.88,0.0001\n1.04,0.0001\n",
     "sigma_s -0.001 is not a timing error"),
    ("time_s,sigma_s\n0.5,0.0001\n0.7,nan\n0.88,0.0001\n1.04,0.0001\n",
     "sigma_s nan is not a timing error"),
    # milliseconds: fitted with every parameter at its prior's edge under Student-t noise
    ("time_s\n100\n288\n465\n630\n785\n", "are the times in seconds?"),
])
def test_onset_lists_that_are_no_recording_are_refused_before_any_work(tmp_path, capsys, ball,
                                                                       rows, message):
    # Each was fitted with exit 0 and plausible numbers (a negative sigma_s set to 0).
    config, _ = ball
    onsets = tmp_path / "onsets.csv"
    onsets.write_text(rows)
    code = main(["estimate", str(onsets), "--prior", str(config), "-o", str(tmp_path / "o"),
                 "-q"])
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def _estimate(tmp_path, ball, *options):
    config, times = ball
    onsets = _roll(tmp_path / "roll.csv", times)
    return main(["estimate", str(onsets), "--prior", str(config), "-q", *options])


@pytest.mark.parametrize(("options", "message"), [
    (["--seed", "-5"], "argument --seed: must be at least 0, got -5"),
    (["-o", "{tmp}/roll.csv/out"], "roll.csv: is not a directory"),
    (["-o", "/proc/drumroll-out"], "/proc: cannot write there"),
    (["--truth", "{tmp}/array.json"], "array.json: not a truth file"),
])
def test_estimate_options_are_checked_before_any_work(tmp_path, capsys, ball, options,
                                                      message):
    # Each ended in an internal error (or a traceback) after the sampling, or not at all.
    (tmp_path / "array.json").write_text("[1, 2]")
    options = [o.format(tmp=tmp_path) for o in options]
    if "-o" not in options:
        options += ["-o", str(tmp_path / "out")]
    try:
        code = _estimate(tmp_path, ball, *options)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2
    assert message in err and "Traceback" not in err and "internal error" not in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("arguments", "message"), [
    (["--plot", "{tmp}/p.xyz", "-o", "{tmp}/o.csv"], "p.xyz: a figure is written as"),
    (["-o", "{tmp}/x.csv", "--labels", "{tmp}/x.csv"], "name the same file"),
    (["--highpass", "-10"], "argument --highpass: must be a finite number above 0"),
    (["--threshold", "nan"], "argument --threshold: must be a finite number above 0"),
])
def test_onsets_options_are_checked_before_anything_is_written(tmp_path, capsys, arguments,
                                                               message):
    arguments = [a.format(tmp=tmp_path) for a in arguments]
    try:
        code = main(["onsets", str(DATA / "table2_h80.flac"), *arguments])
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and message in err and "internal error" not in err
    assert not list(tmp_path.iterdir())  # nothing written


def test_predict_draws_below_two_are_a_usage_error_as_its_help_says(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["predict", str(DATA / "table2_h80.toml"), "--draws", "1"])
    assert exit_.value.code == 2
    assert "argument --draws: must be at least 2, got 1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["predict", "--help"])
    assert "at least 2" in capsys.readouterr().out


@pytest.mark.parametrize("arguments", [["--draws", "1000000000"], ["-n", "1000000"]])
def test_predict_refuses_what_would_not_fit_in_memory(tmp_path, capsys, arguments):
    # --draws 1e9 was killed for want of memory (exit 137); -n 1e6 a MemoryError.
    assert main(["predict", str(DATA / "table2_h80.toml"), *arguments]) == 2
    err = capsys.readouterr().err
    assert "more than 5e+07" in err and len(err.strip().splitlines()) == 1


def test_force_leaves_no_figure_of_the_run_it_replaces(tmp_path, capsys):
    """The first run (a recording) draws onsets.png; the second, --force into the same folder
    from an onset file, draws none: the folder holds only the second run's results."""
    config = tmp_path / "ball.toml"
    config.write_text(BALL_CONFIG)
    out = tmp_path / "out"
    onsets = tmp_path / "pingpong.csv"
    assert main(["onsets", str(DATA / "pingpong.wav"), "-o", str(onsets)]) == 0
    assert main(["estimate", str(DATA / "pingpong.wav"), "--prior", str(config), "-o",
                 str(out), "-q"]) == 0
    assert (out / "onsets.png").exists()
    (out / "my notes.txt").write_text("mine")
    assert main(["estimate", str(onsets), "--prior", str(config), "-o", str(out), "-q",
                 "--force"]) == 0
    assert not (out / "onsets.png").exists()
    assert (out / "my notes.txt").read_text() == "mine"  # not ours: left alone
    assert (out / "summary.json").exists() and (out / "residuals.png").exists()
