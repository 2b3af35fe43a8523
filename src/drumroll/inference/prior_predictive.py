"""Monte Carlo propagation of the priors through the forward models: the "computed t_B".

This is how the paper's "computed" column is made: the measured geometry and its ± (e.g.
d = 131 ± 2 mm, h = 80 ± 3 mm, l1 = 348 ± 1 mm) go through the model; the spread of the
outputs is the computed value's uncertainty.
"""

from __future__ import annotations

import os
from collections import Counter
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from drumroll.config import Config, load_config
from drumroll.errors import DrumrollError
from drumroll.physics import MODELS, REASONS, Bounces, bounce_sequence
from drumroll.physics.models import forward_model, parameter_keys
from drumroll.physics.release import tip_contact_only
from drumroll.quantities import DERIVED


@dataclass(frozen=True)
class Prediction:
    """Distribution-predictive draws of one model.

    Attributes
    ----------
    model
        The forward model's name.
    bounces
        The valid draws only.
    n_draws
        Draws attempted (valid or not).
    invalid_reasons
        How many draws failed, by reason text.
    """

    model: str
    bounces: Bounces
    n_draws: int
    invalid_reasons: dict[str, int]

    @property
    def valid_fraction(self) -> float:
        """Fraction of the draws that make a drumroll."""
        return self.bounces.alpha.shape[0] / self.n_draws

    def quantity(self, key: str) -> NDArray:
        """The valid draws of a derived quantity, by its key in the user's unit (see
        :data:`drumroll.quantities.DERIVED`)."""
        return DERIVED[key].to_user(getattr(self.bounces, DERIVED[key].bounces))

    def summary(self) -> dict[str, object]:
        """Mean and sd of every derived quantity (by its key, in its unit) and flight (the
        ``predict --json`` contract)."""
        out: dict[str, object] = {}
        for name in DERIVED:
            values = self.quantity(name)
            if np.all(np.isnan(values)):
                continue  # the power law has no geometry
            out[name] = {"mean": float(np.mean(values)), "sd": float(np.std(values, ddof=1))}
        flights = self.bounces.flights
        out["flights_s"] = {"mean": np.mean(flights, axis=0).tolist(),
                            "sd": np.std(flights, axis=0, ddof=1).tolist()}
        out["valid_fraction"] = self.valid_fraction
        return out

    def __repr__(self) -> str:
        t_b = self.quantity("t_b") if "t_b" in DERIVED else np.zeros(0)
        spread = (f"; t_B = {np.mean(t_b):.4g} ± {np.std(t_b, ddof=1):.2g} s"
                  if t_b.size > 1 and np.all(np.isfinite(t_b)) else "")
        return (f"<Prediction of {self.model}: {self.bounces.alpha.shape[0]} of {self.n_draws} "
                f"draws make a drumroll{spread}>")

    # The rich displays of a notebook are the reporting layer's (imported only when shown).
    def _repr_html_(self) -> str:
        from drumroll.reporting.display import predictions_display, to_html

        return to_html(predictions_display({self.model: self}))

    def _repr_markdown_(self) -> str:
        from drumroll.reporting.display import predictions_display, to_markdown

        return to_markdown(predictions_display({self.model: self}, figure=False))


class Predictions(dict[str, Prediction]):
    """What :func:`predict` returns: model name → :class:`Prediction`, a plain dict that a
    notebook displays as a table of every model's predicted quantities and a figure of
    their flights."""

    def __repr__(self) -> str:
        draws = ", ".join(str(n) for n in sorted({p.n_draws for p in self.values()}))
        return f"<Predictions of {', '.join(self) or 'no model'} ({draws or 'no'} draws)>"

    def _repr_html_(self) -> str:
        from drumroll.reporting.display import predictions_display, to_html

        return to_html(predictions_display(self))

    def _repr_markdown_(self) -> str:
        from drumroll.reporting.display import predictions_display, to_markdown

        return to_markdown(predictions_display(self, figure=False))


#: Most values (draws × (flights + 1)) in one array of a propagation: each array is then at
#: most 400 MB, and a dozen of them fit in memory; beyond, the Monte Carlo error is long
#: below anything a measured prior can mean.
MAX_VALUES = 50_000_000

def predictable_models(config: Config) -> tuple[str, ...]:
    """The models ``predict`` can propagate: those with a stick when the config gives one,
    the others (the power law) when the config gives a prior for each of their parameters."""
    def predictable(name: str) -> bool:
        if not all(p in config.priors for p in MODELS[name].law.parameters):
            return False  # a restitution law the config does not ask for
        if MODELS[name].needs_stick:
            return config.stick is not None
        return all(config.has_prior(key) for key in parameter_keys(name))

    return tuple(name for name in MODELS if predictable(name))


def propagate(config: Config, model: str, n_flights: int = 5, n_draws: int = 20_000,
              seed: int | None = 0) -> Prediction:
    """Draw ``n_draws`` set-ups from the priors and run them through ``model`` in one batch.

    Parameters
    ----------
    config
        Priors (and stick) to propagate.
    model
        Forward model name.
    n_flights
        Flights per sequence.
    n_draws
        Monte Carlo draws (the sd's relative precision is about 1/sqrt(2 n_draws)).
    seed
        Seed of the random generator (None: fresh entropy).

    Raises
    ------
    DrumrollError
        When no draw makes a drumroll; the message gives the commonest reason.
    """
    if n_draws < 2:
        raise DrumrollError("the number of draws must be at least 2")
    if n_draws * (n_flights + 1) > MAX_VALUES:
        raise DrumrollError(
            f"{n_draws} draws of {n_flights} flights are {n_draws * (n_flights + 1):.2g} values "
            f"per array, more than {MAX_VALUES:.0e} (a few GB of memory): ask for fewer draws "
            "or flights (the sd's precision is 1/sqrt(2 × draws): 20,000 give 0.5 %)")
    rng = np.random.default_rng(seed)
    draws = {name: prior.sample(rng, n_draws) for name, prior in sorted(config.priors.items())}
    forward = forward_model(model)
    given = {name: draws[name] for name in forward.parameters}
    if forward.needs_stick:
        if config.stick is None:
            raise DrumrollError(f"the {model} model needs a [stick] section in the config")
        given.update(stick=config.stick.sample(rng, n_draws), g=config.gravity)
    bounces = bounce_sequence(model, n_flights=n_flights, **given)
    if forward.needs_stick:  # the models assume the tip strikes: say where it would not
        bounces = tip_contact_only(bounces, given["stick"], draws["pivot"], draws["height"])
    valid = bounces.valid
    reasons = Counter(REASONS[code] for code in bounces.reason[~valid])
    if not valid.any():
        reason, _ = reasons.most_common(1)[0]
        raise DrumrollError(f"{model}: no draw from the priors makes a drumroll: {reason}")
    kept = Bounces(**{f.name: getattr(bounces, f.name)[valid] for f in fields(Bounces)})
    return Prediction(model=model, bounces=kept, n_draws=n_draws, invalid_reasons=dict(reasons))


def predict(config: Config | str | os.PathLike[str], n_flights: int = 5,
            n_draws: int = 20_000, seed: int | None = 0) -> Predictions:
    """``drumroll predict`` as a function: every model the config can predict
    (:func:`predictable_models`), propagated from the priors (:func:`propagate`).

    Parameters
    ----------
    config
        A config, or the path of its file.
    n_flights, n_draws, seed
        As for :func:`propagate`.

    Returns
    -------
    Predictions
        Model name → its :class:`Prediction` (a dict).

    Raises
    ------
    DrumrollError
        Nothing to predict (no stick, no power-law prior), or no draw makes a drumroll.
    """
    if not isinstance(config, Config):
        config = load_config(config)
    models = predictable_models(config)
    if not models:
        where = f"{config.path}: " if config.path else ""
        raise DrumrollError(f"{where}nothing to predict: give a [stick] section (for the "
                            "pendulum models) or a prior for t_b (for the power law)")
    return Predictions({m: propagate(config, m, n_flights=n_flights, n_draws=n_draws, seed=seed)
                        for m in models})
