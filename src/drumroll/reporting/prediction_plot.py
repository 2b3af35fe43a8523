"""The flights ``drumroll predict`` propagates from the priors, as a figure: each model's
predicted flight times T_k against bounce number on a log axis, median and 90 % band."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from drumroll.reporting.plot_style import (
    BAND,
    model_color,
    model_linestyle,
    model_name,
    new_figure,
    ordered_models,
    style,
)


def draw_predicted_flights(predictions: Mapping[str, Any]):
    """Build the figure (a :class:`matplotlib.figure.Figure`) of ``predictions`` (model →
    :class:`~drumroll.inference.prior_predictive.Prediction`)."""
    with style():
        fig = new_figure((6.5, 3.4), layout="constrained")
        ax = fig.subplots()
        for i, model in enumerate(ordered_models(list(predictions))):
            flights = np.asarray(predictions[model].bounces.flights, dtype=float)
            k = np.arange(1, flights.shape[1] + 1)
            low, mid, high = np.nanquantile(flights, [(1 - BAND) / 2, 0.5, (1 + BAND) / 2],
                                            axis=0)
            color = model_color(model, i)
            ax.fill_between(k, low, high, color=color, alpha=0.18, lw=0)
            ax.plot(k, mid, marker="o", ms=3.5, color=color, ls=model_linestyle(model),
                    label=model_name(model))
        ax.set_yscale("log")
        ax.set_xlabel("bounce number k")
        ax.set_ylabel("flight time $T_k$ (s)")
        ax.set_title(f"Flights predicted from the priors: median and {BAND:.0%} band")
        ax.legend()
    return fig
