"""How much a Bayes factor owes to the widths of the priors the two models do not share.

The evidence of a model falls as the prior of a parameter the data pin down widens (the Occam
factor): a flat t_B prior twice as wide costs the power law ln 2, and the comparison with a
pendulum, which has no t_B, moves by as much although the data are the same. Widening or
narrowing a prior by a factor f changes the evidence by

    Z_f / Z = E_posterior[ p_f(θ) / p(θ) ]

(importance reweighting of the draws already made: no new sampling), so the Bayes factor of
two models moves by the difference of their shifts over the parameters each has and the other
has not. A Bayes factor that moves by more than :data:`PRIOR_DOMINATED_NATS` when those priors
are half or twice as wide (:data:`WIDTHS`) is "prior-dominated": it says more about the
priors than about the data, and the verdict does not rest on it.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping

import numpy as np

from drumroll.distributions import Distribution
from drumroll.quantities import BY_NAME

#: Width factors of the check: the priors of the non-shared parameters half and twice as wide.
WIDTHS = (0.5, 2.0)
#: A Bayes factor that moves by more than this (nats) under :data:`WIDTHS` is prior-dominated.
PRIOR_DOMINATED_NATS = 1.0


def log_evidence_shift(posterior, priors: Mapping[str, Distribution], names: Collection[str],
                       factor: float) -> float | None:
    """ln Z_f − ln Z when the priors of ``names`` are ``factor`` times as wide.

    Parameters
    ----------
    posterior
        The model's posterior draws: ArviZ's ``posterior`` group (user units, summary keys).
    priors
        The model's priors by internal name (SI).
    names
        The parameters whose priors change (internal names).
    factor
        Width factor (:meth:`~drumroll.distributions.Distribution.widened`).

    Returns
    -------
    float or None
        None when a prior has no width to scale, or no draw lies inside a narrowed prior.
    """
    if not names:
        return 0.0
    log_ratio = 0.0
    for name in names:
        wide = priors[name].widened(factor)
        if wide is None:
            return None
        quantity = BY_NAME[name]
        x = quantity.to_si * np.asarray(posterior[quantity.key].values, float).ravel()
        log_ratio = log_ratio + wide.logpdf(x) - priors[name].logpdf(x)
    log_ratio = np.asarray(log_ratio, float)
    top = np.max(log_ratio)
    if not np.isfinite(top):
        return None
    return float(top + math.log(np.mean(np.exp(log_ratio - top))))


def bayes_factor_shifts(main_posterior, main_priors: Mapping[str, Distribution],
                        other_posterior, other_priors: Mapping[str, Distribution]
                        ) -> tuple[tuple[float, float], float] | None:
    """How ln B (main − other) moves when the priors of the parameters only one of the two
    models samples are half or twice as wide (:data:`WIDTHS`).

    Returns
    -------
    (half, double), largest
        The shifts with both models' non-shared priors scaled together, and the largest
        |shift| of any scaling, together or one model's at a time (the two models' Occam
        factors can cancel when scaled together, and a user changes one prior at a time);
        None when a shift cannot be computed.
    """
    main_only = _sampled(main_priors) - _sampled(other_priors)
    other_only = _sampled(other_priors) - _sampled(main_priors)
    together, largest = [], 0.0
    for factor in WIDTHS:
        main = log_evidence_shift(main_posterior, main_priors, main_only, factor)
        other = log_evidence_shift(other_posterior, other_priors, other_only, factor)
        if main is None or other is None:
            return None
        together.append(main - other)
        largest = max(largest, abs(main - other), abs(main), abs(other))
    return (together[0], together[1]), largest


def _sampled(priors: Mapping[str, Distribution]) -> set[str]:
    """The sampled parameters of a model with a registered quantity (its physics and noise;
    T0 and ν of the Student-t noise are shared by construction)."""
    return {name for name, prior in priors.items()
            if not prior.is_fixed and name in BY_NAME and BY_NAME[name].kind != "nuisance"}
