"""Model comparison: PSIS-LOO and Bayes factors (nested sampling), and a verdict.

Signs: every difference is **main model − other model**, so a positive ``elpd_loo_diff`` or
``log_bayes_factor`` favours the main model.

A preference is claimed only when it is clear (the verdict must not over-claim):

* LOO decides when |Δelpd| > 4 and |Δelpd| > 2 × its standard error (below 4 the standard
  error itself is unreliable: Sivula, Magnusson & Vehtari 2022);
* the Bayes factor decides when |ln B| > 1 (Jeffreys' "substantial") and > 2 × its error,
  unless it is prior-dominated (:mod:`~drumroll.inference.prior_sensitivity`: it moves by more
  than 1 nat when the priors the two models do not share are half or twice as wide), when it
  is reported but decides nothing;
* a model is preferred over another when LOO decides for it and the Bayes factor does not
  decide against it, or the Bayes factor decides for it and LOO does not decide against it.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from drumroll.distributions import Distribution
from drumroll.inference.convergence import ess_mean
from drumroll.inference.evidence import Evidence
from drumroll.inference.prior_sensitivity import PRIOR_DOMINATED_NATS, bayes_factor_shifts
from drumroll.inference.psis import smoothed_log_weights
from drumroll.inference.results import ComparisonRow, LooSummary
from drumroll.physics.models import MODELS

if TYPE_CHECKING:
    import arviz as az

    from drumroll.inference.draws import Draws

LOO_MIN_DIFF = 4.0
SIGMAS = 2.0
BF_MIN = 1.0
PARETO_K_BAD = 0.7



@dataclass(frozen=True)
class LooResult:
    """PSIS-LOO of one model.

    ``bounces`` are the bounce numbers of the onsets (the InferenceData's ``onset``
    coordinate; ``None``: 0, 1, 2, …), by which onsets are named to the user.
    """

    elpd: float
    se: float
    pointwise: np.ndarray
    pareto_k: np.ndarray
    bounces: np.ndarray | None = None

    def summary(self) -> LooSummary:
        """The record ``summary.json`` keeps."""
        return LooSummary(elpd_loo=self.elpd, elpd_loo_se=self.se,
                          pareto_k_bad=tuple(self.bad_onsets))

    @property
    def bad_onsets(self) -> list[int]:
        """Bounce numbers of the onsets whose Pareto k exceeds 0.7 (LOO unreliable there)."""
        bad = np.flatnonzero(self.pareto_k > PARETO_K_BAD)
        return [int(k) for k in (bad if self.bounces is None else self.bounces[bad])]


def loo(idata: Draws | az.InferenceData) -> LooResult:
    """PSIS-LOO of one fit (:class:`~drumroll.inference.draws.Draws` or InferenceData),
    keeping the pointwise values for paired differences: ``arviz.loo(idata, pointwise=True)``
    computed here, step for step (tests compare the two), so that the estimate need not import
    ArviZ.

    Each onset's draws are weighted by 1 / p(t_i | θ), Pareto-smoothed
    (:func:`~drumroll.inference.psis.smoothed_log_weights`) with the relative efficiency
    r_eff = mean ESS of the posterior variables / draws (ArviZ's), and elpd_i = log Σ w p.
    """
    log_lik = idata.log_likelihood["onset_time"]
    values = np.asarray(log_lik.values, float)
    n_chain, n_draw = values.shape[:2]
    n_samples = n_chain * n_draw
    pointwise = values.reshape(n_samples, -1).T  # (onsets, draws), draws chain by chain
    if n_chain == 1:
        r_eff = 1.0
    else:
        posterior = idata.posterior
        r_eff = float(np.mean(ess_mean(np.stack([np.asarray(posterior[name].values, float)
                                                  .reshape(n_chain, n_draw)
                                                  for name in posterior.data_vars]))))
        r_eff /= n_samples
    elpd_i = np.empty(pointwise.shape[0])
    pareto_k = np.empty(pointwise.shape[0])
    for i, row in enumerate(pointwise):
        log_w, pareto_k[i] = smoothed_log_weights(-row, r_eff)
        terms = log_w + row
        top = np.max(terms)
        elpd_i[i] = top + math.log(np.sum(np.exp(terms - top)))
    bounces = (np.asarray(log_lik["onset"].values) if "onset" in log_lik.coords else None)
    return LooResult(elpd=float(elpd_i.sum()), se=float((elpd_i.size * np.var(elpd_i)) ** 0.5),
                     pointwise=elpd_i, pareto_k=pareto_k, bounces=bounces)


def _sign(value: float, error: float, minimum: float) -> int:
    """+1 / −1 when ``value`` clearly favours the first / second model, else 0."""
    if abs(value) > minimum and abs(value) > SIGMAS * error:
        return 1 if value > 0 else -1
    return 0


def decide(elpd_diff: float, elpd_diff_se: float, log_bf: float | None = None,
           log_bf_err: float | None = None) -> int:
    """+1 if the first model is clearly preferred, −1 if the second is, 0 if undecided."""
    by_loo = _sign(elpd_diff, elpd_diff_se, LOO_MIN_DIFF)
    by_bf = 0 if log_bf is None else _sign(log_bf, log_bf_err or 0.0, BF_MIN)
    if by_loo and by_bf != -by_loo:
        return by_loo
    if by_bf and by_loo != -by_bf:
        return by_bf
    return 0


def compare_models(idatas: dict[str, Draws | az.InferenceData], main: str,
                   evidences: dict[str, Evidence] | None = None,
                   loos: dict[str, LooResult] | None = None,
                   inadequate: Collection[str] = (),
                   priors: Mapping[str, Mapping[str, Distribution]] | None = None
                   ) -> tuple[tuple[ComparisonRow, ...], str | None, str,
                              dict[str, LooResult]]:
    """Compare ``main`` with every other fitted model (``loos``: each model's PSIS-LOO where
    already computed, see :func:`loo`).

    A model in ``inadequate`` (its residuals fail :mod:`~drumroll.inference.adequacy`'s
    checks) is never the preferred one: that it fits better than the others does not make it
    right, and the verdict says so. ``priors`` (each model's priors by internal name) give
    every Bayes factor its prior-width sensitivity; a prior-dominated one decides nothing.

    Returns
    -------
    rows, preferred, verdict, loos
        One :class:`~drumroll.inference.results.ComparisonRow` per other model (main −
        other); the preferred model (None when the data cannot tell); the verdict in plain
        words; and each model's LOO.
    """
    evidences = evidences or {}
    loos = {name: (loos or {}).get(name) or loo(idata) for name, idata in idatas.items()}
    rows: list[ComparisonRow] = []
    sentences = []
    for name in idatas:
        if name == main:
            continue
        diff_i = loos[main].pointwise - loos[name].pointwise
        diff = float(diff_i.sum())
        diff_se = float(math.sqrt(diff_i.size * np.var(diff_i)))
        log_bf = log_bf_err = shifts = None
        if main in evidences and name in evidences:
            log_bf = evidences[main].log_z - evidences[name].log_z
            log_bf_err = math.hypot(evidences[main].log_z_err, evidences[name].log_z_err)
            if priors and main in priors and name in priors:
                shifts = bayes_factor_shifts(idatas[main].posterior, priors[main],
                                             idatas[name].posterior, priors[name])
        dominated = None if shifts is None else bool(shifts[1] > PRIOR_DOMINATED_NATS)
        rows.append(ComparisonRow(
            model=name, elpd_loo_diff=diff, elpd_loo_diff_se=diff_se, elpd_loo=loos[name].elpd,
            elpd_loo_se=loos[name].se, pareto_k_bad=tuple(loos[name].bad_onsets),
            log_bayes_factor=log_bf, log_bayes_factor_err=log_bf_err,
            log_bayes_factor_half_width=None if shifts is None else log_bf + shifts[0][0],
            log_bayes_factor_double_width=None if shifts is None else log_bf + shifts[0][1],
            prior_dominated=dominated))
        sentences.append(_sentence(main, name, decide(*_deciding(rows[-1])), diff, diff_se,
                                   log_bf, log_bf_err, dominated))
    preferred = _preferred(main, rows)
    verdict = "; ".join(sentences) if sentences else "no other model was fitted"
    if preferred is not None and preferred in inadequate:
        misfit = (f"{preferred} does not describe the onsets (its residuals fail the adequacy "
                  "checks)")
        verdict = (f"{verdict}; but {misfit}, so no model is preferred" if rows
                   else f"{verdict}, and {misfit}")
        preferred = None
    return tuple(rows), preferred, verdict, loos


def _deciding(row: ComparisonRow) -> tuple[float, float, float | None, float | None]:
    """What :func:`decide` weighs for one row: LOO, and the Bayes factor unless it is
    prior-dominated."""
    if row.prior_dominated:
        return row.elpd_loo_diff, row.elpd_loo_diff_se, None, None
    return (row.elpd_loo_diff, row.elpd_loo_diff_se, row.log_bayes_factor,
            row.log_bayes_factor_err)


def _preferred(main: str, rows: list[ComparisonRow]) -> str | None:
    """The model clearly better than every other one, or None."""
    outcomes = {row.model: decide(*_deciding(row)) for row in rows}
    if all(o == 1 for o in outcomes.values()):
        return main
    winners = [m for m, o in outcomes.items() if o == -1]
    if winners:
        # The best of the models that beat the main one must also beat the remaining
        # models: compare through the main model (winner − other = (main − other) −
        # (main − winner)).
        w = min((r for r in rows if r.model in winners), key=lambda r: r.elpd_loo_diff)
        for row in rows:
            if row.model == w.model:
                continue
            diff = row.elpd_loo_diff - w.elpd_loo_diff
            se = math.hypot(row.elpd_loo_diff_se, w.elpd_loo_diff_se)
            if _sign(diff, se, LOO_MIN_DIFF) != 1:
                return None
        return w.model
    return None


def _sentence(main: str, other: str, outcome: int, diff: float, diff_se: float,
              log_bf: float | None, log_bf_err: float | None,
              dominated: bool | None = None) -> str:
    numbers = f"Δelpd = {diff:.1f} ± {diff_se:.1f}"
    if log_bf is not None:
        # A cheap evidence's error can be ~0.01: give it one significant digit, not "± 0.0".
        decimals = 1 if not log_bf_err or log_bf_err >= 0.05 else min(
            3, -math.floor(math.log10(log_bf_err)))
        numbers += f", log BF = {log_bf:.{decimals}f} ± {log_bf_err:.{decimals}f}"
        if dominated:
            numbers += ", prior-dominated: not weighed"
    a, b = (f"the {MODELS[m].title}" if m in MODELS else m for m in (main, other))
    if outcome == 1:
        return f"{a} is preferred over {b} ({numbers})"
    if outcome == -1:
        return f"{b} is preferred over {a} ({numbers}, signs are {main} − {other})"
    return f"the data cannot tell {a} from {b} ({numbers})"
