"""The public API: one function per command, at the top level, on the bundled data."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import drumroll
from paths import DATA


def test_the_top_level_names_every_command_and_imports_nothing_heavy():
    assert set(drumroll.__all__) >= {"detect", "read_onsets", "estimate", "load_posteriors",
                                     "predict", "simulate", "load_runs", "run_table",
                                     "load_config", "__version__"}
    code = ("import sys, drumroll; heavy = [m for m in ('scipy', 'emcee', 'arviz', "
            "'matplotlib') if m in sys.modules]; assert not heavy, heavy")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
    with pytest.raises(AttributeError, match="no attribute 'estimates'"):
        drumroll.estimates  # noqa: B018


def test_predict_gives_every_predictable_model_of_a_config():
    predictions = drumroll.predict(DATA / "table2_h80.toml", n_draws=2000)
    assert set(predictions) == {"powerlaw", "small-angle", "pendulum"} or \
        set(predictions) == {"small-angle", "pendulum"}
    t_b = predictions["pendulum"].summary()["t_b"]
    assert 0.24 < t_b["mean"] < 0.27  # the paper's Table 2, h = 80 mm: t_B = 0.253 s


def test_simulate_detect_and_read_onsets_agree_with_the_truth(tmp_path):
    recording = drumroll.simulate(DATA / "table2_h80.toml", seed=3)
    truth = np.array(recording.truth["impact_times_s"])
    onsets = drumroll.detect(recording.samples, sr=recording.sample_rate)
    nearest = np.abs(onsets.time_s[:, None] - truth[None, :]).min(axis=1)
    assert len(onsets) >= 12 and np.median(nearest) < 2e-4  # every onset is an impact
    np.testing.assert_array_equal(onsets.bounce, np.arange(len(onsets)))  # from the first
    path = tmp_path / "onsets.csv"
    path.write_text(onsets.to_csv())
    np.testing.assert_allclose(drumroll.read_onsets(path).time_s, onsets.time_s, atol=1e-6)


def test_the_console_entry_ends_with_the_command_s_status_and_all_its_output(tmp_path):
    """``python -m drumroll`` (and the console scripts) end the process without Python's
    teardown (cli.main.end_process): the exit status and every line still come out."""
    ok = subprocess.run([sys.executable, "-m", "drumroll", "predict",
                         str(DATA / "table2_h80.toml"), "-n", "3"],
                        capture_output=True, text=True, check=False)
    assert ok.returncode == 0 and "t_B" in ok.stdout and ok.stdout.endswith("\n")
    bad = subprocess.run([sys.executable, "-m", "drumroll", "estimate",
                          str(tmp_path / "none.flac"), "--prior",
                          str(DATA / "table2_h80.toml")],
                         capture_output=True, text=True, check=False)
    assert bad.returncode == 2 and "no such file" in bad.stderr
