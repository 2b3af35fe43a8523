"""``drumroll table`` end to end on onset files with tiny sampler settings: cache, executors."""

from __future__ import annotations

import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from drumroll.cli.main import main
from drumroll.table import load_runs, run_table
from tests.unit.table.test_table import BASE, RUN_H80, run_d131, runs_text, write_onsets


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """Two runs estimated once through the CLI (the cache then holds them)."""
    path = tmp_path_factory.mktemp("table")
    (path / "base.toml").write_text(BASE)
    write_onsets(path / "h80.txt", "table2_h80")
    write_onsets(path / "d131.txt", "table1_d131", seed=1)
    (path / "runs.toml").write_text(runs_text(RUN_H80, run_d131()))
    status = main(["table", str(path / "runs.toml"), "-q", "--workers", "1",
                   "-o", str(path / "table.json"), "--plot", str(path / "fig5.png")])
    assert status == 0
    return path


def test_table_values(folder):
    rows = json.loads((folder / "table.json").read_text())["rows"]
    assert [r["label"] for r in rows] == ["h80", "d131"]
    for row, truth in zip(rows, (0.90, 0.88), strict=True):
        assert abs(row["alpha"]["value"] - truth) < 0.01
        assert abs(row["fitted_t_b"]["value"] - 0.2531) < 0.002
        assert abs(row["computed_t_b"]["value"] - 0.251) < 0.003  # small-angle, priors
        assert row["computed_t_b"]["err"] == pytest.approx(0.006, abs=0.0015)
        assert row["computed_t_b_pendulum"]["value"] > row["computed_t_b"]["value"]
        assert row["vary"] == {"key": "pivot_mm", "value": 131.0, "err": 2.0}
    assert (folder / "fig5.png").stat().st_size > 10_000
    assert len(list((folder / ".drumroll-cache").glob("*.json"))) == 2


def test_unchanged_table_comes_from_the_cache(folder, capsys):
    # What the cache saves is said by the command (and measured in benchmarks/table.py), not
    # timed here: a loaded machine is no slower cache.
    cached = {p: p.stat().st_mtime_ns for p in (folder / ".drumroll-cache").glob("*.json")}
    assert main(["table", str(folder / "runs.toml")]) == 0
    assert {p: p.stat().st_mtime_ns
            for p in (folder / ".drumroll-cache").glob("*.json")} == cached  # nothing refitted
    out, err = capsys.readouterr()
    assert "2 of 2 runs from the cache" in err
    assert "| h80 | 131 ± 2 |" in out


def test_a_new_run_is_the_only_one_computed(folder, tmp_path):
    (folder / "runs3.toml").write_text(runs_text(
        RUN_H80, run_d131(), '\n[[run]]\nlabel = "h80-again"\nsource = "h80.txt"\n'
        '[run.sampler]\nseed = 7\n'))
    with ProcessPoolExecutor(max_workers=2) as pool:
        result = run_table(load_runs(folder / "runs3.toml"), executor=pool)
    assert result.computed == ["h80-again"]
    assert abs(result.rows[2].alpha.value - 0.90) < 0.01


def test_corrupt_cache_entry_is_recomputed(folder, tmp_path):
    runs = load_runs(folder / "runs.toml")
    cache = tmp_path / "cache"
    first = run_table(runs, cache_dir=cache, workers=1)
    entry = next(cache.glob("*.json"))
    entry.write_text("{not json")
    again = run_table(runs, cache_dir=cache, workers=1)
    assert len(again.computed) == 1
    assert again.rows[0].alpha == first.rows[0].alpha  # same seed, same numbers


def test_dask_executor(folder, capsys):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) \
            as cluster:
        status = main(["table", str(folder / "runs.toml"), "--dask", cluster.scheduler_address,
                       "--no-cache", "--format", "json"])
    out, err = capsys.readouterr()
    assert status == 0, err
    assert "estimating 2 runs on ClientExecutor" in err
    cached = run_table(load_runs(folder / "runs.toml"))
    assert cached.computed == []
    for row, again in zip(json.loads(out)["rows"], cached.rows, strict=True):
        assert row["alpha"]["value"] == pytest.approx(again.alpha.value, rel=1e-12)


def test_a_failing_run_is_one_line_and_the_others_stay_cached(folder, tmp_path, capsys):
    (folder / "short.txt").write_text("1.0\n1.2\n1.35\n")
    (folder / "runs_bad.toml").write_text(runs_text(
        RUN_H80, '\n[[run]]\nlabel = "short"\nsource = "short.txt"\n'))
    status = main(["table", str(folder / "runs_bad.toml"), "-q", "--workers", "2",
                   "--cache-dir", str(tmp_path)])
    err = capsys.readouterr().err.strip()
    assert status == 2
    assert err.startswith("drumroll: error: run 'short': ") and "only 3 onsets" in err
    assert "\n" not in err
    assert len(list(tmp_path.glob("*.json"))) == 1  # h80 finished and was cached


@pytest.fixture(scope="module")
def joint_folder(tmp_path_factory) -> Path:
    """Two set-ups (d = 131 and 110 mm) with the same α = 0.9, stick dimensions fixed."""
    from drumroll.physics import StickGeometry, bounce_sequence

    path = tmp_path_factory.mktemp("joint")
    base = BASE.replace('{ dist = "normal", mu = 348, sigma = 1 }', "348").replace(
        '{ dist = "normal", mu = 60, sigma = 1 }', "60").replace("max_steps = 500",
                                                                 "max_steps = 300")
    (path / "base.toml").write_text(base)
    stick = StickGeometry("cylinder-cone", length=0.348, tip=0.060, radius=0.0075)
    rng = np.random.default_rng(3)
    for name, pivot in (("a", 0.131), ("b", 0.110)):
        impacts = bounce_sequence("pendulum", alpha=np.array([0.9]), pivot=pivot, height=0.08,
                                  stick=stick, n_flights=12).impacts[0]
        times = 1.0 + impacts + 1e-4 * rng.standard_normal(impacts.size)
        (path / f"{name}.txt").write_text("\n".join(f"{t:.6f}" for t in times) + "\n")
    (path / "runs.toml").write_text(
        'base = "base.toml"\nvary = "pivot_mm"\nshare = ["alpha"]\n'
        '[[run]]\nlabel = "a"\nsource = "a.txt"\n'
        '[[run]]\nlabel = "b"\nsource = "b.txt"\n'
        '[run.priors]\npivot_mm = { dist = "normal", mu = 110, sigma = 2 }\n')
    return path


def _assert_sum_of_runs(joint, parts, z: np.ndarray) -> None:
    """The joint density at ``z`` is the runs' posteriors summed, α's prior once: in sampler
    coordinates, so each run's log Jacobian (h via q, the atom's plateau) is added."""
    xa, xb = joint.run_parameters(z)
    expected = parts[0](xa) + parts[1](xb) - parts[0].space.priors["alpha"].logpdf(xa[:, 0])
    expected += sum(c.to_parameters(zi)[1] for c, zi in zip(joint.coordinates, joint.split(z),
                                                             strict=True))
    finite = np.isfinite(expected)
    assert finite.sum() > 10
    np.testing.assert_allclose(joint(z)[finite], expected[finite], rtol=1e-12)


def test_joint_posterior_is_the_sum_of_the_runs(joint_folder):
    from drumroll.inference.likelihood import OnsetData
    from drumroll.inference.posterior import LogPosterior
    from drumroll.table.joint import JointPosterior

    runs = load_runs(joint_folder / "runs.toml")
    parts = []
    for run in runs.runs:
        times = np.loadtxt(run.source)
        parts.append(LogPosterior.build(run.config, "pendulum", OnsetData.from_arrays(times)))
    joint = JointPosterior(parts, ["a", "b"], ("alpha",))
    # α once, and each run's pivot, height, jitter and contact time (sampled by default)
    assert joint.space.names[0] == "shared:alpha" and joint.space.ndim == 9
    z = joint.space.sample_prior(np.random.default_rng(0), 50)
    xa, xb = joint.run_parameters(z)
    np.testing.assert_array_equal(xa[:, 0], xb[:, 0])  # one alpha
    _assert_sum_of_runs(joint, parts, z)
    assert joint(z[0]) == pytest.approx(joint(z[:1])[0])


def test_a_joint_fit_shares_its_parameters_whatever_the_runs_atoms(joint_folder):
    """Each run's coordinates with the geometry of its contact time's atom (a plateau and a
    ridge along which every other column moves with the contact): the runs still share one
    α, value for value, and the joint density is still the sum of the runs' posteriors."""
    from drumroll.inference.coordinates import AtomGeometry, SamplerCoordinates
    from drumroll.inference.likelihood import OnsetData
    from drumroll.inference.posterior import LogPosterior
    from drumroll.table.joint import JointPosterior

    runs = load_runs(joint_folder / "runs.toml")
    parts, coordinates = [], []
    for run in runs.runs:
        part = LogPosterior.build(run.config, "pendulum",
                                  OnsetData.from_arrays(np.loadtxt(run.source)))
        plain = SamplerCoordinates(part.space, part.data)
        (j,) = plain.atom_columns
        ridge = np.full(part.space.ndim, -2.0)  # α among the columns the contact moves
        ridge[j] = 0.0
        coordinates.append(SamplerCoordinates(part.space, part.data,
                                              (AtomGeometry(1e-4, tuple(ridge)),)))
        parts.append(part)
    joint = JointPosterior(parts, ["a", "b"], ("alpha",), coordinates)
    z = joint.space.sample_prior(np.random.default_rng(1), 50)
    xa, xb = joint.run_parameters(z)
    np.testing.assert_array_equal(xa[:, 0], xb[:, 0])
    assert np.any(xa[:, 1] != joint.split(z)[0][:, 1])  # the pivot did follow the contact
    _assert_sum_of_runs(joint, parts, z)


@pytest.mark.slow
def test_joint_table(joint_folder, capsys):
    assert main(["table", str(joint_folder / "runs.toml"), "--workers", "2", "-q",
                 "--format", "json"]) == 0
    document = json.loads(capsys.readouterr().out)
    shared = document["joint"]["shared"]["alpha"]
    assert abs(shared["value"] - 0.9) < 5 * shared["err"] + 1e-4
    for row in document["rows"]:
        assert row["shared"] == ["alpha"]
        assert row["alpha"]["value"] == shared["value"]
        assert abs(row["alpha_separate"]["value"] - 0.9) < 0.01
    assert "consistent with one common value" in document["joint"]["consistency"]["alpha"]


@pytest.mark.slow
def test_a_joint_fit_keeps_each_runs_numbering(joint_folder, tmp_path, capsys):
    """Run b given as an onset file that lost its first two impacts and says so (its bounce
    column starts at 2): its own fit and the joint fit number it alike, so the shared α is
    the truth and b's first rebound under the joint posterior is its geometry's."""
    import shutil

    for name in ("base.toml", "a.txt"):
        shutil.copy(joint_folder / name, tmp_path / name)
    times = np.loadtxt(joint_folder / "b.txt")
    (tmp_path / "b.csv").write_text("time_s,bounce\n" + "".join(
        f"{t:.6f},{k}\n" for k, t in enumerate(times) if k >= 2))
    (tmp_path / "runs.toml").write_text(
        (joint_folder / "runs.toml").read_text().replace('"b.txt"', '"b.csv"'))
    assert main(["table", str(tmp_path / "runs.toml"), "--workers", "2", "-q",
                 "--format", "json"]) == 0
    document = json.loads(capsys.readouterr().out)
    shared = document["joint"]["shared"]["alpha"]
    assert abs(shared["value"] - 0.9) < 5 * shared["err"] + 1e-4
    b = document["rows"][1]
    assert abs(b["alpha_separate"]["value"] - 0.9) < 0.01
    # b's first rebound under the joint posterior is its geometry's (numbered from 0 there, it
    # was its third flight's: 0.183 s against the geometry's 0.225 s)
    predicted = b["computed_t_b_pendulum"]
    assert abs(b["fitted_t_b"]["value"] - predicted["value"]) < 2 * predicted["err"]


def test_a_cache_folder_that_cannot_be_written_names_the_cache(folder, capsys):
    """The cache's folder refused (here /proc, which refuses root too): the line says it is
    the cache's, and how to do without it; it named the folder alone."""
    status = main(["table", str(folder / "runs.toml"), "-q", "--cache-dir",
                   "/proc/drumroll-cache"])
    err = capsys.readouterr().err.strip()
    assert status == 2 and "\n" not in err
    assert "cannot write there" in err and "cache" in err and "--no-cache" in err


@pytest.mark.parametrize(("fmt", "name"), [("csv", "table.md"), ("markdown", "table.csv"),
                                           ("json", "table.tex")])
def test_a_format_its_file_name_contradicts_is_refused_before_any_run(fmt, name, tmp_path,
                                                                      capsys):
    """``--format csv -o table.md`` once wrote CSV into a file named as Markdown (and
    ``--format markdown -o table.csv`` Markdown into .csv): one line, exit 2, nothing written
    and nothing run (the runs file named does not even exist)."""
    status = main(["table", str(tmp_path / "absent.toml"), "-q", "--format", fmt,
                   "-o", str(tmp_path / name)])
    err = capsys.readouterr().err.strip()
    assert status == 2 and "\n" not in err
    assert f"--format {fmt}" in err and "leave --format out" in err
    assert list(tmp_path.iterdir()) == []


def test_a_format_with_a_suffix_no_format_claims_is_written_as_asked(folder, tmp_path):
    """An explicit format with a suffix of no format (``.txt``) is written as asked."""
    out = tmp_path / "table.txt"
    assert main(["table", str(folder / "runs.toml"), "-q", "--format", "csv",
                 "-o", str(out)]) == 0
    assert out.read_text().splitlines()[0].startswith("label,")
