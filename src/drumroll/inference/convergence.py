"""Convergence diagnostics of an ensemble run, for many quantities at once.

Bulk and tail ESS are ArviZ's (Vehtari et al. 2021: rank-normalised, split chains, Geyer's
initial monotone sequence), with the walkers as chains; they equal ``arviz.ess(...,
method="bulk"/"tail")`` to rounding, but take every quantity in one vectorised pass (the
sampler checks them several times per run, and ArviZ costs ~10 ms per quantity and call).

R-hat is ArviZ's rank-normalised split R-hat (the larger of bulk and folded), computed with
the walkers in :data:`RHAT_GROUPS` groups as chains, each group's walkers interleaved in time
(a nested R-hat: Margossian et al. 2024, "Nested R-hat: assessing the convergence of Markov
chain Monte Carlo when running many short chains"). With the 32 walkers themselves as chains,
R-hat² ≈ 1 + (split chains) / ESS for any chain however well mixed (each walker's mean
scatters by its own Monte Carlo error), so R-hat < 1.01 would demand ESS ≈ 3,200: it would
measure the chain's length, which ESS already does, rather than whether the walkers agree.
Between groups of walkers the same term is 8 / ESS, and what is left is disagreement.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import fft, special

#: Groups of walkers that R-hat compares (Stan's customary number of chains).
RHAT_GROUPS = 4
#: Quantiles whose indicator ESS is the tail ESS (ArviZ's default).
TAIL_PROBS = (0.05, 0.95)


def _split(draws: NDArray) -> NDArray:
    """``(q, chains, n)`` → ``(q, 2 chains, n // 2)``: first and last halves (ArviZ's split)."""
    half = draws.shape[-1] // 2
    return np.concatenate([draws[..., :half], draws[..., draws.shape[-1] - half:]], axis=1)


def _average_ranks(flat: NDArray) -> NDArray:
    """Ranks 1 … n along each row of ``(q, n)``, ties given their mean rank: ``rankdata(flat,
    method="average", axis=1)`` in one sort (scipy's ranks each row apart, 1.7× slower)."""
    q, n = flat.shape
    order = np.argsort(flat, axis=1)
    ordered = np.take_along_axis(flat, order, axis=1)
    position = np.arange(n)
    starts = np.ones((q, n), bool)
    starts[:, 1:] = ordered[:, 1:] != ordered[:, :-1]
    ends = np.ones((q, n), bool)
    ends[:, :-1] = starts[:, 1:]
    # each sorted value's run of ties: from its first position to its last
    first = np.maximum.accumulate(np.where(starts, position, 0), axis=1)
    last = np.minimum.accumulate(np.where(ends, position, n - 1)[:, ::-1], axis=1)[:, ::-1]
    ranks = np.empty((q, n))
    np.put_along_axis(ranks, order, (first + last) / 2.0 + 1.0, axis=1)
    return ranks


def _z_scale(draws: NDArray) -> NDArray:
    """Rank-normalise each quantity over all its chains and draws (Blom's offset 3/8)."""
    q = draws.shape[0]
    flat = draws.reshape(q, -1)
    ranks = _average_ranks(flat)
    return special.ndtri((ranks - 0.375) / (flat.shape[1] + 0.25)).reshape(draws.shape)


def _rhat_plain(draws: NDArray) -> NDArray:
    """Classic R-hat of ``(q, chains, n)`` per quantity."""
    n = draws.shape[-1]
    chain_mean = draws.mean(axis=-1)
    within = draws.var(axis=-1, ddof=1).mean(axis=-1)
    between = n * chain_mean.var(axis=-1, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt((between / within + n - 1) / n)


def _geyer_tau(rho: list[float]) -> float:
    """τ from the combined autocorrelations ρ_0 … ρ_{n-1} by Geyer's initial monotone
    sequence, step for step as ArviZ's ``_ess``."""
    n = len(rho)
    out = [0.0] * n
    out[0] = 1.0
    even, odd = 1.0, rho[1]
    out[1] = odd
    t = 1
    while t < n - 3 and even + odd > 0.0:
        even, odd = rho[t + 1], rho[t + 2]
        if even + odd >= 0:
            out[t + 1], out[t + 2] = even, odd
        t += 2
    max_t = t - 2
    if even > 0:
        out[max_t + 1] = even
    t = 1
    while t <= max_t - 2:
        if out[t + 1] + out[t + 2] > out[t - 1] + out[t]:
            out[t + 1] = out[t + 2] = (out[t - 1] + out[t]) / 2.0
        t += 2
    return -1.0 + 2.0 * math.fsum(out[:max_t + 1]) + math.fsum(out[max_t + 1:max_t + 2])


def _ess(draws: NDArray) -> NDArray:
    """ESS of ``(q, chains, n)`` per quantity (ArviZ's ``_ess``, vectorised up to Geyer's
    sequence, which runs only as far as the autocorrelations stay positive)."""
    q, chains, n = draws.shape
    out = np.full(q, np.nan)
    if n < 4:
        return out
    centred = draws - draws.mean(axis=-1, keepdims=True)
    m = fft.next_fast_len(2 * n, real=True)
    spectrum = fft.rfft(centred, n=m, axis=-1)
    acov = fft.irfft(spectrum * np.conjugate(spectrum), n=m, axis=-1)[..., :n] / n
    mean_var = acov[..., 0].mean(axis=-1) * n / (n - 1.0)
    var_plus = mean_var * (n - 1.0) / n
    if chains > 1:
        var_plus = var_plus + draws.mean(axis=-1).var(axis=-1, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = 1.0 - (mean_var[:, None] - acov.mean(axis=1)) / var_plus[:, None]
    total = chains * n
    span = draws.max(axis=(1, 2)) - draws.min(axis=(1, 2))
    for i in range(q):
        if not np.all(np.isfinite(draws[i])):
            continue
        if span[i] < np.finfo(float).resolution:
            out[i] = total  # a constant: every draw counts (ArviZ's convention)
            continue
        if not np.all(np.isfinite(rho[i])):
            continue
        tau = max(_geyer_tau(rho[i].tolist()), 1.0 / math.log10(total))
        out[i] = total / tau
    return out


def grouped(draws: NDArray, groups: int = RHAT_GROUPS) -> NDArray:
    """``(q, walkers, n)`` → ``(q, groups, n × walkers // groups)``: each group's walkers
    interleaved step by step, so that a group's first half is the run's first half. Walkers
    beyond a multiple of ``groups`` are left out (R-hat needs chains of one length)."""
    q, walkers, n = draws.shape
    groups = max(1, min(groups, walkers))
    size = walkers // groups
    kept = draws[:, :groups * size].reshape(q, groups, size, n)
    return kept.transpose(0, 1, 3, 2).reshape(q, groups, n * size)


def r_hat(draws: NDArray, groups: int = RHAT_GROUPS) -> NDArray:
    """Rank-normalised split R-hat (max of bulk and folded) of ``(q, walkers, n)`` draws,
    the walkers in ``groups`` groups as chains (see the module docstring)."""
    split = _split(grouped(np.asarray(draws, float), groups))
    if split.shape[-1] < 2:
        return np.full(split.shape[0], np.nan)
    bulk = _rhat_plain(_z_scale(split))
    median = np.median(split.reshape(split.shape[0], -1), axis=1)[:, None, None]
    folded = _rhat_plain(_z_scale(np.abs(split - median)))
    out = np.maximum(bulk, folded)
    # A constant (a contact time at its atom 0 in every draw): the walkers agree exactly.
    out[np.ptp(split, axis=(1, 2)) == 0.0] = 1.0
    out[~np.all(np.isfinite(split), axis=(1, 2))] = np.nan
    return out


def ess_mean(draws: NDArray) -> NDArray:
    """ESS of the mean of ``(q, walkers, n)`` draws per quantity (ArviZ's ``method="mean"``:
    split chains, not rank-normalised), as PSIS-LOO's relative efficiency uses it."""
    draws = np.asarray(draws, float)
    out = _ess(_split(draws))
    out[~np.all(np.isfinite(draws), axis=(1, 2))] = np.nan
    return out


def ess_bulk(draws: NDArray) -> NDArray:
    """Bulk ESS of ``(q, walkers, n)`` draws per quantity (walkers as chains)."""
    draws = np.asarray(draws, float)
    out = _ess(_z_scale(_split(draws)))
    out[~np.all(np.isfinite(draws), axis=(1, 2))] = np.nan
    return out


def ess_tail(draws: NDArray) -> NDArray:
    """Tail ESS (the smaller of the 5 % and 95 % quantiles' indicator ESS) per quantity."""
    draws = np.asarray(draws, float)
    q = draws.shape[0]
    flat = draws.reshape(q, -1)
    out = np.full(q, np.inf)
    for prob in TAIL_PROBS:
        # R's type 7 quantile, as ArviZ's (numpy's default 'linear')
        level = np.quantile(flat, prob, axis=1)[:, None, None]
        out = np.minimum(out, _ess(_split((draws <= level).astype(float))))
    out[~np.all(np.isfinite(draws), axis=(1, 2))] = np.nan
    return out


def diagnose(variables: dict[str, NDArray], groups: int = RHAT_GROUPS
             ) -> dict[str, dict[str, float]]:
    """R-hat and bulk and tail ESS of every ``(walkers, draws)`` array, in one pass.

    Returns
    -------
    dict
        Name → ``{"r_hat", "ess_bulk", "ess_tail"}`` (NaN where undefined: non-finite
        draws, or fewer than four draws).
    """
    if not variables:
        return {}
    names = list(variables)
    stacked = np.stack([np.asarray(variables[k], float) for k in names])
    if stacked.shape[-1] < 4:
        nan = float("nan")
        return {k: {"r_hat": nan, "ess_bulk": nan, "ess_tail": nan} for k in names}
    rh, bulk, tail = r_hat(stacked, groups), ess_bulk(stacked), ess_tail(stacked)
    return {k: {"r_hat": float(rh[i]), "ess_bulk": float(bulk[i]), "ess_tail": float(tail[i])}
            for i, k in enumerate(names)}


def integrated_time(chain: NDArray, c: float = 5.0) -> NDArray:
    """Integrated autocorrelation time of each parameter of ``(steps, walkers, ndim)``: the
    walkers' mean autocorrelation function summed up to Sokal's automatic window (the
    smallest M with M ≥ c τ(M)), as ``emcee.autocorr.integrated_time`` with ``tol=0``, in one
    vectorised FFT instead of one per walker and parameter."""
    steps = chain.shape[0]
    x = np.moveaxis(np.asarray(chain, float), 0, -1)  # (walkers, ndim, steps)
    x = x - x.mean(axis=-1, keepdims=True)
    m = fft.next_fast_len(2 * steps, real=True)
    spectrum = fft.rfft(x, n=m, axis=-1)
    acf = fft.irfft(spectrum * np.conjugate(spectrum), n=m, axis=-1)[..., :steps]
    with np.errstate(divide="ignore", invalid="ignore"):
        acf = (acf / acf[..., :1]).mean(axis=0)  # (ndim, steps)
        taus = 2.0 * np.cumsum(acf, axis=-1) - 1.0
    window = np.arange(steps)[None, :] < c * taus
    first = np.where(np.any(~window, axis=-1), np.argmin(window, axis=-1), steps - 1)
    return taus[np.arange(taus.shape[0]), first]
