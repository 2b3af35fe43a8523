"""Impacts missed before the first onset: a discrete parameter of the stick models.

A roll's first impact is its loudest sound, but a recording can still begin late, or its
first impact be clipped or masked by handling noise. The onsets are then numbered from the
wrong impact, and every flight is one α too long. The power law cannot notice (its t_B
absorbs the factor), but a stick model can: its geometry fixes t_B (eq. 11's N = 0 term),
so numbering the first onset as impact m is a different prediction. The number m of impacts
missed before the first onset (0, 1 or 2, equally likely a priori) is therefore a discrete
parameter, marginalised by the models' evidences:

    P(m | onsets) = Z_m / Σ_j Z_j,   Z_m = p(onsets | first onset is impact m),

each Z_m the evidence of the main model fitted to the onsets renumbered k → k + m
(:func:`shifted`). Z_0 is the main fit's own evidence; each other numbering is sampled to a
smaller ESS (its draws only have to carry the importance-sampling evidence), so m up to 2
costs two more fits of the main model, which is why it is asked for (``[likelihood]
missed_first = 2``) rather than on by default. (A Laplace approximation at the renumbered
mode, tried instead of the chain, gave the same ln Z differences on table2_h80 but failed the
importance sampler's own Pareto-k check, so nested sampling would have had to decide, at
three times the cost.) A warning is given where m = 0 is not clearly preferred.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from drumroll.inference.likelihood import OnsetData

#: The largest number of impacts that can be considered missed (each costs one fit).
MAX_MISSED = 2
#: The ESS a numbering m ≥ 1 is sampled to: importance sampling needs draws that cover its
#: posterior, not a thousand independent ones.
EVIDENCE_ONLY_ESS = 300
#: P(m = 0) below this: "0" is not clearly preferred, and the user is told.
CLEARLY = 0.95


def shifted(data: OnsetData, missed: int) -> OnsetData:
    """The onsets with the first one numbered as impact ``missed`` (k → k + missed)."""
    return OnsetData(data.times, data.sigmas, np.asarray(data.bounces) + missed)


def missed_probabilities(log_evidences: Sequence[float]) -> tuple[float, ...]:
    """P(m | onsets) for m = 0, 1, … from each numbering's ln Z (a uniform prior over m);
    a numbering whose evidence is not finite gets probability 0."""
    log_z = np.asarray(log_evidences, float)
    finite = np.isfinite(log_z)
    if not finite.any():
        return tuple(math.nan for _ in log_z)
    weights = np.where(finite, np.exp(np.where(finite, log_z, 0.0) - log_z[finite].max()), 0.0)
    return tuple(float(w) for w in weights / weights.sum())


def missed_note(model: str, probabilities: Sequence[float]) -> str:
    """The posterior of m in words, for the report's notes."""
    shown = ", ".join(f"P({m}) = {p:.3g}" for m, p in enumerate(probabilities))
    return (f"{model}: impacts missed before the first onset (the geometry fixes t_B, so a "
            f"recording that begins late would show): {shown}")


def missed_warning(model: str, probabilities: Sequence[float]) -> str | None:
    """A warning where m = 0 is not clearly preferred (P(0) < :data:`CLEARLY`)."""
    if not probabilities or not probabilities[0] < CLEARLY:
        return None
    likeliest = int(np.argmax(probabilities))
    return (f"{model}: the first onset may not be the roll's first impact: P(none missed) = "
            f"{probabilities[0]:.2g}, P({likeliest} missed) = {probabilities[likeliest]:.2g}; "
            "check the recording's start (onsets.png), or number the onsets with a bounce "
            "column")
