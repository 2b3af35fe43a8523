"""The geometric power law of eq. 11: T_k = t_B α^k, with no geometry at all.

It fits any bouncer whose restitution does not depend on the impact speed (a ball on a table
as well as a drumstick) and is what the paper fits to its recordings.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from drumroll.physics.bounces import (
    BAD_ALPHA,
    BAD_T_B,
    NOT_FINITE,
    Bounces,
    first_failure,
    masked_bounces,
    safe_alpha,
)


def powerlaw_bounces(alpha: ArrayLike, t_b: ArrayLike, n_flights: int) -> Bounces:
    """Flight times of the power law, T_k = t_B α^k for k = 1 … N (eq. 11).

    Parameters
    ----------
    alpha
        Coefficient of restitution α, shape ``(batch,)`` or scalar.
    t_b
        First-rebound time t_B (s), broadcastable against ``alpha``.
    n_flights
        Number N of flights to return.

    Returns
    -------
    Bounces
        ``t_c``, ``theta_c``, ``omega_c`` and ``tip_speed_c`` are NaN: the power law has no
        geometry.
    """
    alpha, t_b = np.broadcast_arrays(np.asarray(alpha, float), np.asarray(t_b, float))
    alpha, t_b = np.atleast_1d(alpha), np.atleast_1d(t_b)
    reason = first_failure([(NOT_FINITE, ~(np.isfinite(alpha) & np.isfinite(t_b))),
                            (BAD_ALPHA, ~((alpha > 0) & (alpha <= 1))),
                            (BAD_T_B, ~(t_b > 0))], alpha.shape)
    k = np.arange(1, n_flights + 1)
    t_b_safe = np.where(reason == 0, t_b, 1.0)
    flights = t_b_safe[:, None] * safe_alpha(alpha, reason)[:, None] ** k
    nan = np.full(alpha.shape, np.nan)
    return masked_bounces(reason, alpha=alpha, flights=flights, t_c=nan, t_b=t_b_safe,
                          theta_c=nan, omega_c=nan, tip_speed_c=nan)
