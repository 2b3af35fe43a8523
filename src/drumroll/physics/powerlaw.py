"""The geometric power law of eq. 11: T_k = t_B α^k, with no geometry at all.

It fits any bouncer whose restitution does not depend on the impact speed (a ball on a table
as well as a drumstick) and is what the paper fits to its recordings.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from drumroll.physics.bounces import (
    BAD_ALPHA,
    BAD_T_B,
    NOT_FINITE,
    Bounces,
    first_failure,
    masked_bounces,
    safe_alpha,
)
from drumroll.physics.geometry import StickGeometry
from drumroll.physics.model import (
    ForwardModel,
    Values,
    alpha_of,
    alpha_valid,
    batch,
    geometric,
)


class PowerLaw(ForwardModel):
    """T_k = t_B α^k for k = 1 … N (eq. 11): parameters α and t_B."""

    name = "powerlaw"
    title = "power law"
    colour = "#009E73"
    linestyle = (0, (1, 1.6))
    parameters = ("alpha", "t_b")
    geometric_flights = True

    def flights(self, values: Values, n_flights: int, stick_shape: str | None = None,
                g: float = 9.81) -> tuple[NDArray, NDArray]:
        alpha, t_b = alpha_of(values), values["t_b"]
        if np.ndim(t_b) == 0:
            t_b = np.full(alpha.shape, t_b)
        with np.errstate(all="ignore"):
            valid = np.isfinite(alpha) & np.isfinite(t_b) & alpha_valid(alpha) & (t_b > 0.0)
            return geometric(t_b, alpha, n_flights), valid

    def bounces(self, values: Values, n_flights: int, stick: StickGeometry | None = None,
                g: float = 9.81) -> Bounces:
        """``t_c``, ``theta_c``, ``omega_c`` and ``tip_speed_c`` are NaN: the power law has
        no geometry."""
        alpha, t_b = batch(values["alpha"], values["t_b"])
        reason = first_failure([(NOT_FINITE, ~(np.isfinite(alpha) & np.isfinite(t_b))),
                                (BAD_ALPHA, ~alpha_valid(alpha)),
                                (BAD_T_B, ~(t_b > 0))], alpha.shape)
        t_b_safe = np.where(reason == 0, t_b, 1.0)
        nan = np.full(alpha.shape, np.nan)
        return masked_bounces(reason, alpha=alpha,
                              flights=geometric(t_b_safe, safe_alpha(alpha, reason), n_flights),
                              t_c=nan, t_b=t_b_safe, theta_c=nan, omega_c=nan, tip_speed_c=nan)
