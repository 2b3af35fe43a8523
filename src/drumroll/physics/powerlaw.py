"""The geometric power law of eq. 11: T_k = t_B α^k, with no geometry at all.

Under a constant restitution it fits any bouncer (a ball on a table as well as a drumstick)
and is what the paper fits to its recordings; ``powerlaw/speed`` lets the restitution change
with the impact speed (:mod:`drumroll.physics.restitution`), T_k = t_B r_k.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from drumroll.physics.bounces import (
    BAD_ALPHA,
    BAD_T_B,
    NOT_FINITE,
    Bounces,
    first_failure,
    masked_bounces,
)
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.model import (
    ForwardModel,
    Values,
    alpha_of,
    alpha_valid,
    geometric,
)


class PowerLaw(ForwardModel):
    """T_k = t_B r_k for k = 1 … N (eq. 11 with r_k = α^k): parameters α and t_B."""

    motion = "powerlaw"
    motion_title = "power law"
    colours: ClassVar[dict[str, str]] = {"constant": "#009E73", "speed": "#CC79A7"}
    linestyle = (0, (1, 1.6))
    motion_parameters = ("alpha", "t_b")
    geometric_flights = True

    def flights_at(self, ratios: NDArray, values: Values, stick_shape: str | None = None,
                   g: float = 9.81) -> tuple[NDArray, NDArray]:
        alpha, t_b = alpha_of(values), values["t_b"]
        if np.ndim(t_b) == 0:
            t_b = np.full(alpha.shape, t_b)
        with np.errstate(all="ignore"):
            valid = np.isfinite(alpha) & np.isfinite(t_b) & alpha_valid(alpha) & (t_b > 0.0)
            return geometric(t_b, ratios), valid

    def bounces_at(self, values: dict[str, NDArray], ratios: NDArray, n_flights: int,
                   stick: StickGeometry | None = None, g: float = 9.81) -> Bounces:
        """``t_c``, ``theta_c``, ``omega_c`` and ``tip_speed_c`` are NaN: the power law has
        no geometry."""
        alpha, t_b = values["alpha"], values["t_b"]
        reason = first_failure([(NOT_FINITE, ~(np.isfinite(alpha) & np.isfinite(t_b))),
                                (BAD_ALPHA, ~alpha_valid(alpha)),
                                (BAD_T_B, ~(t_b > 0))], alpha.shape)
        t_b_safe = np.where(reason == 0, t_b, 1.0)
        nan = np.full(alpha.shape, np.nan)
        return masked_bounces(reason, alpha=alpha, flights=geometric(t_b_safe, ratios),
                              speed_ratios=ratios, t_c=nan, t_b=t_b_safe, theta_c=nan,
                              omega_c=nan, tip_speed_c=nan)
