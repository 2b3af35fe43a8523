"""Every quantity drumroll reads or reports, in one registry: its names, symbols, unit, range.

A quantity has one **key** everywhere a user meets it: in configs (``[priors]``, ``[simulate]``),
``summary.json``, truth files, ``predict --json``, tables and figures (``pivot_mm``,
``theta_c_deg``, ``t_b``). Inside the package every number is SI under the quantity's
**name** (``pivot``, ``theta_c``); :attr:`Quantity.to_si` converts, once, at the boundary.
Every label, table column and JSON key is derived from here: a new quantity is one entry.

Kinds:

* ``parameter``: a model parameter with a prior (or a fixed value) under ``[priors]``;
* ``stick``: a stick dimension under ``[stick]`` (its key there drops the ``stick_`` prefix);
* ``derived``: computed from the parameters by a forward model (attribute ``bounces``: the
  :class:`~drumroll.physics.bounces.Bounces` field it comes from);
* ``nuisance``: part of the noise model (T0, Student-t ν).

This module imports nothing of drumroll's: every stage may use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

_INF = math.inf


@dataclass(frozen=True)
class Quantity:
    """One quantity as a user sees it.

    Attributes
    ----------
    key
        Name in configs, summaries, truth files and tables (a contract), e.g. ``"pivot_mm"``.
    name
        Name inside the package, in SI units, e.g. ``"pivot"``.
    symbol
        Mathematical symbol for figures (matplotlib mathtext), e.g. ``r"$d$"``.
    plain
        The symbol in plain text (Markdown, the terminal), e.g. ``"d"``, ``"θ_C"``.
    unit
        Unit of ``key`` as the user writes it (``""``: dimensionless).
    to_si
        Factor from the user's unit to SI.
    kind
        ``"parameter"``, ``"stick"``, ``"derived"`` or ``"nuisance"`` (module docstring).
    description
        Plain words.
    lower, upper, open_lower, open_upper
        Physical range in the user's unit, and whether each end is excluded.
    bounces
        For a derived quantity, the :class:`~drumroll.physics.bounces.Bounces` attribute it
        is (in SI).
    at_lower_end
        What a posterior piled against the prior's lower end means for the other quantities,
        and what to do: added to the summary's warning (``""``: nothing to add).
    may_be_absent
        Whether its prior may put an atom at 0 (``p_zero``, :class:`~drumroll.distributions.
        OrZero`): an effect that a bouncer can lack altogether.
    """

    key: str
    name: str
    symbol: str
    plain: str
    unit: str
    to_si: float
    kind: str
    description: str
    lower: float = -_INF
    upper: float = _INF
    open_lower: bool = True
    open_upper: bool = True
    bounces: str | None = None
    at_lower_end: str = ""
    may_be_absent: bool = False

    @property
    def section_key(self) -> str:
        """The key in its config section (``[stick]`` keys drop the ``stick_`` prefix)."""
        return self.key.removeprefix("stick_") if self.kind == "stick" else self.key

    @property
    def field(self) -> str:
        """The internal name within its section (a stick's ``length``, ``tip``, ``radius``)."""
        return self.name.removeprefix("stick_") if self.kind == "stick" else self.name

    def contains(self, value: float) -> bool:
        """Whether ``value`` (user's unit) lies in the physical range."""
        above = value > self.lower if self.open_lower else value >= self.lower
        below = value < self.upper if self.open_upper else value <= self.upper
        return above and below

    def range_text(self) -> str:
        """The physical range as an interval, e.g. ``(0, 1]``."""
        def show(v: float) -> str:
            return "∞" if math.isinf(v) else f"{v:g}"
        left = "(" if self.open_lower or math.isinf(self.lower) else "["
        right = ")" if self.open_upper or math.isinf(self.upper) else "]"
        return f"{left}{show(self.lower)}, {show(self.upper)}{right}"

    def label(self) -> str:
        """Axis label, e.g. ``$d$ (mm)``."""
        return f"{self.symbol} ({self.unit})" if self.unit else self.symbol

    def plain_label(self) -> str:
        """Plain-text label, e.g. ``d (mm)``."""
        return f"{self.plain} ({self.unit})" if self.unit else self.plain

    def to_user(self, value_si: float) -> float:
        """A value in SI, in the user's unit."""
        return value_si / self.to_si


_DEG = math.pi / 180.0

#: Every quantity, by key, in the order reports list them.
QUANTITIES: dict[str, Quantity] = {q.key: q for q in (
    Quantity("alpha", "alpha", r"$\alpha$", "α", "", 1.0, "parameter",
             "coefficient of restitution", 0.0, 1.0, True, False),
    Quantity("t_b", "t_b", r"$t_B$", "t_B", "s", 1.0, "parameter",
             "first-rebound time (N = 0 term of eq. 11)", 0.0, _INF, True, True,
             bounces="t_b"),
    Quantity("pivot_mm", "pivot", r"$d$", "d", "mm", 1e-3, "parameter",
             "pivot distance from the butt", 0.0, _INF, False, True),
    Quantity("height_mm", "height", r"$h$", "h", "mm", 1e-3, "parameter",
             "pivot height above the drumhead", 0.0, _INF, True, True),
    Quantity("release_speed_m_s", "release_speed", r"$v_0$", "v₀", "m/s", 1.0, "parameter",
             "tip speed at release (downwards)", 0.0, _INF, False, True),
    Quantity("release_angle_deg", "release_angle", r"$\theta_0$", "θ₀", "deg", _DEG,
             "parameter", "release angle below the horizontal", -90.0, 90.0, True, True),
    Quantity("stick_length_mm", "stick_length", r"$l_1$", "l₁", "mm", 1e-3, "stick",
             "cylinder length l1 (thin rod: the whole length L)", 0.0, _INF, True, True),
    Quantity("stick_tip_mm", "stick_tip", r"$l_2$", "l₂", "mm", 1e-3, "stick",
             "conical tip length l2", 0.0, _INF, False, True),
    Quantity("stick_radius_mm", "stick_radius", r"$R$", "R", "mm", 1e-3, "stick",
             "stick radius R", 0.0, _INF, False, True),
    Quantity("jitter_ms", "jitter", r"$\sigma$", "σ", "ms", 1e-3, "parameter",
             "onset-timing jitter", 0.0, _INF, True, True),
    Quantity("contact_ms", "contact", r"$\tau_c$", "τ_c", "ms", 1e-3, "parameter",
             "contact time of each impact (its flight starts this long after its onset)",
             0.0, _INF, False, True,
             # benchmarks/corpus_truth.py, rolls with instantaneous impacts under U(0, 3 ms):
             # alpha's mean z -1.0, t_B's -1.5 (-0.2 with contact_ms = 0)
             at_lower_end="α and t_B lean low with it, by about 1 sd if the impacts truly "
                          "have no contact: give the prior an atom at 0 (p_zero = 0.5, as "
                          "the default does) or say contact_ms = 0",
             may_be_absent=True),
    Quantity("restitution_scatter", "restitution_scatter", r"$s_\alpha$", "s_α", "", 1.0,
             "parameter", "bounce-to-bounce scatter of the restitution (sd of ln α_k)",
             0.0, _INF, False, True, may_be_absent=True),
    Quantity("restitution_exponent", "restitution_exponent", r"$p$", "p", "", 1.0,
             "parameter", "exponent of the restitution's speed dependence, "
             "1 − α(v) = (1 − α)(v/v₁)^p (models MOTION/speed)"),
    Quantity("jitter_sd_ms", "jitter_sd", r"$\sigma_\mathrm{sd}$", "sd of the jitter", "ms",
             1e-3, "derived", "standard deviation of the Student-t onset noise, "
             "σ √(ν / (ν − 2)) (ν > 2; the jitter σ is its scale)", 0.0, _INF, True, True),
    Quantity("nu", "nu", r"$\nu$", "ν", "", 1.0, "nuisance",
             "Student-t degrees of freedom of the onset noise", 0.0, _INF, True, True),
    Quantity("t_c", "t_c", r"$t_C$", "t_C", "s", 1.0, "derived",
             "fall time from release to the first impact", bounces="t_c"),
    Quantity("theta_c_deg", "theta_c", r"$\theta_C$", "θ_C", "deg", _DEG, "derived",
             "stick angle at contact", bounces="theta_c"),
    Quantity("omega_c", "omega_c", r"$\omega_C$", "ω_C", "rad/s", 1.0, "derived",
             "angular speed at the first contact", bounces="omega_c"),
    Quantity("contact_tip_speed_m_s", "tip_speed_c", r"$v_C$", "v_C", "m/s", 1.0, "derived",
             "tip speed at the first contact", bounces="tip_speed_c"),
    Quantity("effective_height_mm", "effective_height", r"$h_\mathrm{eff}$", "h_eff", "mm",
             1e-3, "derived", "effective height of eq. 8, h K_O² / ((l_C − d)(L − d))"),
    Quantity("tip_mass_ratio", "tip_mass_ratio", r"$K_O^2/(L-d)^2$", "K_O²/(L − d)²", "", 1.0,
             "derived", "the tip's effective mass ratio K_O² / (L − d)²"),
    Quantity("t0_s", "t0", r"$t_0$", "t₀", "s", 1.0, "nuisance",
             "time of the first impact in the recording"),
)}

#: The quantities with a prior under ``[priors]``, by key.
PARAMETERS: dict[str, Quantity] = {k: q for k, q in QUANTITIES.items()
                                   if q.kind == "parameter"}
#: The stick's dimensions, by their ``[stick]`` key (``length_mm``, ``tip_mm``, ``radius_mm``).
STICK_DIMENSIONS: dict[str, Quantity] = {q.section_key: q for q in QUANTITIES.values()
                                         if q.kind == "stick"}
#: Quantities a forward model derives from the parameters (t_B is one too where it is not a
#: parameter), by key.
DERIVED: dict[str, Quantity] = {k: q for k, q in QUANTITIES.items() if q.bounces is not None}
#: Quantities computed from each posterior draw outside the forward model, by key: eq. 8's
#: effective height and the tip's mass ratio (:func:`drumroll.physics.geometry.
#: effective_height`), the Student-t noise's standard deviation.
DRAW_DERIVED: dict[str, Quantity] = {k: q for k, q in QUANTITIES.items()
                                      if q.kind == "derived" and q.bounces is None}
#: Every quantity by its internal (SI) name.
BY_NAME: dict[str, Quantity] = {q.name: q for q in QUANTITIES.values()}

#: Values used when a config leaves a parameter out (user's units).
DEFAULT_VALUES: dict[str, float] = {"release_speed_m_s": 0.0, "release_angle_deg": 0.0}
#: Priors used when a model needs a parameter the config leaves out, written as in a config:
#: the speed law's exponent is weakly informative around the constant law (p = 0), wide
#: enough for viscoelastic theory's 1/5 and for a light ball's drag (p ≈ 0.5).
DEFAULT_PRIORS: dict[str, dict[str, object]] = {
    "restitution_exponent": {"dist": "normal", "mu": 0.0, "sigma": 0.5}}


def quantity(key: str) -> Quantity:
    """The quantity of ``key`` (a user-facing key, or an internal name).

    Raises
    ------
    KeyError
        Neither a key nor a name of any quantity.
    """
    if key in QUANTITIES:
        return QUANTITIES[key]
    if key in BY_NAME:
        return BY_NAME[key]
    raise KeyError(key)


def report_order(keys: list[str] | tuple[str, ...]) -> list[str]:
    """``keys`` in the registry's order (unknown keys last, alphabetically)."""
    order = {key: i for i, key in enumerate(QUANTITIES)}
    return sorted(keys, key=lambda k: (order.get(k, len(order)), k))
