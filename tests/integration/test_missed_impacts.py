"""Impacts missed before the first onset (issue 13 item 9), through the command line with the
default config: the exact pendulum's geometry fixes t_B, so the same roll with its first
impact cut off is recognised as starting one impact late, and the full roll as starting on
time; the numberings far from the data are screened out rather than fitted."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import arviz as az
import numpy as np
import pytest

from drumroll.cli.main import main
from drumroll.inference.missed_impacts import missed_probabilities
from paths import DATA


def test_probabilities_are_the_normalised_evidences():
    p = missed_probabilities([10.0, 10.0 + math.log(3.0), -math.inf])
    assert p == pytest.approx((0.25, 0.75, 0.0))


@pytest.mark.slow
def test_a_roll_that_begins_late_is_fitted_with_its_likeliest_numbering(tmp_path):
    """table2_h80 with its first one and two impacts cut off, each numbered from its first
    onset: the estimate finds the impacts missed and fits every model again numbered from
    there, so the reported geometry and α are the simulator's truth, as for the whole roll."""
    assert main(["onsets", str(DATA / "table2_h80.flac"), "-o", str(tmp_path / "all.csv")]) == 0
    rows = list(csv.DictReader((tmp_path / "all.csv").open()))
    config = DATA / "table2_h80.toml"
    assert "missed_first" not in config.read_text()  # on by default
    truth = json.loads((DATA / "table2_h80.truth.json").read_text())["simulate"]
    found = {}
    for first in (0, 1, 2):
        with (tmp_path / f"from{first}.csv").open("w", newline="") as handle:
            writer = csv.writer(handle)
            # numbered from the first onset written, as a recording that begins there would be
            # (the bounces the extractor did not hear, 13 and 14, stay gaps)
            # (the extractor's sigma_s kept, as in a file `drumroll onsets` writes)
            writer.writerow(["time_s", "sigma_s", "bounce"])
            writer.writerows([row["time_s"], row["sigma_s"], int(row["bounce"]) - first]
                             for row in rows[first:])
        out = tmp_path / f"from{first}"
        assert main(["estimate", str(tmp_path / f"from{first}.csv"), "--prior",
                     str(config), "-o", str(out), "-q"]) == 0
        found[first] = json.loads((out / "summary.json").read_text())
    for first, summary in found.items():
        probabilities = summary["missed_first_impacts"]
        assert probabilities[first] > 0.99
        assert summary["onsets"][0]["bounce"] == first
        # the first onset weighed as a stray sound too (again after a renumbering): no
        assert summary["stray_first"] < 1e-3
        assert not any("may not be impact" in w
                       for w in summary["diagnostics"]["pendulum"]["warnings"])
        assert (f"fitted with the first onset as impact {first}" in summary["notes"][-1]) == (
            first > 0)
        for name, key in (("alpha", "alpha"), ("pivot_mm", "pivot_mm"),
                          ("height_mm", "height_mm")):
            estimate = summary["parameters"][key]
            assert abs(estimate["mean"] - truth[name]) < 3 * estimate["sd"], (first, name)
        # the comparison is the whole roll's too (misnumbered, the power law won by 23 nats)
        assert summary["preferred"] != "powerlaw"
    # Numbered from impact 2, the whole roll is far below the data: screened, not fitted.
    assert found[0]["missed_first_impacts"][2] < 1e-6
    assert any("P(2) < 3e-07 (screened)" in note for note in found[0]["notes"])
    # Numbered from impact 0, the roll that lost two impacts is ruled out by its screen too.
    assert any("P(0) < 3e-07 (screened)" in note for note in found[2]["notes"])


def estimate_pendulum_alone(source, tmp_path, missed_first: int) -> dict:
    """summary.json of ``estimate source`` with table2_h80's config, the exact pendulum alone
    and ``[likelihood] missed_first`` as given."""
    config = (DATA / "table2_h80.toml").read_text().replace(
        "[likelihood]\n", f"[likelihood]\nmissed_first = {missed_first}\n").replace(
        'compare = ["small-angle", "powerlaw"]', "compare = []")
    (tmp_path / "h80.toml").write_text(config)
    out = tmp_path / "out"
    assert main(["estimate", str(source), "--prior", str(tmp_path / "h80.toml"),
                 "-o", str(out), "-q"]) == 0
    return json.loads((out / "summary.json").read_text())


def test_missed_first_zero_fits_the_first_numbering_alone(tmp_path):
    """With ``missed_first = 0`` the numbering is imposed: no impact is weighed as missed, nor
    the first onset as a stray sound."""
    summary = estimate_pendulum_alone(DATA / "table2_h80.flac", tmp_path, 0)
    assert summary["missed_first_impacts"] == []
    assert summary["stray_first"] is None
    assert not any("impacts missed" in note for note in summary["notes"])


def test_the_first_impact_is_not_taken_for_a_stray_sound(tmp_path):
    """table2_h80 as the extractor finds it, the exact pendulum alone: its first onset is
    weighed as a stray sound and found negligible."""
    summary = estimate_pendulum_alone(DATA / "table2_h80.flac", tmp_path, 2)
    assert summary["stray_first"] < 1e-3
    assert summary["missed_first_impacts"][0] > 0.99
    assert not any("no impact of the roll" in note for note in summary["notes"])


@pytest.mark.slow
@pytest.mark.parametrize(("cut", "file_first", "missed_first", "fitted"), [
    (2, 2, 0, 2),  # the file's numbering imposed
    (2, 2, 2, 2),  # the file's numbering checked, and kept
    (0, 1, 2, 0),  # the file's numbering checked, and replaced
])
def test_a_files_own_bounce_numbers_are_the_numbering_fitted_first(
        tmp_path, cut, file_first, missed_first, fitted):
    """table2_h80 less its first ``cut`` onsets, in a file whose bounce column numbers its
    first onset ``file_first`` (as a user who knows, or thinks, that impacts went unheard
    writes it): the models are fitted with the file's numbering first; the check (off with
    ``missed_first = 0``) keeps it where it is right, with no second pass, and fits again from
    the right impact where it is wrong; the geometry and α are the simulator's truth."""
    assert main(["onsets", str(DATA / "table2_h80.flac"), "-o", str(tmp_path / "all.csv"),
                 "-q"]) == 0
    rows = list(csv.DictReader((tmp_path / "all.csv").open()))
    with (tmp_path / "late.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["time_s", "sigma_s", "bounce"])
        writer.writerows([row["time_s"], row["sigma_s"], int(row["bounce"]) - cut + file_first]
                         for row in rows[cut:])
    summary = estimate_pendulum_alone(tmp_path / "late.csv", tmp_path, missed_first)
    assert [o["bounce"] for o in summary["onsets"][:2]] == [fitted, fitted + 1]
    assert summary["notes"][0].startswith(
        f"the roll's first onset is numbered bounce {file_first} in ")
    assert ("first_numbering" in summary["seconds"]) == (fitted != file_first)
    probabilities = summary["missed_first_impacts"]
    assert (probabilities[fitted] > 0.99) if missed_first else probabilities == []
    if missed_first:
        assert f"fitted with the first onset as impact {fitted} (" in summary["notes"][-1]
    truth = json.loads((DATA / "table2_h80.truth.json").read_text())["simulate"]
    for name in ("alpha", "pivot_mm", "height_mm"):
        estimate = summary["parameters"][name]
        assert abs(estimate["mean"] - truth[name]) < 3 * estimate["sd"], name


def _with_a_tap(tmp_path, off: float) -> tuple:
    """table2_h80's onsets with a sound before them, where the law of the flights after it
    puts a bounce ``off`` (relative) too early or late: a tap the extractor could take for
    the first bounce (the tracker joins a first flight up to 16 % shorter than the next)."""
    assert main(["onsets", str(DATA / "table2_h80.flac"), "-o", str(tmp_path / "all.csv"),
                 "-q"]) == 0
    rows = list(csv.DictReader((tmp_path / "all.csv").open()))
    times = [float(row["time_s"]) for row in rows]
    first, second = times[1] - times[0], times[2] - times[1]
    tap = times[0] - first * (first / second) * (1.0 + off)
    with (tmp_path / "tapped.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["time_s", "sigma_s"])
        writer.writerow([f"{tap:.6f}", rows[0]["sigma_s"]])
        writer.writerows([row["time_s"], row["sigma_s"]] for row in rows)
    return tmp_path / "tapped.csv", times


@pytest.mark.slow
@pytest.mark.parametrize("model", ["pendulum", "powerlaw"])
def test_a_tap_taken_for_the_first_bounce_is_dropped(tmp_path, model):
    """A sound 4 % (10 ms) off where the flights after it put a bounce, before table2_h80's
    roll: under the exact pendulum (its geometry fixes t_B) and under the power law (whose
    t_B is free: the timing alone tells), the first onset is weighed as a stray sound, found
    the likelier, and the models fitted from the onset after it: T0 is the first impact's
    time (and the pendulum's α and geometry the simulator's truth), and a note says what was
    dropped."""
    source, times = _with_a_tap(tmp_path, 0.04)
    config = (DATA / "table2_h80.toml").read_text().replace(
        'compare = ["small-angle", "powerlaw"]', "compare = []")
    config = config.replace('model = "pendulum"', f'model = "{model}"', 1)
    assert f'model = "{model}"' in config
    (tmp_path / "h80.toml").write_text(config)
    out = tmp_path / "out"
    assert main(["estimate", str(source), "--prior", str(tmp_path / "h80.toml"),
                 "-o", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stray_first"] > 0.99
    assert [o["time_s"] for o in summary["onsets"]] == pytest.approx(times)
    assert summary["onsets"][0]["bounce"] == 0
    assert any(note.startswith("the first onset (") and "no impact of the roll" in note
               for note in summary["notes"])
    if model == "pendulum":  # (the power law's α is not the pendulum's: eq. 9 against 11)
        truth = json.loads((DATA / "table2_h80.truth.json").read_text())["simulate"]
        for name in ("alpha", "pivot_mm", "height_mm"):
            estimate = summary["parameters"][name]
            assert abs(estimate["mean"] - truth[name]) < 3 * estimate["sd"], name
    t0 = summary["parameters"]["t0_s"]
    assert abs(t0["mean"] - times[0]) < max(3 * t0["sd"], 1e-4)



@pytest.mark.slow
def test_where_no_numbering_is_clearly_preferred_the_numberings_are_averaged(tmp_path):
    """table2_h80 less its first onset, numbered from impact 0, under geometry priors three
    times wider (pivot ± 6 mm, height ± 10 mm): the onsets cannot tell how many impacts came
    before them. The estimate's α and t_B over the numberings are checked against a
    reference made without the average: the roll fitted once per numbering, imposed by the
    file (``missed_first = 0``), each fit's draws mixed by the estimate's probabilities."""
    assert main(["onsets", str(DATA / "table2_h80.flac"), "-o", str(tmp_path / "all.csv"),
                 "-q"]) == 0
    rows = list(csv.DictReader((tmp_path / "all.csv").open()))
    text = (DATA / "table2_h80.toml").read_text().replace(
        'compare = ["small-angle", "powerlaw"]', "compare = []").replace(
        "sigma = 2 }", "sigma = 6 }").replace("mu = 80, sigma = 3 }", "mu = 80, sigma = 10 }")
    (tmp_path / "wide.toml").write_text(text)
    (tmp_path / "imposed.toml").write_text(
        text.replace("[likelihood]\n", "[likelihood]\nmissed_first = 0\n"))

    def run(first: int, config: str) -> tuple[dict, Path]:
        name = f"from{first}-{config}"
        with (tmp_path / f"{name}.csv").open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(["time_s", "sigma_s", "bounce"])
            writer.writerows([row["time_s"], row["sigma_s"], int(row["bounce"]) - 1 + first]
                             for row in rows[1:])
        out = tmp_path / name
        assert main(["estimate", str(tmp_path / f"{name}.csv"), "--prior",
                     str(tmp_path / f"{config}.toml"), "-o", str(out), "-q"]) == 0
        return json.loads((out / "summary.json").read_text()), out

    summary, _ = run(0, "wide")
    averaged = summary["numbering_average"]
    probabilities = summary["missed_first_impacts"]
    assert max(probabilities) < 0.95  # the case meant
    assert averaged["fitted"] == "0"
    weighed = {**{str(m): p for m, p in enumerate(probabilities)},
               "stray": summary["stray_first"]}
    kept = {m: p for m, p in weighed.items() if p >= 0.01}
    assert averaged["probabilities"] == pytest.approx(
        {m: p / sum(kept.values()) for m, p in kept.items()})
    assert "stray" not in kept  # its first onset is the roll's impact 1, clearly
    weights = {int(m): w for m, w in averaged["probabilities"].items()}
    # The reference mixture, from each numbering's own fit (stored draws of posterior.nc).
    draws = {}
    for first in weights:
        fit, out = run(first, "imposed")
        assert fit["onsets"][0]["bounce"] == first and fit["missed_first_impacts"] == []
        posterior = az.from_netcdf(out / "posterior.nc").posterior
        draws[first] = {key: np.asarray(posterior[key]).ravel() for key in ("alpha", "t_b")}
    for key in ("alpha", "t_b"):
        mean = sum(w * draws[m][key].mean() for m, w in weights.items())
        second = sum(w * (draws[m][key].var() + draws[m][key].mean() ** 2)
                     for m, w in weights.items())
        sd = math.sqrt(second - mean**2)
        got = averaged["parameters"][key]
        assert got["mean"] == pytest.approx(mean, abs=0.1 * sd), key
        assert got["sd"] == pytest.approx(sd, rel=0.1), key
        # the numbering fitted alone is narrower than the mixture
        assert summary["parameters"][key]["sd"] < got["sd"], key
