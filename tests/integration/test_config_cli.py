"""Every config error of the foundation issue, through the command line: exit 2, one line."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from configs import PAPER_STICK
from drumroll.cli.main import main

GOOD = textwrap.dedent("""\
    model = "pendulum"
    compare = ["small-angle"]

    """) + PAPER_STICK + textwrap.dedent("""\

    [priors]
    alpha = { dist = "uniform", low = 0.5, high = 1.0 }
    pivot_mm = { dist = "normal", mu = 131, sigma = 2 }
    height_mm = { dist = "normal", mu = 80, sigma = 3 }
    release_speed_m_s = 0
    release_angle_deg = 0
    jitter_ms = { dist = "loguniform", low = 0.01, high = 10 }
    t_b = { dist = "uniform", low = 0.01, high = 2.0 }
    """)


def run_predict(tmp_path: Path, text: str, capsys) -> tuple[int, str, str]:
    path = tmp_path / "config.toml"
    path.write_text(text)
    code = main(["predict", str(path), "--draws", "200"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def replace(old: str, new: str) -> str:
    assert old in GOOD, old
    return GOOD.replace(old, new)


def test_good_config_runs(tmp_path, capsys):
    code, out, err = run_predict(tmp_path, GOOD, capsys)
    assert code == 0, err
    assert "pendulum" in out and "small-angle" in out


def test_a_byte_order_mark_is_no_toml_statement(tmp_path, capsys):
    """Windows editors save UTF-8 with a byte-order mark first: read as text, not refused as
    "invalid TOML (at line 1, column 1)"; a file in another encoding is named as such."""
    path = tmp_path / "config.toml"
    path.write_bytes(b"\xef\xbb\xbf" + GOOD.encode())
    assert main(["predict", str(path), "--draws", "200"]) == 0, capsys.readouterr().err
    capsys.readouterr()
    path.write_bytes(GOOD.replace("[priors]", "# pr\u00e9-set\n[priors]").encode("latin-1"))
    assert main(["predict", str(path), "--draws", "200"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not UTF-8 text" in err[0] and "save the file as UTF-8" in err[0]


BAD_CONFIGS = {
    "malformed TOML": (replace("radius_mm = 7.5", "radius_mm = = 7.5"), ["line 8", "column"]),
    "unknown top-level key": (replace('compare = ["small-angle"]', 'compair = ["small-angle"]'),
                              ["compair", "did you mean 'compare'"]),
    "unknown prior": (replace("pivot_mm =", "pivot_m ="), ["priors.pivot_m", "pivot_mm"]),
    "unknown stick key": (replace("radius_mm", "radius"), ["stick.radius", "radius_mm"]),
    "unknown distribution": (replace('dist = "uniform", low = 0.5', 'dist = "unifrom", low = 0.5'),
                             ["priors.alpha.dist", "uniform"]),
    "unknown distribution parameter": (replace("mu = 131, sigma = 2", "mu = 131, sd = 2"),
                                       ["priors.pivot_mm", "sd"]),
    "unknown model": (replace('model = "pendulum"', 'model = "pendelum"'),
                      ["model", "'pendulum'"]),
    # a top-level key written after a [section] header belongs to that section in TOML: it
    # was reported as the default model's missing [stick], never named
    "model written under a section": (
        'gravity_m_s2 = 9.81\n[sampler]\nseed = 1\nmodel = "powerlaw"\ncompare = []\n'
        '[priors]\nalpha = { dist = "uniform", low = 0.5, high = 1.0 }\n',
        ["sampler.model", "belongs at the top of the file"]),
    "wrong type": (replace("length_mm = 348", 'length_mm = "348"'),
                   ["stick.length_mm", "expected a number"]),
    "wrong type of section": (replace("[stick]", "stick = 3\n[stack]"), ["stick"]),
    "inverted range": (replace("low = 0.5, high = 1.0", "low = 0.9, high = 0.6"),
                       ["priors.alpha", "inverted"]),
    "empty range": (replace("low = 0.5, high = 1.0", "low = 0.7, high = 0.7"),
                    ["priors.alpha", "empty"]),
    "alpha above 1": (replace("low = 0.5, high = 1.0", "low = 0.5, high = 1.2"),
                      ["priors.alpha", "(0, 1]"]),
    "fixed alpha of zero": (replace('alpha = { dist = "uniform", low = 0.5, high = 1.0 }',
                                    "alpha = 0"), ["priors.alpha", "(0, 1]"]),
    "pivot past the centre of mass": (replace("mu = 131, sigma = 2", "mu = 200, sigma = 2"),
                                      ["priors.pivot_mm", "centre of mass"]),
    "unreachable height": (replace("mu = 80, sigma = 3", "mu = 300, sigma = 3"),
                           ["priors.height_mm", "cannot reach"]),
    "negative size": (replace("radius_mm = 7.5", "radius_mm = -7.5"), ["stick.radius_mm"]),
    "negative length": (replace("length_mm = 348", "length_mm = -348"), ["stick.length_mm"]),
    "negative sigma": (replace("mu = 131, sigma = 2", "mu = 131, sigma = -2"),
                       ["priors.pivot_mm.sigma", "positive"]),
    "missing prior": (replace('height_mm = { dist = "normal", mu = 80, sigma = 3 }\n', ""),
                      ["priors.height_mm", "missing"]),
    "missing stick": (GOOD.split("[stick]")[0] + "[priors]" + GOOD.split("[priors]")[1],
                      ["stick", "missing"]),
    "tip on a thin rod": (replace('shape = "cylinder-cone"', 'shape = "thin-rod"'),
                          ["stick.tip_mm", "cylinder-cone"]),
    "negative release speed": (replace("release_speed_m_s = 0", "release_speed_m_s = -1"),
                               ["priors.release_speed_m_s"]),
    "release below contact": (replace("release_angle_deg = 0", "release_angle_deg = 40"),
                              ["priors.release_angle_deg", "contact angle"]),
    "loguniform from zero": (replace("low = 0.01, high = 10", "low = 0, high = 10"),
                             ["priors.jitter_ms"]),
    "distribution without dist": (replace('{ dist = "normal", mu = 131, sigma = 2 }',
                                          "{ mu = 131, sigma = 2 }"), ["priors.pivot_mm", "dist"]),
}


@pytest.mark.parametrize("case", sorted(BAD_CONFIGS))
def test_bad_config_is_one_line_exit_2(tmp_path, capsys, case):
    text, expected = BAD_CONFIGS[case]
    code, out, err = run_predict(tmp_path, text, capsys)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert str(tmp_path / "config.toml") in lines[0]
    for fragment in expected:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.mark.parametrize("target", ["missing.toml", "."])
def test_missing_file_and_directory(tmp_path, capsys, target):
    code = main(["predict", str(tmp_path / target)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1


def test_real_process_prints_no_traceback(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(replace("low = 0.5, high = 1.0", "low = 0.9, high = 0.6"))
    proc = subprocess.run([sys.executable, "-m", "drumroll", "predict", str(path)],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "priors.alpha" in proc.stderr


def test_usage_error_exits_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["predict"])
    assert exc.value.code == 2


def test_config_reads_no_later_stage_and_parses_their_sections_when_asked():
    """Loading a config imports neither the samplers nor the simulator (they register their
    sections' parsers); a section is parsed by its stage's parser when asked for."""
    code = textwrap.dedent("""\
        import sys
        from drumroll.config import parse_config
        priors = {"alpha": {"dist": "uniform", "low": 0.5, "high": 1.0},
                  "t_b": {"dist": "uniform", "low": 0.1, "high": 1.0}}
        config = parse_config({"model": "powerlaw", "priors": priors,
                               "sampler": {"seed": 3}, "simulate": {"n_bounces": 12, "alpha": 0.8,
                                                                "pivot_mm": 131, "height_mm": 80}})
        assert not any(m.startswith(("drumroll.inference", "drumroll.simulation", "emcee"))
                       for m in sys.modules), sorted(sys.modules)
        assert config.sections == {}
        from drumroll.inference.settings import estimate_settings
        assert estimate_settings(config).sampler.seed == 3
        import drumroll.simulation.settings
        assert config.section("simulate").n_bounces == 12
        """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stderr


def test_a_section_is_registered_under_a_known_name_only():
    from drumroll.config.loader import register_section

    with pytest.raises(ValueError, match="unknown config section 'smapler'"):
        register_section("smapler", lambda table, where: table)
