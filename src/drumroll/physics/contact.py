"""How long each impact lasts: the contact time's law.

The onset marks the start of contact; the next flight starts at its end, so impact m comes
Σ_{j<m} τ_j later than the flights alone put it (physics.md). Two laws:

* ``constant``: τ_j = τ_c for every impact;
* ``hertz``: τ_j = τ_c (v_j / v_1)^{−1/5}, the duration of a Hertzian impact of an elastic
  sphere (Landau & Lifshitz, *Theory of Elasticity*, §9; Johnson, *Contact Mechanics*,
  eq. 11.24): slower impacts last longer. ``contact_ms`` is then the first impact's τ_c.

v_j / v_1 is the impact's speed over the first one's: 1 for impact 0, the rebound-speed ratio
r_j of :mod:`drumroll.physics.restitution` for impact j ≥ 1 (a flight lands as fast as it
left).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: The contact-time laws by name; the first is the default.
CONTACT_LAWS: tuple[str, ...] = ("constant", "hertz")
#: τ ∝ v^{HERTZ_EXPONENT} for a Hertzian impact.
HERTZ_EXPONENT = -0.2


def contact_delays(contact: ArrayLike, n_impacts: int, speed_ratios: NDArray | None = None
                   ) -> NDArray:
    """How much later than the flights alone each impact 0 … n_impacts − 1 comes.

    Parameters
    ----------
    contact
        τ_c (s) per batch row, shape ``(batch,)``, or a scalar.
    n_impacts
        N + 1.
    speed_ratios
        r_1 … r_N, shape ``(batch, N)``, for the Hertzian law; None for a constant τ_c.

    Returns
    -------
    NDArray
        Shape ``(batch, N + 1)``: 0, τ_0, τ_0 + τ_1, …
    """
    contact = np.reshape(np.asarray(contact, float), (-1, 1))
    if speed_ratios is None:
        return contact * np.arange(n_impacts, dtype=float)
    durations = np.ones((max(contact.shape[0], speed_ratios.shape[0]), n_impacts))
    durations[:, 1:] = speed_ratios[:, :n_impacts - 1] ** HERTZ_EXPONENT
    delays = np.zeros_like(durations)
    np.cumsum(durations[:, :-1], axis=1, out=delays[:, 1:])
    return contact * delays
