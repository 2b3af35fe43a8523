"""The statistics of simulation-based calibration (SBC; Talts, Betancourt, Simpson, Vehtari &
Gelman 2018, "Validating Bayesian inference algorithms with simulation-based calibration",
arXiv:1804.06788).

If θ̃ is drawn from the prior, data ỹ from the model given θ̃, and θ_1 … θ_L from the posterior
given ỹ, then the rank of θ̃ among the θ_l (the number of draws below it) is uniform on
{0, …, L} for every quantity f(θ) whenever the posterior is the right one (Talts et al.,
Theorem 1). An inference that is too confident piles the ranks at both ends (a ∪), one too
cautious in the middle (a ∩), a biased one on one side. What this module computes, for n such
simulations:

* the rank of a truth among draws (ties broken at random, Algorithm 1), and which draws of a
  chain to rank against: L of them, spaced by the autocorrelation time so that they are
  nearly independent (correlated draws pile the ranks at the ends, Talts et al., section 5.1);
* the rank histogram in B bins (B divides L + 1, so every bin holds the same number of rank
  values), the band each bin's count stays inside with 99 % probability when the ranks are
  uniform (Binomial(n, 1/B) quantiles, as Talts et al.'s figures draw it), and Pearson's χ²
  test of uniformity on the bins;
* the coverage of central credible intervals (the share of simulations whose interval holds
  the truth) with Clopper–Pearson error bars, and the binomial band in which a calibrated
  coverage falls with 99 % probability.

Everything here is plain numbers: the binomial and χ² tails come from :mod:`scipy.special`
(scipy.stats, with its import cost, is not needed; the tests check these against it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

from drumroll.inference.results import Record

#: The probability of the bands drawn for a calibrated inference (rank-histogram bins,
#: coverage): a calibrated quantity falls outside with probability 1 %.
BAND_PROBABILITY = 0.99
#: The error bars of an observed coverage: the central 68.27 % (one standard deviation's)
#: Clopper–Pearson interval.
ERROR_PROBABILITY = math.erf(1.0 / math.sqrt(2.0))
#: Least expected count per rank-histogram bin for Pearson's χ² test to hold (Cochran's rule).
MIN_EXPECTED = 5
#: Most rank-histogram bins (Talts et al. use 20).
MAX_BINS = 20


def rank_statistic(truth: float, draws: ArrayLike, rng: np.random.Generator) -> int:
    """The rank of ``truth`` among ``draws``: how many draws lie below it, in 0 … L.

    A draw equal to the truth (a discrete quantity, or a value fixed by a bound) counts as
    below with a fair coin per tie, so that ties cannot pile the ranks up (Talts et al. 2018,
    Algorithm 1: the rank is uniform on 0 … L only if ties are split at random).
    """
    values = np.asarray(draws, float).ravel()
    below = int(np.count_nonzero(values < truth))
    ties = int(np.count_nonzero(values == truth))
    return below + (int(rng.integers(0, ties + 1)) if ties else 0)


def draw_spacing(tau_steps: ArrayLike, thin: int) -> int:
    """How many stored draws apart two draws of one chain must be to be nearly independent:
    the longest integrated autocorrelation time τ (in sampler steps) over the thinning the
    stored draws already have (at least 1)."""
    tau = np.asarray(tau_steps, float)
    tau = tau[np.isfinite(tau)]
    longest = float(tau.max()) if tau.size else 1.0
    return max(1, math.ceil(longest / max(int(thin), 1)))


def independent_draws(n_chains: int, n_draws: int, spacing: int, size: int,
                      rng: np.random.Generator) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """``size`` positions (chain, draw) of a run of ``n_chains`` chains of ``n_draws`` stored
    draws that are nearly independent of each other.

    Along each chain only every ``spacing``-th draw is a candidate (from a random offset):
    draws one autocorrelation time apart (:func:`draw_spacing`). ``size`` of the candidates
    of all chains are then taken at random without replacement, so the draws come from many
    walkers at many times. Talts et al. (2018, section 5.1) thin the chain to L ≤ ESS draws
    for the same purpose: ranks among autocorrelated draws are not uniform even when the
    posterior is right.

    Returns
    -------
    chains, draws
        Index arrays of length ``min(size, candidates)``.

    Raises
    ------
    ValueError
        No draws at all.
    """
    if n_chains < 1 or n_draws < 1:
        raise ValueError("no draws to choose from")
    spacing = max(1, int(spacing))
    offset = int(rng.integers(0, min(spacing, n_draws)))
    times = np.arange(offset, n_draws, spacing)
    chains, steps = np.meshgrid(np.arange(n_chains), times, indexing="ij")
    chosen = rng.choice(chains.size, size=min(size, chains.size), replace=False)
    return chains.ravel()[chosen], steps.ravel()[chosen]


def histogram_bins(n_ranks: int, n_simulations: int, max_bins: int = MAX_BINS,
                   min_expected: float = MIN_EXPECTED) -> int:
    """B, the rank histogram's bins: the most that divide the ``n_ranks`` = L + 1 rank values
    evenly (each bin then holds the same share of a uniform rank), at most ``max_bins``, with
    at least ``min_expected`` simulations expected per bin (so that χ² holds); at least 1."""
    best = 1
    for bins in range(1, min(max_bins, n_ranks) + 1):
        if n_ranks % bins == 0 and n_simulations / bins >= min_expected:
            best = bins
    return best


def rank_histogram(ranks: ArrayLike, n_ranks: int, bins: int) -> NDArray[np.int64]:
    """Counts of ``ranks`` (each in 0 … n_ranks − 1) in ``bins`` equal bins of rank values."""
    if n_ranks % bins:
        raise ValueError(f"{bins} bins do not divide {n_ranks} rank values evenly")
    ranks = np.asarray(ranks, dtype=np.int64)
    if ranks.size and (ranks.min() < 0 or ranks.max() >= n_ranks):
        raise ValueError(f"ranks must lie in 0 … {n_ranks - 1}")
    return np.bincount(ranks // (n_ranks // bins), minlength=bins).astype(np.int64)


@dataclass(frozen=True)
class ChiSquare(Record):
    """Pearson's χ² test of equal bin probabilities: statistic, degrees of freedom, p-value."""

    statistic: float = math.nan
    dof: int = 0
    p_value: float = math.nan


def chi_square_uniform(counts: ArrayLike) -> ChiSquare:
    """Pearson's χ² test that ``counts`` come from equally likely bins: Σ (O − E)² / E with
    B − 1 degrees of freedom, p = P(χ²_{B−1} ≥ statistic)."""
    counts = np.asarray(counts, float)
    bins, total = counts.size, float(counts.sum())
    if bins < 2 or total <= 0:
        return ChiSquare()
    expected = total / bins
    statistic = float(np.sum((counts - expected) ** 2) / expected)
    return ChiSquare(statistic=statistic, dof=bins - 1,
                     p_value=float(special.chdtrc(bins - 1, statistic)))


def binomial_quantile(q: float, n: int, p: float) -> int:
    """The smallest k with P(Binomial(n, p) ≤ k) ≥ q (the binomial's quantile function)."""
    if not 0.0 <= q <= 1.0:
        raise ValueError("q must lie in [0, 1]")
    if q == 1.0:  # the CDF reaches 1 exactly only at n (in floating point, sooner)
        return int(n)
    k = np.arange(n + 1)
    cdf = special.bdtr(k, n, p)
    # The CDF is computed, not exact: a q it meets to rounding counts as met.
    return int(k[np.argmax(cdf >= q * (1.0 - 64 * np.finfo(float).eps))])


def binomial_band(n: int, p: float, prob: float = BAND_PROBABILITY) -> tuple[int, int]:
    """The central ``prob`` band of Binomial(n, p): counts (low, high) with at most
    (1 − prob)/2 probability below low and above high (the band Talts et al. draw over the
    rank histogram, and the band of a calibrated coverage)."""
    tail = 0.5 * (1.0 - prob)
    return binomial_quantile(tail, n, p), binomial_quantile(1.0 - tail, n, p)


def clopper_pearson(k: int, n: int, prob: float = ERROR_PROBABILITY) -> tuple[float, float]:
    """The Clopper–Pearson ("exact") central ``prob`` interval of a binomial proportion from
    ``k`` successes in ``n`` trials: Beta quantiles, 0 and 1 at the ends."""
    if n < 1:
        return (math.nan, math.nan)
    tail = 0.5 * (1.0 - prob)
    low = 0.0 if k == 0 else float(special.betaincinv(k, n - k + 1, tail))
    high = 1.0 if k == n else float(special.betaincinv(k + 1, n - k, 1.0 - tail))
    return low, high


@dataclass(frozen=True)
class Coverage(Record):
    """How often central ``nominal`` credible intervals held the truth.

    Attributes
    ----------
    nominal
        The intervals' probability (0.5, 0.9).
    covered, n
        Simulations whose interval held the truth, and simulations.
    rate
        ``covered / n``.
    low, high
        The rate's Clopper–Pearson 68.27 % interval (its error bars).
    band_low, band_high
        Where a calibrated rate falls with 99 % probability (binomial quantiles of
        ``nominal`` over ``n`` simulations, as rates).
    inside
        Whether ``rate`` lies in that band.
    """

    nominal: float = math.nan
    covered: int = 0
    n: int = 0
    rate: float = math.nan
    low: float = math.nan
    high: float = math.nan
    band_low: float = math.nan
    band_high: float = math.nan
    inside: bool = False

    @property
    def error(self) -> float:
        """Half the error bars' width (about the rate's standard error)."""
        return 0.5 * (self.high - self.low)

    @property
    def can_fail(self) -> bool:
        """Whether some count of covered simulations lies outside the band: with one or two
        simulations every count from none to all lies inside the 90 % interval's band, and
        "inside the band" says nothing."""
        return self.n > 0 and not (self.band_low <= 0.0 and self.band_high >= 1.0)


def coverage(covered: ArrayLike, nominal: float, band: float = BAND_PROBABILITY) -> Coverage:
    """The :class:`Coverage` of intervals of probability ``nominal`` from one boolean per
    simulation (whether its interval held the truth)."""
    hits = np.asarray(covered, bool)
    n, k = int(hits.size), int(np.count_nonzero(hits))
    if n == 0:
        return Coverage(nominal=nominal)
    low, high = clopper_pearson(k, n)
    band_low, band_high = binomial_band(n, nominal, band)
    return Coverage(nominal=nominal, covered=k, n=n, rate=k / n, low=low, high=high,
                    band_low=band_low / n, band_high=band_high / n,
                    inside=band_low <= k <= band_high)


def central_interval_covers(truth: float, draws: ArrayLike, prob: float,
                            rng: np.random.Generator | None = None) -> bool:
    """Whether the central (equal-tailed) ``prob`` interval of ``draws`` holds ``truth``:
    whether the truth's quantile among the draws lies within ``prob``'s central band.

    Draws equal to the truth (an effect that may be absent, whose posterior holds 0 with a
    probability of its own) count below it in a uniformly random share, drawn from ``rng``
    (half without one), as the rank's ties are split (:func:`rank_statistic`): a posterior
    with P(0) ≥ 25 % puts 0 inside every central 50 % interval, so that counting the tied
    draws whole would cover a true 0 far more often than half the time. Without ties this is
    the interval of the draws' quantiles.
    """
    values = np.asarray(draws, float).ravel()
    below = np.count_nonzero(values < truth)
    ties = np.count_nonzero(values == truth)
    share = 0.5 if rng is None else float(rng.random())
    quantile = (below + share * ties) / values.size
    return bool(0.5 * (1.0 - prob) <= quantile <= 0.5 * (1.0 + prob))


@dataclass(frozen=True)
class QuantityCalibration(Record):
    """The calibration of one quantity over n simulations.

    Attributes
    ----------
    key
        The quantity's key (:mod:`drumroll.quantities`).
    n
        Simulations.
    n_ranks
        L + 1: the rank values 0 … L.
    histogram
        Counts of the ranks in equal bins (:func:`histogram_bins`).
    band
        Each bin's 99 % band (counts) for uniform ranks.
    chi_square
        Pearson's χ² test of the histogram's uniformity.
    coverage_50, coverage_90
        Coverage of the central 50 % and 90 % intervals.
    mean_z, sd_z
        Mean and standard deviation over the simulations of (posterior mean − truth) /
        posterior sd: 0 and about 1 for an unbiased, honest posterior.
    contraction
        Mean over the simulations of 1 − posterior variance / prior variance: how much the
        data teach (0: nothing; 1: everything).
    passed
        Whether the 90 % coverage lies inside its 99 % band and the χ² test's p ≥ 0.01 (the
        acceptance of issue 14; with too few simulations for a χ² test, the coverage alone).
    """

    key: str = ""
    n: int = 0
    n_ranks: int = 0
    histogram: tuple[int, ...] = ()
    band: tuple[int, int] = (0, 0)
    chi_square: ChiSquare = ChiSquare()
    coverage_50: Coverage = Coverage()
    coverage_90: Coverage = Coverage()
    mean_z: float = math.nan
    sd_z: float = math.nan
    contraction: float = math.nan
    passed: bool = False

    nested: ClassVar[dict[str, tuple[type[Record], str]]] = {
        "chi_square": (ChiSquare, "one"), "coverage_50": (Coverage, "one"),
        "coverage_90": (Coverage, "one")}


#: Smallest χ² p-value a calibrated quantity passes with.
CHI_SQUARE_LEVEL = 0.01


def calibrate_quantity(key: str, ranks: ArrayLike, n_ranks: int, covered_50: ArrayLike,
                       covered_90: ArrayLike, z: ArrayLike, contraction: ArrayLike
                       ) -> QuantityCalibration:
    """Every statistic of one quantity from its per-simulation numbers.

    Parameters
    ----------
    key
        The quantity.
    ranks
        The truth's rank in each simulation (0 … ``n_ranks`` − 1).
    n_ranks
        L + 1.
    covered_50, covered_90
        Whether each simulation's central 50 % / 90 % interval held the truth.
    z
        (posterior mean − truth) / posterior sd of each simulation.
    contraction
        1 − posterior variance / prior variance of each simulation.
    """
    ranks = np.asarray(ranks, dtype=np.int64)
    n = int(ranks.size)
    bins = histogram_bins(n_ranks, n)
    counts = rank_histogram(ranks, n_ranks, bins)
    test = chi_square_uniform(counts)
    c50, c90 = coverage(covered_50, 0.5), coverage(covered_90, 0.9)
    z = np.asarray(z, float)
    z = z[np.isfinite(z)]
    shrink = np.asarray(contraction, float)
    shrink = shrink[np.isfinite(shrink)]
    # Too few simulations for two bins leave no rank test: coverage alone decides then.
    passed = bool(c90.inside and not test.p_value < CHI_SQUARE_LEVEL)
    return QuantityCalibration(
        key=key, n=n, n_ranks=int(n_ranks), histogram=tuple(int(c) for c in counts),
        band=binomial_band(n, 1.0 / bins) if n else (0, 0), chi_square=test,
        coverage_50=c50, coverage_90=c90,
        mean_z=float(z.mean()) if z.size else math.nan,
        sd_z=float(z.std(ddof=1)) if z.size > 1 else math.nan,
        contraction=float(shrink.mean()) if shrink.size else math.nan, passed=passed)
