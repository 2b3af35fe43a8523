"""Timing each bounce with the whole roll's help: the sequence as a prior on every onset.

A faint bounce late in a roll lands in the ringing and snare-wire buzz of the louder bounces
before it. Its sound is detected, but its first milliseconds can be weaker than what they
land in: the change point of :mod:`.refine` then finds where the bounce's sound *grows*
(its own wires and modes building up, a few ms in), not where it starts, and on the
waveform alone the start cannot be told from the later step.

The roll itself says where the bounce must be. The flight times of a bouncer follow a smooth
law, close to geometric with a slowly changing ratio, so a robust fit of

    t_j = t_0 + sum_{i < j} exp(a + b i + c i^2)

to all the onsets (Cauchy loss: mistimed onsets hardly pull on it) predicts each onset,
with a scatter measured on the roll itself: the robust spread of the onsets about the fit.
That prediction is the prior of a second change-point search (:class:`~.refine.Prior`),
and each onset is placed at its posterior. Where the sound has a clear start the likelihood
is sharp and the prior does not matter; where it has none the prior decides; where the roll
is irregular the measured scatter is large and the prior is weak. The prior is robust (a
Gaussian mixed with a uniform), so a clear onset off the fitted law stays where it is.

An onset is moved further from its own change point than :data:`~.start.LOUD_STAGE_S` (in a
lossy file, a codec block more: its noise may precede the sound by that much) only onto a
sound at least as loud as the one it leaves. The stage exists for a faint bounce found at the
loud stage of its sound, and that stage comes no later than :data:`~.start.LOUD_STAGE_S`
after its start; further off, the search, which a roll's scatter of milliseconds widens,
holds other sounds (a tap before the roll, sounds in the ring before a bounce), and a
split there is either on one of them, fainter than the impact, or on the impact itself from
a fainter sound before it (the real ping-pong's first onset, on a sound 4 ms and 57 dB ahead
of the ball's first click, moves onto the click). A move onto a fainter sound is looked for
again within that reach, and where the best split there is at its end (the evidence points
further off) the onset stays as it was. In the 40 rolls of the audio calibration whose
bouncer keeps its law only to milliseconds, 11.6 % of the onsets had ended more than 3 ms
from their impact and 14.8 % more than 1 ms, most moved there by this stage (a first impact
39 ms back, onto a tap); now 5.9 % and 9.5 %. Every onset of the bundled recordings, the
shared corpus and the real ping-pong is where it was.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drumroll.onsets.excerpt import Excerpt
from drumroll.onsets.numerics import cauchy_least_squares
from drumroll.onsets.refine import Prior
from drumroll.onsets.roll import Roll
from drumroll.onsets.start import LOUD_STAGE_S

#: MAD to Gaussian standard deviation.
_MAD_TO_SIGMA = 1.4826

#: Fewest onsets a law is fitted to: three parameters and five to spare, since with fewer
#: the fit all but interpolates them, a mistimed onset cannot be told from a bent law, and
#: the scatter (hence the prior's width) is not measured at all.
_MIN_ONSETS = 8


@dataclass(frozen=True)
class SequenceFit:
    """The smooth law fitted to a roll's onsets.

    Attributes
    ----------
    time_s
        The law's time for every onset (seconds).
    sd_s
        Scale of an onset about the law: the roll's measured scatter and the fit's own
        uncertainty at that onset (seconds).
    dof
        Degrees of freedom the scatter was measured with (onsets less parameters): the
        prediction is a Student t with that many, heavy-tailed for a short roll.
    """

    time_s: np.ndarray
    sd_s: np.ndarray
    dof: int


def _law(p: np.ndarray, bounce: np.ndarray, quadratic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Onset times of the law with parameters ``p`` (t0, a, b[, c]) at the bounce numbers
    ``bounce`` (counted from the first onset's), and their Jacobian."""
    k = bounce - bounce[0]
    i = np.arange(int(k[-1]), dtype=float)
    c = p[3] if quadratic else 0.0
    # (The optimiser may try absurd parameters on its way: no flight is e^20 s long.)
    f = np.exp(np.minimum(p[1] + p[2] * i + c * i * i, 20.0))

    def at_bounces(v: np.ndarray) -> np.ndarray:
        return np.concatenate(([0.0], np.cumsum(v)))[k]

    t = p[0] + at_bounces(f)
    cols = [np.ones(k.size), t - p[0], at_bounces(i * f)]
    if quadratic:
        cols.append(at_bounces(i * i * f))
    return t, np.stack(cols, axis=1)


def _robust_fit(times: np.ndarray, bounce: np.ndarray, weight: np.ndarray, p0: list[float],
                quadratic: bool) -> tuple[np.ndarray, float]:
    """Cauchy-loss fit of the law; returns the parameters and the loss (half the Cauchy
    deviance of the residuals scaled by ``1 / weight``)."""

    def resid(p):
        return (_law(p, bounce, quadratic)[0] - times) / weight

    def jac(p):
        return _law(p, bounce, quadratic)[1] / weight[:, None]

    return cauchy_least_squares(resid, jac, np.asarray(p0, dtype=float))


def fit_sequence(times: np.ndarray, sigmas: np.ndarray, bounce: np.ndarray | None = None,
                 timeable: np.ndarray | None = None) -> SequenceFit | None:
    """Robust fit of the flight law to onset ``times`` with timing uncertainties ``sigmas``
    at bounce numbers ``bounce`` (default 0, 1, 2, …: no bounce unheard).

    Each onset's residual is scaled by its own uncertainty combined with the roll's scatter
    (measured as the MAD of the residuals, corrected for the parameters fitted); the loss is
    Cauchy's, so a mistimed onset hardly pulls. The drift of the ratio (``c``) is kept only
    when it pays for itself by the Bayesian information criterion on the Cauchy deviance.
    The scatter is never put below the typical ``sigmas`` of the onsets flagged
    ``timeable`` (default: all), those whose start can be told: an onset quieter than what
    it lands in has a wide ``sigma_s`` because its own timing is unsure, which says nothing
    of how closely the bouncer keeps to its law, so the more of them a roll reports the
    wider every onset's prior would be (a faint bounce's prior let a far step 3 ms early
    win). Returns None for fewer than :data:`_MIN_ONSETS` onsets or flights that do not
    shrink.
    """
    n = times.size
    bounce = np.arange(n) if bounce is None else np.asarray(bounce, dtype=np.int64)
    flights = np.diff(times)
    if n < _MIN_ONSETS or np.any(flights <= 0) or np.any(np.diff(bounce) <= 0):
        return None
    # Per single flight: a step over m unheard bounces is m + 1 flights.
    steps = np.diff(bounce)
    single = flights / steps
    ratio = float(np.median((single[1:] / single[:-1]) ** (1.0 / steps[1:])))
    if not 0.0 < ratio < 1.5:
        return None
    sig2 = np.square(np.maximum(sigmas, 1e-6))
    scatter = 0.0
    p = np.array([times[0], np.log(single[0]), np.log(ratio)])
    quadratic = False
    for _ in range(2):  # the scatter weights the fit, the fit sets the scatter
        weight = np.sqrt(sig2 + scatter**2)
        p, cost = _robust_fit(times, bounce, weight, list(p[:3]), False)
        quadratic = False
        if n >= 8:
            p2, cost2 = _robust_fit(times, bounce, weight, [*p[:3], 0.0], True)
            if 2.0 * (cost - cost2) > np.log(n):
                p, quadratic = p2, True
        law, jmat = _law(p, bounce, quadratic)
        r = times - law
        dof = max(n - p.size, 1)
        scatter = _MAD_TO_SIGMA * float(np.median(np.abs(r))) * np.sqrt(n / dof)
    told = np.ones(n, dtype=bool) if timeable is None else np.asarray(timeable, dtype=bool)
    scatter = max(scatter, float(np.sqrt(np.median(sig2[told] if told.any() else sig2))))
    # The fit's own uncertainty at each onset, from the linearised weighted least squares.
    jw = jmat / np.sqrt(sig2 + scatter**2)[:, None]
    try:
        cov = np.linalg.inv(jw.T @ jw)
    except np.linalg.LinAlgError:
        return None
    var_fit = np.einsum("ij,jk,ik->i", jmat, cov, jmat)
    return SequenceFit(law, np.sqrt(scatter**2 + np.maximum(var_fit, 0.0)), dof)


def retime_by_law(roll: Roll, ex: Excerpt, *, outlier: float = 0.05,
                  min_snr_db: float = 0.0) -> Roll:
    """Place every onset at its posterior given the roll's law (see the module docstring).

    Parameters
    ----------
    roll
        The roll's onsets (seconds, absolute), bounce numbers and timing uncertainties.
    ex
        The audio around the roll.
    outlier
        Prior probability that a bounce is off the law by more than its scatter.
    min_snr_db
        Local SNR from which an onset's start can be told (``timeable`` of
        :func:`fit_sequence`).

    Returns
    -------
    Roll
        The roll timed again (unchanged when no law could be fitted).
    """
    times = roll.time_s
    law = fit_sequence(times, roll.sigma_s, roll.bounce, roll.snr_db >= min_snr_db)
    if law is None:
        return roll
    sr = ex.sr
    margin = round(0.001 * sr)
    # How far from its own change point an onset may be moved (module docstring); in a
    # lossy file the change point may also be the start of the codec's noise ahead of it.
    bound = round(LOUD_STAGE_S * sr) + ex.codec_block
    out = []
    # An onset is searched for between the middles of the flights either side of it: the
    # bounces keep their order whatever the law says.
    mids = np.concatenate(([-np.inf], 0.5 * (times[1:] + times[:-1]), [np.inf]))
    for j, (t, mu, sd) in enumerate(zip(times, law.time_s, law.sd_s, strict=True)):
        reach = max(4.0 * sd * sr, margin)
        lo = round(max(min(t, mu) * sr - reach, mids[j] * sr + 1))
        hi = round(min(max(t, mu) * sr + reach, mids[j + 1] * sr - 1))
        # The whitening reference: up to 6 ms before the searched stretch, never reaching
        # back past the middle of the flight before it.
        flight = times[j] - times[j - 1] if j else 0.05
        fit = max(64, min(round(0.006 * sr), round(0.5 * flight * sr) - (hi - lo) // 2))
        guess = (lo + hi) // 2
        prior = Prior(mean=mu * sr, sd=sd * sr, outlier=outlier, width=hi - lo,
                      dof=law.dof)
        here = round(t * sr)
        search = dict(pre=guess - lo + fit, post=2 * margin, search=guess - lo,
                      search_after=hi - guess, prior=prior)
        r = ex.refine(guess, **search)
        if abs(r.sample - here) > bound and not r.amplitude >= roll.amplitude[j]:
            # Further from the onset's own change point than a faint bounce's loud stage lags
            # its start, onto a fainter sound: another one (module docstring). Only within
            # reach, then; and where the best split there is at its end, the evidence points
            # further off, where the onset may not go, and it stays as it was.
            r = ex.refine(guess, **search, within=(here - bound, here + bound))
            if abs(r.sample - here) >= bound - 1:
                out.append((t, roll.amplitude[j], roll.snr_db[j], roll.sigma_s[j]))
                continue
        out.append((r.sample / sr, r.amplitude, r.snr_db, r.sigma_s))
    return roll.with_times(*(np.asarray(col, dtype=float) for col in zip(*out, strict=True)))
