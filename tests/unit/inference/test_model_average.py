"""Stacking weights and the model-averaged α (drumroll.inference.model_average), against a
brute-force search of the simplex and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from drumroll.inference.model_average import mixture_summaries, model_average, stacking_weights


def _objective(elpd: np.ndarray, w: np.ndarray) -> float:
    return float(np.log(w @ np.exp(elpd)).sum())


@pytest.mark.parametrize("n_models", [2, 3])
def test_stacking_weights_maximise_the_mixtures_loo_score(n_models):
    rng = np.random.default_rng(n_models)
    elpd = rng.normal(0.0, 1.0, (n_models, 40)) + rng.normal(0, 0.5, (n_models, 1))
    got = stacking_weights({f"m{i}": elpd[i] for i in range(n_models)})
    w = np.array(list(got.values()))
    assert w.sum() == pytest.approx(1.0) and (w >= 0).all()
    grid = np.linspace(0, 1, 201)
    if n_models == 2:
        candidates = np.stack([grid, 1 - grid], axis=1)
    else:
        a, b = np.meshgrid(grid, grid)
        keep = a + b <= 1
        candidates = np.stack([a[keep], b[keep], 1 - a[keep] - b[keep]], axis=1)
    best = max(_objective(elpd, c) for c in candidates)
    assert _objective(elpd, w) >= best - 1e-6


def test_a_model_that_predicts_every_onset_worse_gets_no_weight():
    better = np.full(30, -1.0)
    got = stacking_weights({"good": better, "bad": better - 2.0})
    assert got["good"] == pytest.approx(1.0, abs=1e-6)


def _posterior(alpha: np.ndarray) -> xr.Dataset:
    return xr.Dataset({"alpha": (("chain", "draw"), alpha.reshape(4, -1)),
                       "t_b": (("chain", "draw"), np.full((4, alpha.size // 4), 0.25))})


def test_the_average_is_the_weighted_mixture_of_the_models_draws():
    rng = np.random.default_rng(0)
    a, b = rng.normal(0.9000, 1e-4, 40_000), rng.normal(0.9010, 1e-4, 40_000)
    posteriors = {"a": _posterior(a), "b": _posterior(b)}
    alone = model_average(posteriors, {"a": 1.0, "b": 0.0}).parameters["alpha"]
    assert alone.mean == pytest.approx(0.9, abs=3e-6) and alone.sd == pytest.approx(1e-4, rel=0.03)
    assert alone.hdi_low == pytest.approx(0.9 - 1.645e-4, abs=1e-5)
    mixed = model_average(posteriors, {"a": 0.75, "b": 0.25}).parameters["alpha"]
    # Mixture: mean 0.90025, variance σ² + w(1 − w) Δ².
    assert mixed.mean == pytest.approx(0.90025, abs=5e-6)
    assert mixed.sd == pytest.approx(np.sqrt(1e-8 + 0.75 * 0.25 * 1e-6), rel=0.03)
    assert mixed.r_hat is None and mixed.hdi_low < 0.9 and mixed.hdi_high > 0.9009


def test_a_mixture_of_components_that_lack_a_quantity_leaves_it_out():
    rng = np.random.default_rng(1)
    posteriors = {0: {"alpha": rng.normal(0.9, 1e-3, 4000), "t_b": np.full(4000, 0.25)},
                  1: {"alpha": rng.normal(0.8, 1e-3, 4000)}}
    got = mixture_summaries(posteriors, {0: 0.5, 1: 0.5}, ["alpha", "t_b"])
    assert set(got) == {"alpha"}
    # Two well separated halves: the mean halfway, the sd half the separation, and the
    # shortest interval of 90 % reaching into both.
    assert got["alpha"].mean == pytest.approx(0.85, abs=1e-3)
    assert got["alpha"].sd == pytest.approx(0.05, rel=0.02)
    assert got["alpha"].hdi_low < 0.81 and got["alpha"].hdi_high > 0.89
