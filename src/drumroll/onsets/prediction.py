"""Where a roll's next bounces fall: its recent flights continued.

The flights of a bouncer shrink roughly geometrically, with a ratio that changes slowly, so a
straight line through the logarithms of the recent flight times (against their bounce
numbers) predicts the next ones, with an uncertainty from the scatter about the line, the
line's own uncertainty and the onsets' timing errors.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np


def flight_predictor(time_s: np.ndarray, bounce: np.ndarray, sigma_s: np.ndarray,
                     history: int = 6, ratio_jitter: float = 0.05
                     ) -> Callable[[int], tuple[float, float]] | None:
    """A function ``n -> (interval from the last onset to bounce last + n, its log-scale
    sigma)`` from a weighted straight-line fit of the log flights (between consecutive bounce
    numbers) against their bounce numbers, or None when fewer than two flights are known."""
    consecutive = np.flatnonzero(np.diff(bounce) == 1)[-history:]
    if consecutive.size < 2:
        return None
    flights = time_s[consecutive + 1] - time_s[consecutive]
    if np.any(flights <= 0):
        return None
    y = np.log(flights)
    k = bounce[consecutive + 1].astype(float)
    # Timing errors of both ends enter each log flight.
    var_t = (sigma_s[consecutive + 1] ** 2 + sigma_s[consecutive] ** 2) / flights**2
    wts = 1.0 / (var_t + ratio_jitter**2)
    kbar = np.sum(wts * k) / wts.sum()
    sxx = np.sum(wts * (k - kbar) ** 2)
    slope = np.sum(wts * (k - kbar) * (y - np.sum(wts * y) / wts.sum())) / max(sxx, 1e-12)
    slope = min(slope, 0.0)  # flights do not grow
    icpt = np.sum(wts * (y - slope * k)) / wts.sum()
    resid = y - (icpt + slope * k)
    dof = max(flights.size - 2, 1)
    s2 = max(float(np.sum(wts * resid**2) / dof), 1.0)  # variance scale: >1 if misfitting
    w_sum = float(wts.sum())
    last_var = float(sigma_s[-1]) ** 2
    last_k = float(bounce[-1])

    def at(n: int) -> tuple[float, float]:
        ks = last_k + 1 + np.arange(n, dtype=float)
        flight = np.exp(icpt + slope * ks)
        # The line's own uncertainty is shared by the n flights; each flight's scatter is not.
        sd_line = np.sqrt(s2 * (1.0 / w_sum + (ks - kbar) ** 2 / max(sxx, 1e-12)))
        total = float(flight.sum())
        var_abs = float(np.sum(flight * sd_line)) ** 2 \
            + float(np.sum(flight**2)) * s2 * ratio_jitter**2 + last_var
        return total, math.sqrt(var_abs) / total

    return at
