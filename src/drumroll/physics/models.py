"""The registry of forward models, and one entry point for them by name."""

from __future__ import annotations

from typing import Literal

from numpy.typing import ArrayLike

from drumroll.physics.bounces import Bounces
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.model import ForwardModel
from drumroll.physics.pendulum import Pendulum
from drumroll.physics.powerlaw import PowerLaw
from drumroll.physics.release import STANDARD_GRAVITY
from drumroll.physics.restitution import DEFAULT_LAW, EXPONENT, LAWS
from drumroll.physics.small_angle import SmallAngle
from drumroll.quantities import BY_NAME

ModelName = Literal["powerlaw", "small-angle", "pendulum", "powerlaw/speed",
                    "small-angle/speed", "pendulum/speed"]

#: The motions between impacts, simplest first (a new motion: one module, one line here).
MOTIONS: tuple[type[ForwardModel], ...] = (PowerLaw, SmallAngle, Pendulum)
#: Every forward model by name: each motion under each restitution law, ``MOTION`` for the
#: constant law (eq. 9) and ``MOTION/LAW`` for the others (the names are a contract).
MODELS: dict[str, ForwardModel] = {m.name: m for law in LAWS.values()
                                   for m in (motion(law) for motion in MOTIONS)}
#: The motions that need a stick and the set-up's geometry, by their constant-law names: what
#: the geometry alone predicts (t_B does not depend on the law) and what the simulator runs.
GEOMETRIC_MODELS: tuple[str, ...] = tuple(m.motion for m in MOTIONS if m.needs_stick)


def parameter_keys(name: str) -> tuple[str, ...]:
    """The config keys of the parameters model ``name`` takes a prior (or value) for."""
    return tuple(BY_NAME[parameter].key for parameter in forward_model(name).parameters)


def canonical_name(name: str) -> str:
    """A model's name as registered: ``MOTION/constant`` is written ``MOTION``."""
    return name.removesuffix(f"/{DEFAULT_LAW.name}")


def forward_model(name: str) -> ForwardModel:
    """The registered model called ``name`` (``MOTION`` or ``MOTION/LAW``)."""
    try:
        return MODELS[canonical_name(name)]
    except KeyError:
        raise ValueError(f"unknown model {name!r}; expected one of {tuple(MODELS)}") from None


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
    restitution_exponent: ArrayLike = 0.0,
    stick: StickGeometry | None = None,
    g: float = STANDARD_GRAVITY,
) -> Bounces:
    """The first ``n_flights`` flights of a batch of drops under ``model`` (SI units).

    Parameters
    ----------
    model
        ``"powerlaw"`` (eq. 11; needs ``alpha`` and ``t_b``), ``"small-angle"`` (eqs. 6–7) or
        ``"pendulum"`` (exact; eq. 5 generalised); the last two need ``pivot``, ``height`` and
        ``stick``. ``MOTION/speed`` makes the restitution depend on the impact speed.
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
    restitution_exponent
        p of the speed law, 1 − α(v) = (1 − α)(v / v₁)^p (models ``MOTION/speed``).
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
    forward = forward_model(model)
    law = {EXPONENT: restitution_exponent} if EXPONENT in forward.parameters else {}
    if not forward.needs_stick:
        if t_b is None:
            raise ValueError(f"the {model} model needs t_b")
        return forward.bounces({"alpha": alpha, "t_b": t_b, **law}, n_flights)
    if pivot is None or height is None or stick is None:
        raise ValueError(f"the {model} model needs pivot, height and stick")
    return forward.bounces({"alpha": alpha, "pivot": pivot, "height": height,
                            "release_speed": release_speed, "release_angle": release_angle,
                            **law}, n_flights, stick, g)
