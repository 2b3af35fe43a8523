"""Pointwise log-likelihood for leave-one-out when T0 is marginalised.

With T0 integrated out, the onsets are no longer independent given θ (they share T0), so the
pointwise terms PSIS-LOO needs are the conditional densities p(t_i | t_{-i}, θ) (Bürkner,
Gabry & Vehtari 2021, "Efficient leave-one-out cross-validation for Bayesian non-factorized
normal and Student-t models"): the importance ratio of leaving onset i out is exactly
1 / p(t_i | t_{-i}, θ). Under the flat prior on T0 this is Gaussian in closed form: given the
other onsets, T0 ~ N(T̂_{-i}, 1/W_{-i}) with W_{-i} = Σ_{k≠i} w_k and T̂_{-i} the weighted
mean of their residuals, so p(t_i | t_{-i}, θ) = N(r_i; T̂_{-i}, v_i + 1/W_{-i}).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from drumroll.inference.likelihood import OnsetData

_LOG_2PI = math.log(2.0 * math.pi)


def conditional_pointwise(data: OnsetData, impacts: NDArray, jitter: NDArray) -> NDArray:
    """log p(t_i | t_{-i}, θ) per parameter row and onset, shape ``(batch, n_onsets)``.

    Parameters
    ----------
    data
        The onsets.
    impacts
        Model impact times τ_0 … τ_K after the first impact, shape ``(batch, K + 1)``; the
        onsets are compared with the columns of their bounce numbers.
    jitter
        σ (s) per row.
    """
    variance = np.asarray(jitter)[:, None] ** 2 + data.sigmas**2
    weight = 1.0 / variance
    residual = data.times - data.at_onsets(impacts)
    total_w = weight.sum(axis=1, keepdims=True)
    total_wr = (weight * residual).sum(axis=1, keepdims=True)
    others_w = total_w - weight
    others_mean = (total_wr - weight * residual) / others_w
    predictive_var = variance + 1.0 / others_w
    return -0.5 * ((residual - others_mean) ** 2 / predictive_var + np.log(predictive_var)
                   + _LOG_2PI)
