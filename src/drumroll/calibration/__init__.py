"""Simulation-based calibration of ``estimate`` (Talts et al. 2018): ``drumroll calibrate``.

:mod:`.roll` draws a parameter point from a config's priors and simulates its roll,
:mod:`.recording` renders it as a recording and extracts its onsets, :mod:`.run` fits every
simulation and gathers the ranks and coverages (whose statistics are
:mod:`drumroll.inference.calibration`'s), and :mod:`.results` holds what was found.
"""

from drumroll.calibration.results import CalibrationResult
from drumroll.calibration.run import calibrate

__all__ = ["CalibrationResult", "calibrate"]
