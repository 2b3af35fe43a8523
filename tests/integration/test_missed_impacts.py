"""Impacts missed before the first onset (issue 13 item 9), through the command line with the
default config: the exact pendulum's geometry fixes t_B, so the same roll with its first
impact cut off is recognised as starting one impact late, and the full roll as starting on
time; the numberings far from the data are screened out rather than fitted."""

from __future__ import annotations

import csv
import json
import math

import pytest

from drumroll.cli.main import main
from drumroll.inference.missed_impacts import missed_probabilities
from paths import DATA


def test_probabilities_are_the_normalised_evidences():
    p = missed_probabilities([10.0, 10.0 + math.log(3.0), -math.inf])
    assert p == pytest.approx((0.25, 0.75, 0.0))


@pytest.mark.slow
def test_a_roll_whose_first_impact_is_cut_off_is_numbered_from_impact_one(tmp_path, capsys):
    assert main(["onsets", str(DATA / "table2_h80.flac"), "-o", str(tmp_path / "all.csv")]) == 0
    rows = list(csv.DictReader((tmp_path / "all.csv").open()))
    config = DATA / "table2_h80.toml"
    assert "missed_first" not in config.read_text()  # on by default
    found = {}
    for name, first in (("late", 1), ("whole", 0)):
        with (tmp_path / f"{name}.csv").open("w", newline="") as handle:
            writer = csv.writer(handle)
            # numbered from the first onset written, as a recording that begins there would be
            # (the bounces the extractor did not hear, 13 and 14, stay gaps)
            writer.writerow(["time_s", "bounce"])
            writer.writerows([row["time_s"], int(row["bounce"]) - first] for row in rows[first:])
        out = tmp_path / name
        assert main(["estimate", str(tmp_path / f"{name}.csv"), "--prior",
                     str(config), "-o", str(out), "-q"]) == 0
        found[name] = json.loads((out / "summary.json").read_text())
    printed = capsys.readouterr().out
    late, whole = found["late"]["missed_first_impacts"], found["whole"]["missed_first_impacts"]
    assert late[1] > 0.99 and whole[0] > 0.99
    # Numbered from impact 2, the whole roll is far below the data.
    assert whole[2] < 1e-6
    assert any("P(2) " in note for note in found["whole"]["notes"])
    assert "the first onset may not be the roll's first impact" in printed
    assert "every number given assumes none was missed" in printed
    assert any("P(none missed)" in w for w in found["late"]["diagnostics"]["pendulum"]["warnings"])
    assert not any("P(none missed)" in w
                   for w in found["whole"]["diagnostics"]["pendulum"]["warnings"])


def test_missed_first_zero_fits_the_first_numbering_alone(tmp_path):
    config = (DATA / "table2_h80.toml").read_text().replace(
        "[likelihood]\n", "[likelihood]\nmissed_first = 0\n").replace(
        'compare = ["small-angle", "powerlaw"]', "compare = []")
    (tmp_path / "h80.toml").write_text(config)
    out = tmp_path / "out"
    assert main(["estimate", str(DATA / "table2_h80.flac"), "--prior", str(tmp_path / "h80.toml"),
                 "-o", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["missed_first_impacts"] == []
    assert not any("impacts missed" in note for note in summary["notes"])
