"""One entry point for the three forward models, by name."""

from __future__ import annotations

from typing import Literal

from numpy.typing import ArrayLike

from drumroll.physics.bounces import Bounces
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.pendulum import pendulum_bounces
from drumroll.physics.powerlaw import powerlaw_bounces
from drumroll.physics.release import STANDARD_GRAVITY, prepare_release
from drumroll.physics.small_angle import small_angle_bounces

ModelName = Literal["powerlaw", "small-angle", "pendulum"]
#: The forward models, simplest first.
MODELS: tuple[str, ...] = ("powerlaw", "small-angle", "pendulum")
#: Models that need a stick and the set-up's geometry.
GEOMETRIC_MODELS: tuple[str, ...] = ("small-angle", "pendulum")


def bounce_sequence(
    model: ModelName,
    *,
    alpha: ArrayLike,
    n_flights: int,
    t_b: ArrayLike | None = None,
    pivot: ArrayLike | None = None,
    height: ArrayLike | None = None,
    release_speed: ArrayLike = 0.0,
    release_angle: ArrayLike = 0.0,
    stick: StickGeometry | None = None,
    g: float = STANDARD_GRAVITY,
) -> Bounces:
    """The first ``n_flights`` flights of a batch of drops under ``model`` (SI units).

    Parameters
    ----------
    model
        ``"powerlaw"`` (eq. 11; needs ``alpha`` and ``t_b``), ``"small-angle"`` (eqs. 6–7) or
        ``"pendulum"`` (exact; eq. 5 generalised); the last two need ``pivot``, ``height`` and
        ``stick``.
    alpha
        Coefficient of restitution α (eq. 9).
    n_flights
        Number N of flights after the first impact.
    t_b
        First-rebound time (s), power law only.
    pivot, height
        Pivot distance d from the butt and pivot height h above the head (m).
    release_speed, release_angle
        Tip speed at release (m/s, downwards) and angle below the horizontal (rad).
    stick
        The stick's shape and size.
    g
        Gravitational acceleration (m/s²).

    Returns
    -------
    Bounces
        One sequence per element of the broadcast parameters (leading batch axis).
    """
    if n_flights < 0:
        raise ValueError("n_flights must be zero or positive")
    if model == "powerlaw":
        if t_b is None:
            raise ValueError("the powerlaw model needs t_b")
        return powerlaw_bounces(alpha, t_b, n_flights)
    if model not in GEOMETRIC_MODELS:
        raise ValueError(f"unknown model {model!r}; expected one of {MODELS}")
    if pivot is None or height is None or stick is None:
        raise ValueError(f"the {model} model needs pivot, height and stick")
    release = prepare_release(alpha, pivot, height, stick, release_speed, release_angle, g)
    if model == "pendulum":
        return pendulum_bounces(release, n_flights)
    return small_angle_bounces(release, n_flights)
