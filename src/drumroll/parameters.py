"""The model parameters: names, units and physical ranges, in one table.

Config files and reports speak in the units of the paper's tables (millimetres, milliseconds,
degrees); everything inside the package is SI. The conversion happens once, with
:attr:`ParameterSpec.to_si`, when a config is read and when a report is written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class ParameterSpec:
    """One parameter as a user sees it.

    Attributes
    ----------
    key
        Name in configs and summaries (a contract), e.g. ``"pivot_mm"``.
    name
        Name inside the package (SI units), e.g. ``"pivot"``.
    symbol
        Mathematical symbol for tables and plots (matplotlib mathtext).
    unit
        Unit of ``key`` as the user writes it ('' for dimensionless).
    to_si
        Factor from the user's unit to SI.
    lower, upper
        Physical range in the user's unit.
    open_lower, open_upper
        Whether an end of the range is excluded.
    description
        Plain words.
    """

    key: str
    name: str
    symbol: str
    unit: str
    to_si: float
    lower: float
    upper: float
    open_lower: bool
    open_upper: bool
    description: str

    def contains(self, value: float) -> bool:
        """Whether ``value`` (user's unit) lies in the physical range."""
        above = value > self.lower if self.open_lower else value >= self.lower
        below = value < self.upper if self.open_upper else value <= self.upper
        return above and below

    def range_text(self) -> str:
        """The physical range as an interval, e.g. ``(0, 1]``."""
        def show(v: float) -> str:
            return "∞" if math.isinf(v) else f"{v:g}"
        left = "(" if self.open_lower else "["
        right = ")" if self.open_upper or math.isinf(self.upper) else "]"
        return f"{left}{show(self.lower)}, {show(self.upper)}{right}"

    def label(self) -> str:
        """Axis label such as ``$d$ (mm)``."""
        return f"{self.symbol} ({self.unit})" if self.unit else self.symbol


_INF = math.inf
#: Sampled (or fixed) parameters, by config key.
PARAMETERS: dict[str, ParameterSpec] = {p.key: p for p in (
    ParameterSpec("alpha", "alpha", r"$\alpha$", "", 1.0, 0.0, 1.0, True, False,
                  "coefficient of restitution"),
    ParameterSpec("t_b", "t_b", r"$t_B$", "s", 1.0, 0.0, _INF, True, True,
                  "first-rebound time (power law)"),
    ParameterSpec("pivot_mm", "pivot", r"$d$", "mm", 1e-3, 0.0, _INF, False, True,
                  "pivot distance from the butt"),
    ParameterSpec("height_mm", "height", r"$h$", "mm", 1e-3, 0.0, _INF, True, True,
                  "pivot height above the drumhead"),
    ParameterSpec("release_speed_m_s", "release_speed", r"$v_0$", "m/s", 1.0, 0.0, _INF,
                  False, True, "tip speed at release (downwards)"),
    ParameterSpec("release_angle_deg", "release_angle", r"$\theta_0$", "deg", math.pi / 180,
                  -90.0, 90.0, True, True, "release angle below the horizontal"),
    ParameterSpec("jitter_ms", "jitter", r"$\sigma$", "ms", 1e-3, 0.0, _INF, True, True,
                  "onset-timing jitter"),
)}

#: Stick dimensions, by key of the ``[stick]`` section.
STICK_DIMENSIONS: dict[str, ParameterSpec] = {p.key: p for p in (
    ParameterSpec("length_mm", "length", r"$l_1$", "mm", 1e-3, 0.0, _INF, True, True,
                  "cylinder length l1 (thin rod: the whole length L)"),
    ParameterSpec("tip_mm", "tip", r"$l_2$", "mm", 1e-3, 0.0, _INF, False, True,
                  "conical tip length l2"),
    ParameterSpec("radius_mm", "radius", r"$R$", "mm", 1e-3, 0.0, _INF, False, True,
                  "stick radius R"),
)}

#: Parameters each model needs a prior (or value) for; defaults apply to the others.
MODEL_PARAMETERS: dict[str, tuple[str, ...]] = {
    "powerlaw": ("alpha", "t_b"),
    "small-angle": ("alpha", "pivot_mm", "height_mm", "release_speed_m_s", "release_angle_deg"),
    "pendulum": ("alpha", "pivot_mm", "height_mm", "release_speed_m_s", "release_angle_deg"),
}

#: Values used when a config leaves a parameter out (user's units).
DEFAULT_VALUES: dict[str, float] = {"release_speed_m_s": 0.0, "release_angle_deg": 0.0}
