"""The statistics of simulation-based calibration against independent references: scipy.stats
for the binomial, Beta and χ² tails, plain counting for ranks and histograms, and a conjugate
model whose exact posterior must pass (and whose too-narrow posterior must fail)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from drumroll.inference.calibration import (
    binomial_band,
    binomial_quantile,
    calibrate_quantity,
    central_interval_covers,
    chi_square_uniform,
    clopper_pearson,
    coverage,
    draw_spacing,
    histogram_bins,
    independent_draws,
    rank_histogram,
    rank_statistic,
)


def test_rank_counts_the_draws_below_the_truth():
    rng = np.random.default_rng(1)
    for _ in range(50):
        draws = rng.normal(size=99)
        truth = float(rng.normal())
        expected = stats.percentileofscore(draws, truth, kind="strict") * draws.size / 100
        assert rank_statistic(truth, draws, rng) == round(expected)


def test_ties_are_split_at_random_over_their_ranks():
    rng = np.random.default_rng(2)
    draws = np.array([0.0, 1.0, 1.0, 1.0, 2.0])
    ranks = [rank_statistic(1.0, draws, rng) for _ in range(4000)]
    assert set(ranks) == {1, 2, 3, 4}
    counts = np.bincount(ranks)[1:]
    assert stats.chisquare(counts).pvalue > 1e-3


def test_spacing_is_the_longest_autocorrelation_time_in_stored_draws():
    assert draw_spacing([16.3, 17.6, 14.7], thin=20) == 1
    assert draw_spacing([16.3, 47.0], thin=20) == 3
    assert draw_spacing([np.nan, 5.0], thin=1) == 5
    assert draw_spacing([np.nan], thin=3) == 1


def test_independent_draws_are_distinct_and_spaced_along_each_chain():
    rng = np.random.default_rng(3)
    chains, draws = independent_draws(128, 22, 4, 99, rng)
    assert chains.size == draws.size == 99
    pairs = set(zip(chains.tolist(), draws.tolist(), strict=True))
    assert len(pairs) == 99
    for c in set(chains.tolist()):
        steps = np.sort(draws[chains == c])
        assert np.all(np.diff(steps) % 4 == 0) and np.all(np.diff(steps) >= 4)
    few_chains, _ = independent_draws(2, 10, 5, 99, rng)  # only 4 candidates
    assert few_chains.size == 4


def test_bins_divide_the_rank_values_and_keep_chi_square_valid():
    assert histogram_bins(100, 200) == 20
    assert histogram_bins(100, 30) == 5
    assert histogram_bins(100, 8) == 1
    for n_ranks, n in ((100, 200), (100, 37), (64, 1000)):
        bins = histogram_bins(n_ranks, n)
        assert n_ranks % bins == 0 and n / bins >= 5


def test_rank_histogram_is_numpy_s():
    rng = np.random.default_rng(4)
    ranks = rng.integers(0, 100, 500)
    counts = rank_histogram(ranks, 100, 20)
    reference, _ = np.histogram(ranks, bins=np.arange(0, 101, 5))
    assert counts.tolist() == reference.tolist()
    with pytest.raises(ValueError):
        rank_histogram(ranks, 100, 7)


def test_chi_square_is_scipy_s():
    rng = np.random.default_rng(5)
    for bins in (2, 5, 20):
        counts = rng.multinomial(200, np.full(bins, 1 / bins))
        ours = chi_square_uniform(counts)
        theirs = stats.chisquare(counts)
        assert ours.statistic == pytest.approx(theirs.statistic, rel=1e-12)
        assert ours.p_value == pytest.approx(theirs.pvalue, rel=1e-9)
        assert ours.dof == bins - 1


@pytest.mark.parametrize("n", [1, 7, 30, 200, 1000])
@pytest.mark.parametrize("p", [0.05, 0.5, 0.9])
def test_binomial_quantiles_and_band_are_scipy_s(n, p):
    for q in (0.005, 0.1, 0.5, 0.9, 0.995, 1.0):  # (scipy puts q = 0 at −1)
        assert binomial_quantile(q, n, p) == int(stats.binom.ppf(q, n, p)), q
    low, high = stats.binom.interval(0.99, n, p)
    assert binomial_band(n, p, 0.99) == (int(low), int(high))


@pytest.mark.parametrize("n", [1, 10, 200])
def test_clopper_pearson_is_scipy_s_exact_interval(n):
    for k in sorted({0, 1, n // 2, n - 1, n}):
        for prob in (0.6827, 0.95):
            ours = clopper_pearson(k, n, prob)
            theirs = stats.binomtest(k, n).proportion_ci(confidence_level=prob, method="exact")
            assert ours == pytest.approx((theirs.low, theirs.high), abs=1e-12)


def test_coverage_band_and_error_bars():
    hits = np.r_[np.ones(180, bool), np.zeros(20, bool)]
    c = coverage(hits, 0.9)
    assert (c.covered, c.n, c.rate) == (180, 200, 0.9)
    assert c.inside and c.low < 0.9 < c.high
    assert (c.band_low, c.band_high) == (168 / 200, 190 / 200)  # scipy: binom.interval
    low = coverage(np.r_[np.ones(160, bool), np.zeros(40, bool)], 0.9)
    assert not low.inside
    assert math.isclose(c.error, 0.5 * (c.high - c.low))


@pytest.mark.parametrize(("n", "can_fail"), [(1, False), (2, False), (3, True), (200, True)])
def test_a_coverage_that_cannot_fail_says_so(n, can_fail):
    """With one or two simulations every count lies in the 90 % interval's 99 % band
    (P(none covered) = 0.1^n is not below 0.005 until n = 3): "inside the band" tests
    nothing, and calibrate's headline says "Not tested" instead of "calibrated"."""
    assert coverage(np.ones(n, bool), 0.9).can_fail is can_fail
    assert coverage(np.zeros(n, bool), 0.9).inside is not can_fail
    assert not coverage(np.ones(0, bool), 0.9).can_fail


def test_central_interval_coverage_uses_equal_tails():
    draws = np.arange(1000.0)
    assert central_interval_covers(500.0, draws, 0.5)
    assert not central_interval_covers(100.0, draws, 0.5)
    assert central_interval_covers(100.0, draws, 0.9)
    assert not central_interval_covers(20.0, draws, 0.9)


def test_coverage_of_an_atom_at_zero_is_nominal():
    """A quantity that is 0 with probability p₀ a priori (an effect that may be absent):
    θ = 0 or ~ U(0, 1) at even odds, y ~ N(θ, 0.3²); the exact posterior drawn, ties at the
    truth split at random: a central interval covers in its nominal share of simulations
    (counting the tied draws whole covered a true 0 in nearly every one)."""
    rng = np.random.default_rng(12)
    n, size, sd = 4000, 400, 0.3
    grid = np.linspace(0.0, 1.0, 2001)
    covered = {0.5: [], 0.9: []}
    whole = []
    for _ in range(n):
        theta = 0.0 if rng.random() < 0.5 else rng.random()
        y = theta + sd * rng.normal()
        slab = np.exp(-0.5 * ((y - grid) / sd) ** 2)
        slab_mass = np.trapezoid(slab, grid)
        p_zero = np.exp(-0.5 * (y / sd) ** 2) / (np.exp(-0.5 * (y / sd) ** 2) + slab_mass)
        cdf = np.cumsum(slab) / slab.sum()
        draws = np.where(rng.random(size) < p_zero, 0.0,
                         np.interp(rng.random(size), cdf, grid))
        for prob in covered:
            covered[prob].append(central_interval_covers(theta, draws, prob, rng))
        low, high = np.quantile(draws, [0.25, 0.75])
        whole.append(low <= theta <= high)
    for prob, hits in covered.items():
        assert abs(np.mean(hits) - prob) < 3 * math.sqrt(prob * (1 - prob) / n), prob
    assert np.mean(whole) > 0.6  # the quantiles' own interval, ties counted whole


def _conjugate(width: float, n: int = 1000, draws: int = 99, seed: int = 6):
    """θ ~ N(0, 1), y ~ N(θ, 1): the posterior is N(y/2, 1/2); ``width`` scales its sd (1:
    exact). Per simulation: rank among L draws, coverage, z, contraction."""
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=n)
    y = theta + rng.normal(size=n)
    mean, sd = y / 2, width * math.sqrt(0.5)
    posterior = mean[:, None] + sd * rng.normal(size=(n, draws))
    ranks = [rank_statistic(t, d, rng) for t, d in zip(theta, posterior, strict=True)]
    big = mean[:, None] + sd * rng.normal(size=(n, 2000))
    covered = {p: [central_interval_covers(t, d, p) for t, d in zip(theta, big, strict=True)]
               for p in (0.5, 0.9)}
    return calibrate_quantity("alpha", ranks, draws + 1, covered[0.5], covered[0.9],
                              (mean - theta) / sd, np.full(n, 1 - sd**2))


def test_an_exact_posterior_passes_and_a_too_narrow_one_fails():
    exact = _conjugate(1.0)
    assert exact.passed
    assert exact.coverage_90.inside and exact.coverage_50.inside
    assert abs(exact.mean_z) < 0.1 and abs(exact.sd_z - 1) < 0.1
    assert exact.contraction == pytest.approx(0.5)
    narrow = _conjugate(0.5)
    assert not narrow.passed
    assert narrow.chi_square.p_value < 1e-6
    hist = np.array(narrow.histogram)
    assert hist[0] + hist[-1] > 4 * hist[len(hist) // 2]  # the ∪ of overconfidence
