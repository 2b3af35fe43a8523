"""Geometry the models do not cover: the rim of the cone striking before the tip (issue 13,
item 8), checked against the paper's stick by hand and through the command line."""

from __future__ import annotations

import math

import numpy as np

from configs import PAPER_STICK
from drumroll.cli.main import main
from drumroll.physics.release import rim_strikes_first

#: The paper's stick: l1 = 348, l2 = 60, R = 7.5 mm; pivot d = 131 mm.
L1, L2, R, D = 0.348, 0.060, 0.0075, 0.131
#: The lowest height at which the tip still strikes first: (L − d) sin(atan(R / l2)).
RIM_HEIGHT = (L1 + L2 - D) * math.sin(math.atan2(R, L2))


def test_the_rim_strikes_first_below_34_mm_at_the_papers_pivot():
    assert 0.0343 < RIM_HEIGHT < 0.0345  # the "h < 34 mm at d = 131 mm"
    heights = np.array([0.010, RIM_HEIGHT - 1e-6, RIM_HEIGHT + 1e-6, 0.080, 0.300])
    got = rim_strikes_first("cylinder-cone", L1, L2, R, D, heights)
    np.testing.assert_array_equal(got, [True, True, False, False, False])
    # A thin rod has no cone; a height the tip cannot reach has its own reason.
    assert not rim_strikes_first("thin-rod", 0.408, 0.0, 0.0, D, 0.01).any()


def _config(height: str) -> str:
    return (f'model = "pendulum"\ncompare = ["small-angle"]\n{PAPER_STICK}\n[priors]\n'
            f'alpha = {{ dist = "uniform", low = 0.5, high = 1.0 }}\n'
            f'pivot_mm = 131\nheight_mm = {height}\n')


def test_estimate_refuses_a_set_up_below_the_rim_angle_in_one_line(tmp_path, capsys):
    (tmp_path / "low.toml").write_text(_config("30"))
    (tmp_path / "roll.csv").write_text("time_s\n" + "".join(
        f"{0.2 + 0.1 * k:.3f}\n" for k in range(6)))
    code = main(["estimate", str(tmp_path / "roll.csv"), "--prior", str(tmp_path / "low.toml"),
                 "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "rim of the cone" in err[0] and "34.4 mm" in err[0]
    assert not (tmp_path / "out").exists()


def test_predict_says_which_draws_the_rim_would_strike(tmp_path, capsys):
    (tmp_path / "edge.toml").write_text(_config('{ dist = "normal", mu = 36, sigma = 3 }'))
    assert main(["predict", str(tmp_path / "edge.toml")]) == 0
    err = capsys.readouterr().err
    below = 50 * math.erfc((36 - RIM_HEIGHT * 1e3) / (3 * math.sqrt(2)))  # P(h < rim), %
    lines = [line for line in err.splitlines() if "rim of the cone" in line]
    assert len(lines) == 2  # the exact and the small-angle pendulum
    for line in lines:
        dropped = float(line.split("% of the draws")[0].split()[-1])
        assert abs(dropped - below) < 1.5
