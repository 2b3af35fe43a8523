"""One α for the table: the models' posteriors averaged with stacking weights.

The power law and the pendulums can give α values many of their sds apart while the
comparison cannot tell the models apart (table2_h50: 0.90096 ± 0.00006 against
0.89999 ± 0.00007). Quoting one model's α then hides that choice. Stacking (Yao, Vehtari,
Simpson & Gelman 2018, "Using stacking to average Bayesian predictive distributions") weighs
the models by how well their mixture predicts each onset left out: the weights w maximise

    Σ_i log Σ_m w_m exp(elpd_loo,i,m),   w on the simplex,

with the PSIS-LOO pointwise terms already computed for the comparison. The averaged α and t_B
are those of the weighted mixture of the models' posterior draws.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drumroll.inference.results import ModelAverage, ParameterSummary, json_number

#: The quantities averaged: every model has them (t_B sampled by the power law, derived by
#: the pendulums).
AVERAGED = ("alpha", "t_b")


def stacking_weights(pointwise: Mapping[str, NDArray]) -> dict[str, float]:
    """Stacking weights of the models from their pointwise elpd_loo (module docstring).

    Parameters
    ----------
    pointwise
        Each model's elpd_loo,i per onset (the same onsets, in the same order).

    Returns
    -------
    dict
        Weight per model, summing to 1.
    """
    from scipy.optimize import minimize

    names = list(pointwise)
    if len(names) == 1:
        return {names[0]: 1.0}
    elpd = np.stack([np.asarray(pointwise[n], float) for n in names])  # (models, onsets)
    top = elpd.max(axis=0)
    density = np.exp(elpd - top)  # each onset scaled by its best model: no underflow

    def objective(z: NDArray) -> tuple[float, NDArray]:
        w = np.exp(z - z.max())
        w /= w.sum()
        mix = w @ density
        grad_w = -(density / mix).sum(axis=1)  # d(−Σ log mix)/dw
        return -float(np.log(mix).sum()), w * (grad_w - w @ grad_w)  # through the softmax

    result = minimize(objective, np.zeros(len(names)), jac=True, method="L-BFGS-B")
    w = np.exp(result.x - result.x.max())
    w /= w.sum()
    return {n: float(v) for n, v in zip(names, w, strict=True)}


def model_average(posteriors: Mapping[str, object], weights: Mapping[str, float],
                  prob: float = 0.9, n_draws: int = 20_000, seed: int = 0) -> ModelAverage:
    """α and t_B of the stacking-weighted mixture of the models' posteriors.

    Parameters
    ----------
    posteriors
        Each model's ArviZ ``posterior`` group.
    weights
        From :func:`stacking_weights`.
    prob
        Mass of the highest-density interval.
    n_draws, seed
        Size of the mixture's sample (drawn from each model in proportion to its weight,
        deterministically for a seed).
    """
    return ModelAverage(weights={m: float(w) for m, w in weights.items()},
                        parameters=mixture_summaries(posteriors, weights, AVERAGED, prob,
                                                     n_draws, seed))


def mixture_summaries(posteriors: Mapping[Any, Mapping[str, Any]], weights: Mapping[Any, float],
                      names: Iterable[str], prob: float = 0.9, n_draws: int = 20_000,
                      seed: int = 0) -> dict[str, ParameterSummary]:
    """Summaries of the quantities ``names`` under the mixture of ``posteriors`` weighted by
    ``weights`` (keyed alike): mean, sd, median and the highest-density interval of mass
    ``prob`` of ``n_draws`` draws, drawn from each component in proportion to its weight
    (deterministically for a ``seed``). R-hat and ESS are not defined for a mixture (None).
    A quantity some component lacks is left out.

    Parameters
    ----------
    posteriors
        Each component's draws by quantity name (an ArviZ ``posterior`` group, or a mapping
        of arrays).
    """
    rng = np.random.default_rng(seed)
    counts = _counts(weights, n_draws)
    summaries = {}
    for name in names:
        if any(name not in posteriors[key] for key in counts):
            continue
        parts = []
        for key, count in counts.items():
            draws = np.asarray(posteriors[key][name], float).ravel()
            draws = draws[np.isfinite(draws)]
            if count and draws.size:
                parts.append(rng.choice(draws, size=count))
        mixed = np.sort(np.concatenate(parts)) if parts else np.zeros(0)
        if mixed.size < 2:
            continue
        low, high = _hdi(mixed, prob)
        summaries[name] = ParameterSummary(
            mean=json_number(mixed.mean()), sd=json_number(mixed.std(ddof=1)),
            median=json_number(np.median(mixed)), hdi_low=json_number(low),
            hdi_high=json_number(high), hdi_prob=prob)
    return summaries


def _counts(weights: Mapping[str, float], total: int) -> dict[str, int]:
    """Draws per model in proportion to its weight (largest remainders: they sum to total)."""
    names = list(weights)
    exact = np.array([weights[n] for n in names]) * total
    counts = np.floor(exact).astype(int)
    counts[np.argsort(counts - exact)[: total - counts.sum()]] += 1
    return dict(zip(names, counts.tolist(), strict=True))


def _hdi(sorted_draws: NDArray, prob: float) -> tuple[float, float]:
    """The shortest interval holding ``prob`` of the (sorted) draws."""
    n = sorted_draws.size
    k = max(1, int(np.ceil(prob * n)) - 1)
    widths = sorted_draws[k:] - sorted_draws[: n - k]
    i = int(np.argmin(widths))
    return float(sorted_draws[i]), float(sorted_draws[i + k])
