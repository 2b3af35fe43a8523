"""Model adequacy end to end, through the command line: a real ball whose restitution drifts
with speed is flagged before any number, and never preferred; a roll our exact pendulum made
passes under that model."""

from __future__ import annotations

import json

from drumroll.cli.main import main
from paths import DATA


def test_the_real_ping_pong_is_flagged_before_any_number(tmp_path, capsys):
    # Its flight ratio climbs from 0.944 to 0.947 as it slows (restitution falls with impact
    # speed): a constant-α power law leaves its residuals one smooth wave.
    out = tmp_path / "pingpong"
    assert main(["estimate", str(DATA / "pingpong.wav"), "--prior",
                 str(DATA / "pingpong.toml"), "-o", str(out), "-q"]) == 0
    printed = capsys.readouterr().out.splitlines()
    misfit = next(i for i, line in enumerate(printed) if "does not describe these onsets" in line)
    table = next(i for i, line in enumerate(printed) if line.startswith("alpha "))
    assert misfit < table
    assert printed[misfit].startswith("warning: powerlaw does not describe these onsets")
    summary = json.loads((out / "summary.json").read_text())
    adequacy = summary["models"]["powerlaw"]["adequacy"]
    assert adequacy["adequate"] is False
    assert adequacy["checks"]["lag1_autocorrelation"]["p_value"] < 0.01
    assert adequacy["checks"]["lag1_autocorrelation"]["observed"] > 0.5
    assert summary["preferred"] is None
    report = (out / "report.md").read_text()
    assert report.index("The model does not fit") < report.index("## Parameters")


def test_a_roll_the_exact_pendulum_made_passes_under_it(tmp_path, capsys):
    out = tmp_path / "h80"
    assert main(["estimate", str(DATA / "table2_h80.flac"), "--prior",
                 str(DATA / "table2_h80.toml"), "-o", str(out), "-q"]) == 0
    assert "does not describe" not in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    adequacy = summary["models"]["pendulum"]["adequacy"]
    assert adequacy["adequate"] is True
    assert set(adequacy["checks"]) == {"lag1_autocorrelation", "sign_runs"}
    assert summary["preferred"] == "pendulum"
