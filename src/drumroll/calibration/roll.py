"""One simulation of simulation-based calibration: a parameter point drawn from the priors and
the onsets of the roll it makes, through the model's forward model and the config's noise.

Everything is read from the model's :class:`~drumroll.inference.space.ParameterSpace` (the
same one the fit samples), so a parameter added to a model, its priors or its noise (a
restitution law's exponent, say) is drawn and simulated here without a change:

* θ is drawn from every sampled parameter's prior through its
  :class:`~drumroll.distributions.Distribution` (:meth:`ParameterSpace.sample_prior`);
  the Student-t noise's ν too when it has a prior;
* the impact times τ_0 … τ_K come from the model's own kernel
  (:meth:`ParameterSpace.impacts`), the contact time added; a point the physics forbids (a
  pivot past the centre of mass, the cone's rim striking before its tip, a rebound over the
  top) is drawn again. The posterior gives such points zero probability, so the prior the
  fit uses is the prior truncated to them, and redrawing samples exactly that;
* a restitution that scatters from bounce to bounce is simulated impact by impact, not
  linearised as the likelihood integrates it: impact k's restitution is the law's for the
  speed it comes in with, times e^{ε_k}, ε_k ~ N(0, s²), so the rebound-speed ratios r_k
  (:mod:`drumroll.physics.restitution`) carry every earlier scatter, and the motion's kernel
  turns them into flights exactly. A draw whose scattered restitution would exceed 1 (a
  bounce that gains energy, which no model computes) is made again, and counted;
* the onsets are t_k = T0 + τ_k + e_k, the timing noise e_k Gaussian or Student-t with the
  jitter as its scale, as ``[likelihood] noise`` says; every bounce 0 … K is heard (no gaps),
  and the onsets carry no extractor uncertainty (``sigma_s`` = 0): the noise model is the
  whole of the timing error.

A roll whose onsets come out of time order (a jitter larger than the last flights) cannot be
an onset list (bounce numbers increase with time), so it is drawn again, θ with it. That is a
selection on the data alone, which leaves simulation-based calibration valid: the posterior
given data that pass a check on the data is the posterior given the data (Talts et al. 2018's
uniformity holds conditionally on every data set), but the parameter points calibrated are
then those of the rolls that pass, which :attr:`SimulatedRoll.rejected` counts.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from drumroll.config import Config
from drumroll.distributions import Distribution
from drumroll.errors import DrumrollError
from drumroll.inference.settings import estimate_settings
from drumroll.inference.space import CONTACT, SCATTER, ParameterSpace

#: Where the first impact T0 is put (s from the start of the recording). The likelihood is
#: invariant under a shift of every onset, and T0's prior is flat around the first onset, so
#: where it lies changes nothing; it is drawn so that no fit can lean on a fixed value.
T0_RANGE = (0.5, 1.5)
#: Draws made for one simulation before giving up (the priors then make almost no roll).
MAX_ATTEMPTS = 1000

#: Reasons a draw is made again, as :attr:`SimulatedRoll.rejected` and the report name them.
PHYSICS = "the physics forbids the parameter point"
RESTITUTION_ABOVE_ONE = "a scattered restitution above 1"
OUT_OF_ORDER = "onsets out of time order"


@dataclass(frozen=True)
class SimulatedRoll:
    """A parameter point and the onsets of its roll.

    Attributes
    ----------
    values
        Every parameter of the space (sampled and fixed) by internal name, SI.
    t0
        The first impact's time T0 (s).
    model_times
        The impact times without timing noise, T0 + τ_k (restitution scatter and contact time
        included), k = 0 … K.
    times
        The onsets: ``model_times`` plus the timing noise.
    speeds
        The tip speed arriving at each impact (m/s): what a recording of the roll sounds like.
    attempts
        Parameter points drawn to make this roll (1 when the first one did).
    rejected
        Draws made again, by reason (:data:`PHYSICS`, :data:`RESTITUTION_ABOVE_ONE`,
        :data:`OUT_OF_ORDER`).
    """

    values: dict[str, float]
    t0: float
    model_times: NDArray
    times: NDArray
    speeds: NDArray
    attempts: int = 1
    rejected: dict[str, int] = field(default_factory=dict)


class RollSimulator:
    """Draws parameter points from a config's priors and simulates the onsets of their rolls.

    Parameters
    ----------
    config
        Priors, stick, ``[likelihood]`` noise.
    model
        The forward model (the config's main model).
    n_onsets
        Onsets per roll: bounces 0 … ``n_onsets`` − 1, all heard.
    """

    def __init__(self, config: Config, model: str, n_onsets: int) -> None:
        if n_onsets < 2:
            raise ValueError("a roll needs at least two onsets")
        settings = estimate_settings(config)
        self.noise = settings.noise
        # ν is the Student-t noise's: a parameter of its own when it has a prior.
        extra: dict[str, Distribution] = {"nu": settings.nu} if self.noise == "student-t" else {}
        self.space = ParameterSpace.build(config, model, extra)
        self.n_flights = n_onsets - 1
        scatter = self.space.priors.get(SCATTER)
        self.scatters = scatter is not None and not (scatter.is_fixed and scatter.value == 0.0)
        self.gravity = config.gravity

    def draw(self, rng: np.random.Generator) -> SimulatedRoll:
        """One parameter point from the priors and its roll (see the module docstring).

        Raises
        ------
        DrumrollError
            :data:`MAX_ATTEMPTS` draws made no roll.
        """
        rejected: Counter[str] = Counter()
        space = self.space
        for attempt in range(1, MAX_ATTEMPTS + 1):
            x = space.sample_prior(rng, 1)
            impacts, valid = space.impacts(x, self.n_flights)
            if not bool(valid[0]):
                rejected[PHYSICS] += 1
                continue
            values = {name: float(np.ravel(value)[0]) for name, value in space.values(x).items()}
            ratios = None
            if self.scatters:
                epsilon = values[SCATTER] * rng.standard_normal(self.n_flights)
                scattered = self._scattered_impacts(values, epsilon)
                if scattered is None:
                    rejected[RESTITUTION_ABOVE_ONE] += 1
                    continue
                tau, ratios = scattered
            else:
                tau = impacts[0]
            jitter = values["jitter"]
            if self.noise == "student-t":
                noise = jitter * rng.standard_t(values["nu"], tau.size)
            else:
                noise = jitter * rng.standard_normal(tau.size)
            t0 = float(rng.uniform(*T0_RANGE))
            times = t0 + tau + noise
            if np.any(np.diff(times) <= 0.0):
                rejected[OUT_OF_ORDER] += 1
                continue
            return SimulatedRoll(values=values, t0=t0, model_times=t0 + tau, times=times,
                                 speeds=self._speeds(x, ratios), attempts=attempt,
                                 rejected=dict(rejected))
        commonest = rejected.most_common(1)[0][0] if rejected else "none"
        raise DrumrollError(f"no roll in {MAX_ATTEMPTS} draws from the priors of the "
                            f"{space.model} model (the commonest reason: {commonest}); check "
                            "the priors' ranges")

    def _scattered_impacts(self, values: dict[str, float], epsilon: NDArray
                           ) -> tuple[NDArray, NDArray] | None:
        """τ_0 … τ_K with the restitution of impact j scattered by e^{ε_j} (module docstring),
        contact time included, and the speed ratios r_1 … r_K; None where a restitution would
        exceed 1 or the motion's kernel finds the point invalid.

        Impact by impact: the restitution law's α for the speed the impact comes in with
        (r_{k−1} times the first contact speed), times e^{ε_k}, gives r_k; the motion's kernel
        turns the ratios into flights (:meth:`~drumroll.physics.model.ForwardModel.
        flights_at`). With the constant law this is α^k e^{ε_1 + … + ε_k}."""
        space, n = self.space, self.n_flights
        law = space.forward.law
        alpha = np.array([values["alpha"]])
        ratios = np.empty((1, n))
        ratio = np.ones(1)
        for k in range(n):
            restitution = law.restitution(alpha, values, ratio) * math.exp(epsilon[k])
            if not (0.0 < float(restitution[0]) <= 1.0):
                return None
            ratio = ratio * restitution
            ratios[0, k] = ratio[0]
        shape = space.config.stick.shape if space.forward.needs_stick else None
        kernel = {**values, "alpha": alpha}
        flights, valid = space.forward.flights_at(ratios, kernel, shape, self.gravity)
        if not np.all(valid):
            return None
        impacts = np.concatenate(([0.0], np.cumsum(flights[0])))[None, :]
        if CONTACT in values:
            impacts = space.with_contact(impacts, values[CONTACT], ratios)
        return impacts[0], ratios[0]

    def _speeds(self, x: NDArray, ratios: NDArray | None) -> NDArray:
        """Tip speed at each impact (m/s): the first contact speed times the speed ratios, the
        forward model's or, with a scattering restitution, the scattered ones (energy is kept
        in flight, so an impact comes in as fast as the rebound before it left). A model
        without a tip (the power law) gets a ball's first speed, g t_B / 2: the speed only
        sets how loud a recorded impact is."""
        bounces = self.space.bounces(x, self.n_flights)
        first = float(np.ravel(bounces.tip_speed_c)[0])
        if not math.isfinite(first):
            first = 0.5 * self.gravity * float(np.ravel(bounces.t_b)[0])
        if ratios is None:
            ratios = np.ravel(bounces.speed_ratios)
        return np.maximum(first * np.concatenate(([1.0], ratios)), math.ulp(1.0))
