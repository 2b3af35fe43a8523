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
(:func:`shifted`). The numbering fitted first is the source's: m = 0 for an extractor's
onsets, the first onset's bounce number for an onset file that gives one; Z_m of that m is
the main fit's own evidence. Every other numbering (up to ``[likelihood] missed_first``, 2 by
default, or the source's if higher) is screened while the models are sampled: a
Laplace estimate of its evidence at its mode (:func:`screen`, about 0.2 CPU-s), then
importance sampling from a mixture built on it (:func:`importance_sample`, 0.05 s), whose
estimate is used where its own diagnostic trusts it. Where it does not, the numbering is
fitted for its evidence (sampled to a smaller ESS: its draws only have to carry the
importance-sampling evidence), unless the Laplace estimate falls :data:`SCREEN_NATS` below
Z_0: its probability is then given as a bound, below 3e-7. Against fitted evidences of 45
numberings (the five bundled stick rolls other than table2_h80, each whole and with its
first one or two onsets cut off, numbered from impacts 0, 1 and 2), the sampled estimate was
trusted on 37, within 0.04 nat of the fit in the median and 0.37 at worst where the
numbering was within 15 nats of the roll's best (1.1 at worst, 24 nats below it). A warning
is given where the numbering fitted is not clearly preferred.

Where another numbering is clearly preferred (:func:`renumbering`), the estimate fits every
model again numbered from it, so that no number it gives carries the misfit of a wrong
numbering; where none is, the source's numbering is kept and a warning gives each one's
probability. The first onset's own numbering is screened too (:class:`Numberings`), so a
roll that clearly began late is renumbered on the screens alone, before its misnumbered fits
end (table2_h80 with two impacts cut off: 6 s instead of 57).

Where none is clearly preferred, the main model's every quantity is also given mixed over
the numberings, p(θ | onsets) = Σ_m P(m) p(θ | onsets, m) (:func:`numbering_average`): each
numbering's draws from its own fit, or from the importance sample its evidence came from,
resampled by its weights (:class:`ImportanceSample`).

One more numbering is weighed under every model, the power law's included: :data:`STRAY`,
"the first onset is no impact of the roll" (a tap before it that the extractor took for the
first bounce), whose evidence is that of the onsets after it times the first onset's
density as a stray sound, in time and level (:func:`stray_log_density`). Where it is clearly
preferred, the estimate fits every model again to the onsets after the first.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import special

from drumroll.distributions import Fixed, OrZero
from drumroll.inference.coordinates import SamplerCoordinates
from drumroll.inference.evidence import IMPORTANCE_DRAWS, Evidence, weighted_evidence
from drumroll.inference.laplace import LaplaceEstimate, laplace
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.results import STRAY_KEY, NumberingAverage
from drumroll.inference.sampling import SamplerTarget, climb, find_start
from drumroll.onsets.tracking import TrackParams
from drumroll.stats import student_t_log_norm, student_t_logpdf_fixed

#: The numbering "the first onset is no impact of the roll, the second is impact 0": a tap or
#: another sound before the roll that the extractor took for its first bounce. Weighed with
#: the others (0, 1, 2 impacts missed), its evidence that of the onsets after it times the
#: stray onset's density (:func:`stray_log_density`).
STRAY = -1
#: The largest number of impacts that can be considered missed (each costs one fit).
MAX_MISSED = 2
#: The ESS a numbering m ≥ 1 is sampled to: importance sampling needs draws that cover its
#: posterior, not a thousand independent ones.
EVIDENCE_ONLY_ESS = 300
#: P(m = 0) below this: "0" is not clearly preferred, and the user is told.
CLEARLY = 0.95
#: The least probability of a numbering that enters the average over the numberings
#: (:func:`numbering_average`): those below it move a 90 % interval by less than their
#: share of its mass, and each costs a fit where it has none.
MIXED = 0.01
#: A numbering whose screened ln Z falls this far below the main fit's (m = 0) is not fitted:
#: P(m) < e^(−SCREEN_NATS) ≈ 3e-7. Against the fitted evidences of 45 numberings of the five
#: bundled stick rolls (each whole and with one or two onsets cut off), the screen erred by at
#: most 5.4 nats (low: a mode against the edge of what the stick can do) wherever the
#: numbering was within 15 nats of its roll's best, median 0.5, and by 8.6 nats (low) at
#: worst, 19 nats below it.
SCREEN_NATS = 15.0
#: The screen's importance proposal: Student-t degrees of freedom, and its scale over the
#: Laplace fit's (heavier and wider than the posterior, so that the weights stay bounded).
PROPOSAL_NU, PROPOSAL_INFLATE = 5.0, 1.5
#: How many times the proposal is refitted to its own weighted draws before ln Z is taken,
#: and the least share of it a branch keeps.
ADAPTATIONS, MIN_SHARE = 2, 0.01


def shifted(data: OnsetData, missed: int) -> OnsetData:
    """The onsets with the first one numbered as impact ``missed`` (k → k + missed); for
    :data:`STRAY`, the onsets after the first, numbered from the second (impact 0)."""
    if missed == STRAY:
        bounces = np.asarray(data.bounces)[1:]
        return OnsetData(data.times[1:], data.sigmas[1:], bounces - bounces[0])
    return OnsetData(data.times, data.sigmas, np.asarray(data.bounces) + missed)


def stray_log_density(data: OnsetData, amplitude: NDArray | None = None) -> float:
    """ln p(first onset | it is a stray sound) − ln p(its level | it is the first impact),
    given the onsets after it: what "the first onset is no impact" (:data:`STRAY`) adds to the
    ln Z of the onsets after it.

    **Its time.** A sound that is no impact of the roll (a tap or a finger on the head while
    the stick is set up) stands in the onset table as its first onset only where the
    extractor would take it for one: a first flight T₀ that the second flight T₁ can follow,
    T₁ no more than e^(3 jitter) times T₀ and no less than the smallest ratio times it, and T₀
    no longer than the longest flight (:class:`~drumroll.onsets.tracking.TrackParams`; for
    T₁ = 0.25 s a window of 0.78 s). Sounds before a roll have nothing to do with its timing,
    so such a sound is equally likely anywhere in that window: the density is one over its
    length. T₁ is the flight after the second onset, per bounce where a bounce between was
    not heard.

    **Its level** (where the onsets' ``amplitude`` is known: :func:`stray_level_log_ratio`).
    """
    track = TrackParams()
    bounces = np.asarray(data.bounces)
    after = (data.times[2] - data.times[1]) / float(bounces[2] - bounces[1])
    longest = min(after / track.min_ratio, track.max_interval_s)
    window = longest - after * math.exp(-3.0 * track.ratio_jitter)
    if not window > 0.0:
        return -math.inf
    return -math.log(window) + stray_level_log_ratio(amplitude)


def stray_level_log_ratio(amplitude: NDArray | None) -> float:
    """ln p(Δ | a stray sound) − ln p(Δ | the first impact), Δ the first onset's level (dB)
    against the median of the three after it; 0 where a level is unknown (an onset file
    without amplitudes) or fewer than four onsets are given.

    The tracker's level model, which chose the roll's onsets
    (:class:`~drumroll.onsets.tracking.TrackParams`): a bounce's level scatters about the
    roll's trend as a Student t (3 degrees of freedom, 6 dB), here about the next bounces'
    (the first impact, struck fastest, is if anything louder: over the shared corpus's real
    hits it lay at most 14 dB under them); an unrelated sound's level is uniform over 60 dB.
    A tap 27 dB under the roll is 16 times likelier a stray sound than the first impact for
    its level alone; a first onset as loud as the next, 3.6 times likelier the impact.
    """
    if amplitude is None or len(amplitude) < 4:
        return 0.0
    first, after = float(amplitude[0]), float(np.median(amplitude[1:4]))
    if not (math.isfinite(first) and math.isfinite(after) and first > 0.0 and after > 0.0):
        return 0.0
    track = TrackParams()
    delta = 20.0 * math.log10(first / after)
    scale = track.level_scatter_db
    as_impact = float(student_t_logpdf_fixed((delta / scale) ** 2, track.level_dof,
                                             math.log(scale)))
    return -math.log(track.level_range_db) - as_impact


def stray_warning(model: str, probability: float | None, dropped: bool) -> str | None:
    """A warning where the first onset's being a stray sound (:data:`STRAY`) is not clearly
    decided, either way: dropped with P below :data:`CLEARLY`, or kept with P above
    1 − :data:`CLEARLY`."""
    if probability is None or not (1.0 - CLEARLY < probability < CLEARLY):
        return None
    if dropped:
        return (f"{model}: the first onset, dropped as a sound that is no impact of the roll, "
                f"may be its first impact (P = {1.0 - probability:.2g}); check the recording's "
                "start (onsets.png)")
    return (f"{model}: the first onset may be a sound that is no impact of the roll (a tap "
            f"before it): P = {probability:.2g}, while the fits and figures count it as a "
            "bounce (the numbers over the numberings mix both); check the recording's start "
            "(onsets.png)")


def stray_note(time_s: float, probability: float, model: str) -> str:
    """The note of a first onset dropped as a stray sound (:data:`STRAY`)."""
    return (f"the first onset ({time_s:.4f} s) is taken for a sound that is no impact of the "
            f"roll (a tap before it, say): P = {probability:.3g} by {model}'s evidences, "
            "against its being the first bounce; the fit starts from the onset after it")


def missed_probabilities(log_evidences: Sequence[float]) -> tuple[float, ...]:
    """P(m | onsets) for m = 0, 1, … from each numbering's ln Z (a uniform prior over m);
    a numbering whose evidence is not finite gets probability 0."""
    log_z = np.asarray(log_evidences, float)
    finite = np.isfinite(log_z)
    if not finite.any():
        return tuple(math.nan for _ in log_z)
    weights = np.where(finite, np.exp(np.where(finite, log_z, 0.0) - log_z[finite].max()), 0.0)
    return tuple(float(w) for w in weights / weights.sum())


def unheard(missed: int) -> str:
    """The impacts before the first onset, in words: "the first impact", "the first 3
    impacts"."""
    return "the first impact" if missed == 1 else f"the first {missed} impacts"


def missed_note(model: str, probabilities: Sequence[float], screened: Collection[int] = (),
                numbered_from: int = 0, source_numbering: int = 0) -> str:
    """The posterior of m in words, for the report's notes; the numberings in ``screened``
    were not fitted (:func:`needs_fit`), and their probability is the screen's bound;
    ``numbered_from``: the numbering every model was fitted with (:func:`renumbering`), said
    where it is not 0 or not the source's (``source_numbering``: an onset file's first bounce
    number)."""
    shown = ", ".join(f"P({m}) < {math.exp(-SCREEN_NATS):.0e} (screened)" if m in screened
                      else f"P({m}) = {p:.3g}" for m, p in enumerate(probabilities))
    missed = f"{unheard(numbered_from)} not heard" if numbered_from else "none missed"
    fitted = (f"; every model is fitted with the first onset as impact {numbered_from} "
              f"({missed})" if numbered_from or source_numbering else "")
    return (f"{model}: impacts missed before the first onset (the geometry fixes t_B, so a "
            f"recording that begins late would show): {shown}{fitted}")


def needs_fit(screened_log_z: float, main_log_z: float) -> bool:
    """Whether a numbering screened at ``screened_log_z`` (:func:`screen`)
    needs a fit of its own against the first onset's numbering's fitted ``main_log_z``: all
    but those at least :data:`SCREEN_NATS` below it (and any the screen could not estimate)."""
    return not screened_log_z < main_log_z - SCREEN_NATS


def missed_warning(model: str, probabilities: Sequence[float], numbered_from: int = 0
                   ) -> str | None:
    """A warning where the numbering fitted (``numbered_from`` impacts missed) is not clearly
    preferred (its probability below :data:`CLEARLY`)."""
    if not probabilities or not probabilities[numbered_from] < CLEARLY:
        return None
    # The likeliest of the other numberings (the fitted one may itself be the likeliest).
    other = max((m for m in range(len(probabilities)) if m != numbered_from),
                key=lambda m: probabilities[m], default=None)
    if other is None:
        return None
    assumed = {0: "none was", 1: "1 was"}.get(numbered_from, f"{numbered_from} were")
    return (f"{model}: the first onset may not be impact {numbered_from} of the roll: "
            f"P({numbered_from} missed) = {probabilities[numbered_from]:.2g}, P({other} "
            f"missed) = {probabilities[other]:.2g}, while the fits and figures assume "
            f"{assumed} missed (the numbers over the numberings mix them); check the "
            "recording's start (onsets.png), and each numbering's probability in the notes")


def renumbering(probabilities: Sequence[float] | Mapping[int, float], numbered_from: int = 0
                ) -> int | None:
    """The numbering to fit instead of ``numbered_from``: the likeliest, where it is clearly
    preferred (its probability at least :data:`CLEARLY`) or ``numbered_from`` is clearly
    rejected (its probability at most 1 − :data:`CLEARLY`, the rest spread over several
    others); else None.

    A recording that begins late numbers its onsets from the wrong impact, and every number
    of a fit with that numbering (α, t_B, the pivot) is biased by the misfit: the estimate
    fits the models again with the clearly likelier numbering instead of reporting them.
    Where none is clearly preferred (the geometry's priors too wide for the onsets to tell
    whether the roll began late), the source's numbering is kept, and a warning gives each
    one's probability (:func:`missed_warning`). Moving to the likeliest whenever the source's
    was not clearly preferred moved 10 of the audio calibration's 168 rolls that the
    extractor had numbered right to a wrong impact (P of 0.49 to 0.88), and the 4 it had
    numbered wrong to none of the right ones. But a numbering that the evidences reject is not
    the one to report either: a roll cut off after its first impact gave P(0) = 3e-5, P(1) =
    0.93, P(2) = 0.07, and the fit numbered from impact 0 put α 7 sd from the truth.
    """
    found = (dict(probabilities) if isinstance(probabilities, Mapping)
             else dict(enumerate(probabilities)))
    if not found:
        return None
    likeliest = max(found, key=lambda m: -math.inf if math.isnan(found[m]) else found[m])
    if likeliest == numbered_from:
        return None
    rejected = found.get(numbered_from, math.nan) <= 1.0 - CLEARLY
    return likeliest if found[likeliest] >= CLEARLY or rejected else None


def mixed_numberings(probabilities: Sequence[float] | Mapping[int, float]) -> dict[int, float]:
    """The numberings the average over numberings mixes: m → its weight, for each numbering
    weighed (0, 1, 2 impacts missed, :data:`STRAY`) of probability at least :data:`MIXED`,
    renormalised; empty where only one has that much (it is the posterior)."""
    found = (dict(probabilities) if isinstance(probabilities, Mapping)
             else dict(enumerate(probabilities)))
    kept = {m: float(p) for m, p in found.items() if p >= MIXED}
    total = sum(kept.values())
    return {m: p / total for m, p in kept.items()} if len(kept) > 1 else {}


def numbering_key(missed: int) -> str:
    """A numbering's key in ``summary.json``: the impacts missed ("0", "1", "2"), or "stray"
    (:data:`STRAY`: the first onset no impact of the roll)."""
    return STRAY_KEY if missed == STRAY else str(missed)


def numbering_average(posteriors: Mapping[int, Mapping[str, Any]],
                      weights: Mapping[int, float], fitted: int, prob: float = 0.9,
                      seed: int = 0) -> NumberingAverage:
    """The main model's every quantity under the mixture of its numberings' posteriors.

    Given the onsets, the first onset is impact m with probability P(m), and the posterior
    of any quantity θ is p(θ | onsets) = Σ_m P(m) p(θ | onsets, m): where no numbering is
    clearly preferred, one numbering's fit gives p(θ | onsets, m) alone, whose interval holds
    the truth only if m is right (a foreign roll with P(1) = 0.92 kept numbered from impact
    0 put α 7.5 sd from the truth).

    Parameters
    ----------
    posteriors
        Each numbering's draws of the main model by quantity key (numbering → name → array);
        those in ``weights`` are mixed.
    weights
        From :func:`mixed_numberings`.
    fitted
        The numbering the fits and figures use.
    prob, seed
        Mass of the highest-density intervals; seed of the mixture's draws.
    """
    from drumroll.inference.model_average import mixture_summaries

    names = list(posteriors[fitted])
    return NumberingAverage(
        fitted=numbering_key(fitted),
        probabilities={numbering_key(m): w for m, w in weights.items()},
        parameters=mixture_summaries({m: posteriors[m] for m in weights}, weights, names,
                                     prob, seed=seed))


@dataclass
class Numberings:
    """What an estimate knows of the first onset's numberings (m impacts missed → …), across
    its passes: each one's screen and the evidence sampled from it, its ln Z once settled, and
    those given only as the screen's bound."""

    screens: dict[int, Screen] = field(default_factory=dict)
    screen_evidences: dict[int, Evidence | None] = field(default_factory=dict)
    log_z: dict[int, float] = field(default_factory=dict)
    screened_out: set[int] = field(default_factory=set)
    #: For the average over the numberings: the main model's draws (quantity key → array)
    #: of a first pass's main fit, each numbering fitted for its evidence (its log posterior
    #: and the chain's parameter samples), and the importance samples of those screened.
    draws: dict[int, dict[str, NDArray]] = field(default_factory=dict)
    fitted: dict[int, tuple[LogPosterior, NDArray]] = field(default_factory=dict)
    samples: dict[int, ImportanceSample] = field(default_factory=dict)

    def early_renumbering(self, numbered_from: int) -> int | None:
        """From the screens alone (before any fit is back): the numbering to fit instead of
        ``numbered_from``, or None. Each numbering's ln Z is estimated by importance sampling
        from its screen where that passed its diagnostic, else by the screen's Laplace
        estimate. The likeliest must be of the first kind; ``numbered_from`` must be either of
        the first kind and the change called for (:func:`renumbering`: the likeliest clearly
        preferred, or ``numbered_from`` clearly rejected), or
        :data:`SCREEN_NATS`
        below it (it would be screened out: a misnumbered roll's screen is the least
        trustworthy, as its posterior is the roughest). The estimates that passed their
        diagnostic are kept as the numberings' ln Z."""
        trusted = {m: e.log_z for m, e in self.screen_evidences.items()
                   if e is not None and e.trusted}
        estimates = {m: trusted.get(m, found.log_z) for m, found in self.screens.items()}
        likeliest = max(estimates, key=estimates.get)
        if (any(math.isnan(v) for v in estimates.values()) or likeliest == numbered_from
                or likeliest not in trusted):
            return None
        if numbered_from in trusted:
            order = sorted(estimates)
            found = missed_probabilities([estimates[m] for m in order])
            if renumbering(found, order.index(numbered_from)) is None:
                return None
        elif needs_fit(estimates[numbered_from], trusted[likeliest]):
            return None
        self.log_z.update(trusted)
        return likeliest


@dataclass(frozen=True)
class Branch:
    """One branch of a screen: the effects held absent (by name), the names of the columns
    its Laplace fit is over (the sampled ones less those held), and that fit."""

    held: tuple[str, ...]
    names: tuple[str, ...]
    estimate: LaplaceEstimate
    log_z: float


@dataclass(frozen=True)
class Screen:
    """A numbering's screen (:func:`screen`): the Laplace estimate of its ln Z, summed over
    the branches of its effects that may be absent."""

    log_z: float
    branches: tuple[Branch, ...] = ()


def screen(log_posterior: LogPosterior, seed: int) -> Screen:
    """A Laplace estimate of ln Z: the screen of one numbering.

    Each effect that may be absent (an atom at 0: the contact time, the scatter) splits the
    integral in two, "absent" and "present", each estimated by :func:`laplace` at its own
    mode (:func:`~drumroll.inference.sampling.find_start`'s, in sampler coordinates) and
    weighed by its prior probability: Z ≈ Σ over the 2^k combinations. A renumbered roll
    takes up its misfit in a contact time where it can, so neither branch alone will do
    (table2_h80 numbered from impact 1: 6 nats short with the contact held at 0, 0.1 nat
    with both branches).

    Returns
    -------
    Screen
        ``log_z`` is NaN where no branch has an estimate (then the numbering is fitted).
    """
    space = log_posterior.space
    atoms = {name: prior for name, prior in space.priors.items() if isinstance(prior, OrZero)}
    rng = np.random.default_rng(seed)
    branches = []
    for absent in itertools.product((False, True), repeat=len(atoms)):
        held = tuple(name for name, out in zip(atoms, absent, strict=True) if out)
        branch = log_posterior
        if held:
            config = replace(space.config, priors={**space.config.priors,
                                                   **{name: Fixed(0.0) for name in held}})
            branch = type(log_posterior).build(config, space.model, log_posterior.data,
                                               log_posterior.noise, space.priors.get("nu"))
        coordinates = SamplerCoordinates(branch.space, branch.data)
        target = SamplerTarget(branch, coordinates)
        first = branches[0].estimate if branches else None
        if first is not None and first.covariance is not None:
            # An effect held absent moves the mode little: one climb from the first
            # branch's (every effect present), not a search from the prior.
            kept = [space.names.index(name) for name in branch.space.names]
            mode = climb(target, first.mode[kept], np.sqrt(np.diag(first.covariance))[kept])[0]
        else:
            mode = find_start(target, rng)
        estimate = laplace(target, mode, coordinates.bounds())
        # A held atom's prior mass; a present one's is in its slab's density already.
        branches.append(Branch(held, branch.space.names, estimate, estimate.log_z
                               + sum(math.log(atoms[name].p_zero) for name in held)))
    finite = [b.log_z for b in branches if np.isfinite(b.log_z)]
    return Screen(float(special.logsumexp(finite)) if finite else math.nan, tuple(branches))


@dataclass(frozen=True)
class ImportanceSample:
    """A numbering's importance sample from its screen: the draws z ``(n, ndim)`` in the
    sampler's ``coordinates``, their log weights ln p − ln q, and the evidence they give."""

    z: NDArray
    log_w: NDArray
    evidence: Evidence
    coordinates: SamplerCoordinates | None = None

    def resampled(self, n: int, rng: np.random.Generator) -> NDArray:
        """``n`` draws of the posterior as the model's parameters x ``(n, ndim)``: the draws
        resampled in proportion to their weights (the weights' ESS says how many are
        distinct), mapped out of the sampler's coordinates (only these: mapping all of a
        screen's draws cost 30-60 ms on every estimate, averaged or not)."""
        w = np.exp(self.log_w - np.max(self.log_w))
        z = self.z[rng.choice(self.z.shape[0], size=n, p=w / w.sum())]
        return z if self.coordinates is None else self.coordinates.to_parameters(z)[0]


def importance_sample(log_posterior: LogPosterior, found: Screen, seed: int,
                      n: int = IMPORTANCE_DRAWS) -> ImportanceSample | None:
    """A numbering's posterior and ln Z by importance sampling from its screen (None: no
    branch to draw from, or one holding mass that cannot be drawn from).

    The proposal is the screen's mixture in the sampler coordinates: each branch with a
    Laplace fit, weighed by its estimate of Z, as a multivariate Student-t
    (:data:`PROPOSAL_NU` degrees of freedom, :data:`PROPOSAL_INFLATE` times its scale) over
    its columns, and uniform over the plateau that stands for 0 in each column it holds
    absent. A Laplace fit is off where the posterior is skewed (the contact time against its
    prior's end), so the proposal is adapted (population Monte Carlo, Cappé et al. 2004):
    :data:`ADAPTATIONS` times, each branch's location, scale and share are refitted to
    ``n / 2`` weighted draws of the last proposal; then ln Z = ln mean(w) over ``n`` fresh
    draws of the refitted mixture, whose density is exact, so that Z = E_q[p(z) / q(z)].
    None where a branch without a Laplace covariance holds more than :data:`MIN_SHARE` of the
    screen's estimate: the proposal could not reach it.
    """
    space = log_posterior.space
    drawn = [b for b in found.branches
             if np.isfinite(b.log_z) and b.estimate.covariance is not None]
    undrawn = [b.log_z for b in found.branches
               if np.isfinite(b.log_z) and b.estimate.covariance is None]
    if not drawn or (undrawn and special.logsumexp(undrawn)
                     > found.log_z + math.log(MIN_SHARE)):
        # A branch that holds mass but has no Gaussian to draw from (−H not positive definite
        # at a mode against a prior's edge) is missing from the proposal, and no weight can
        # show it: the estimate would be of the other branches alone, "trusted". (A roll of
        # the audio calibration: 83.2 with k = −0.3, its fit 92.0, the undrawn branch 92.9.)
        return None
    rng = np.random.default_rng(seed)
    target = SamplerTarget(log_posterior, SamplerCoordinates(space, log_posterior.data))
    columns = {name: i for i, name in enumerate(space.names)}
    widths = {name: space.priors[name].width for name in space.names
              if isinstance(space.priors[name], OrZero)}
    frees = [[columns[name] for name in b.names] for b in drawn]
    means = [b.estimate.mode for b in drawn]
    covariances = [PROPOSAL_INFLATE**2 * b.estimate.covariance for b in drawn]
    shares = special.softmax([b.log_z for b in drawn])
    for _ in range(ADAPTATIONS):
        z, which, log_w = _weighted_draws(target, drawn, frees, means, covariances, shares,
                                          columns, widths, n // 2, rng)
        w = np.exp(log_w - np.max(log_w)) if np.isfinite(log_w).any() else np.zeros(n // 2)
        totals = np.array([w[which == index].sum() for index in range(len(drawn))])
        if not totals.sum() > 0.0:
            break
        for index, free in enumerate(frees):
            mine = w * (which == index)
            if (totals[index] ** 2 / max(np.sum(mine**2), 1e-300)) < 2 * len(free) + 2:
                continue  # too few weighted draws to refit this branch's shape
            means[index] = mine @ z[:, free] / totals[index]
            centred = z[:, free] - means[index]
            covariances[index] = (PROPOSAL_INFLATE**2
                                  * (centred * mine[:, None]).T @ centred / totals[index])
        # Each branch's share of the posterior mass, never below a hundredth of it: a branch
        # the first draws missed stays in the proposal.
        shares = np.maximum(totals / totals.sum(), MIN_SHARE)
        shares = shares / shares.sum()
    z, _, log_w = _weighted_draws(target, drawn, frees, means, covariances, shares, columns,
                                  widths, n, rng)
    return ImportanceSample(z, log_w, weighted_evidence(log_w), target.coordinates)


def _weighted_draws(target: SamplerTarget, branches: list[Branch], frees: list[list[int]],
                    means: list[NDArray], covariances: list[NDArray], shares: NDArray,
                    columns: dict[str, int], widths: dict[str, float], n: int,
                    rng: np.random.Generator) -> tuple[NDArray, NDArray, NDArray]:
    """``n`` draws of the proposal mixture (:func:`_mixture_draws`), the component each came
    from, and their log importance weights ln p(z) − ln q(z) (−inf where p is 0)."""
    z, which, log_q = _mixture_draws(branches, frees, means, covariances, shares, columns,
                                     widths, n, rng)
    density = target(z)
    return z, which, np.where(np.isfinite(density), density - log_q, -np.inf)


def _mixture_draws(branches: list[Branch], frees: list[list[int]], means: list[NDArray],
                   covariances: list[NDArray], shares: NDArray, columns: dict[str, int],
                   widths: dict[str, float], n: int, rng: np.random.Generator
                   ) -> tuple[NDArray, NDArray, NDArray]:
    """``n`` draws of the screen's proposal mixture (see :func:`importance_sample`): the
    draws, the component each came from, and the mixture's log density at each."""
    nu = PROPOSAL_NU
    chols = [np.linalg.cholesky(c) for c in covariances]
    z = np.empty((n, len(columns)))
    which = rng.choice(len(branches), size=n, p=shares)
    for index, (branch, free, chol) in enumerate(zip(branches, frees, chols, strict=True)):
        rows = np.flatnonzero(which == index)
        t = rng.standard_normal((rows.size, len(free))) * np.sqrt(
            nu / rng.chisquare(nu, rows.size))[:, None]
        z[np.ix_(rows, free)] = means[index] + t @ chol.T
        for name in branch.held:
            z[rows, columns[name]] = -widths[name] * rng.random(rows.size)
    log_q = np.full((len(branches), n), -np.inf)
    for index, (branch, free, chol) in enumerate(zip(branches, frees, chols, strict=True)):
        d = len(free)
        white = np.linalg.solve(chol, (z[:, free] - means[index]).T).T
        log_t = (student_t_log_norm(nu, d) - float(np.log(np.diag(chol)).sum())
                 - 0.5 * (nu + d) * np.log1p(np.einsum("ij,ij->i", white, white) / nu))
        on_plateau = np.ones(n, bool)
        for name in branch.held:
            value = z[:, columns[name]]
            on_plateau &= (value >= -widths[name]) & (value < 0.0)
            log_t = log_t - math.log(widths[name])
        with np.errstate(divide="ignore"):
            log_q[index] = np.where(on_plateau, math.log(shares[index]) + log_t, -np.inf)
    return z, which, special.logsumexp(log_q, axis=0)
