"""Timing each bounce against the roll's own sound: the loudest impact's envelope as a template.

The change point of :mod:`.refine` finds where a sound steps out of what it lands in. For a
loud impact that is where it starts. A faint one may begin weaker than the ring, buzz and noise
around it and only stand out where its sound grows (a snare's wires slap a head period in):
its change point is then late by that growth, with a small ``sigma_s``, because the step
there is sharp. Nothing in the first milliseconds of the waveform says so.

The roll itself does. Every impact of one bouncer on one surface makes much the same sound,
louder or fainter, and the loudest impact shows the whole of it far above the noise. Its power
envelope above :data:`~.excerpt.BAND_HZ` (the attack's band: the modes that ring for hundreds of
milliseconds lie below it) is the template ``E``. Around every other onset the power envelope
is fitted as

    P(t) = b0 + b1 t + sum_j a_j E(t - t_j) + a E(t - s),

a background (constant and slope), the earlier bounces' sounds at their onsets ``t_j``, and
this bounce's at a trial onset ``s``: weighted least squares with weights ``1 / P^2`` (a power
averaged over a bin scatters in proportion to its mean), the dispersion measured from the best
fit's residuals. The profile likelihood over ``s`` says where the impact's *whole* sound fits.

An onset is moved only when the envelope strongly prefers "elsewhere" to "here": the Bayes
factor of the two, each with a uniform prior over its trial onsets, is at least e^STRONG
(:data:`STRONG` = 3: odds of about 20, "strong" on Kass & Raftery's scale). "Here" is every
trial within a bin (the envelope's resolution: it has nothing to say about finer timing) and
two ``sigma_s`` of the onset. Averaging the likelihood over "elsewhere", rather than taking
its best trial, charges for having looked at many places: a chance bump in the noise a few
milliseconds off does not win. The onset is then placed by the change point within a bin of
the envelope's best trial, and its ``sigma_s`` includes the spread of the envelope's
likelihood. Where a sound starts at its loudest (a click, a ball on a table) or stands well
out of what it lands in, the envelope agrees with the change point and nothing moves.

The same fit finds a bounce that the waveform searches miss (:func:`next_by_envelope`). A
roll of three onsets has one flight ratio and nothing to test it with, so it is no roll;
its fourth bounce, if the three are a roll, lies where the flight law puts it, and its whole
sound (tens of milliseconds of it) can stand out where its first milliseconds do not. The
Bayes factor of "a bounce there, its onset drawn from the law's prediction and its amplitude
up to the last bounce's" against "no bounce" (the likelihood ratio with the amplitude's
Occam factor, averaged over the prediction) must again be at least e^STRONG.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drumroll.onsets.excerpt import BIN_S, Excerpt
from drumroll.onsets.numerics import logsumexp
from drumroll.onsets.roll import Roll
from drumroll.onsets.start import BACK_S

#: Log Bayes factor ("elsewhere" against "here") at which the envelope overrides the change
#: point.
STRONG = 3.0

#: Earlier bounces whose sound is modelled under a bounce (older ones are background).
_EARLIER = 3

#: Longest stretch of the loudest impact taken as the template (seconds).
_TEMPLATE_S = 0.2

#: Fitted stretch around an onset (seconds): background before the earliest trial onset
#: (and before the template's impact), and sound after the template's peak at the latest
#: trial.
_BEFORE_S, _AFTER_S = 0.02, 0.005

#: Trial onsets reach this far past the template's peak before the onset, and after it.
_MARGIN_S = 0.001


def template(power: np.ndarray, onset_bin: int, length: int, before: int
             ) -> np.ndarray | None:
    """The envelope of the impact starting in ``onset_bin``: its power over ``length`` bins
    less the median power of the ``before`` bins before it, scaled to a peak of 1 (None if
    empty).

    One impact's power scatters from bin to bin as the fitted ones' does; a centred
    three-bin mean (0.75 ms, finer than any structure of the sound it needs) keeps the fit
    from matching that scatter to theirs.
    """
    shape = _excess(power, onset_bin, length, before)
    if shape.size < 4:
        return None
    shape = np.convolve(shape, np.ones(3) / 3.0, mode="same")
    return shape / shape.max() if shape.max() > 0 else None


def _excess(power: np.ndarray, onset_bin: int, length: int, before: int) -> np.ndarray:
    """Power over ``length`` bins from ``onset_bin``, less the median power of the ``before``
    bins before it (what the impact added), clipped at zero."""
    pre = power[max(onset_bin - before, 0): onset_bin]
    floor = float(np.median(pre)) if pre.size else 0.0
    return np.clip(power[onset_bin: onset_bin + length] - floor, 0.0, None)


def _placed(shape: np.ndarray, n: int, first: np.ndarray) -> np.ndarray:
    """Columns (``n`` bins each) holding ``shape`` starting at bins ``first`` (any integer,
    also negative or past the end: only the overlap is kept)."""
    rows = np.arange(n)[:, None] - np.asarray(first)[None, :]
    inside = (rows >= 0) & (rows < shape.size)
    return np.where(inside, shape[np.clip(rows, 0, shape.size - 1)], 0.0)


def profile(power: np.ndarray, shape: np.ndarray, earlier: np.ndarray, trials: np.ndarray,
            against_none: float | None = None) -> np.ndarray:
    """Log likelihood (up to a constant) of each trial onset bin for the sound in ``power``.

    Parameters
    ----------
    power
        The power envelope over the fitted stretch.
    shape
        The template.
    earlier
        Onset bins (relative to ``power``) of the earlier bounces whose sound is modelled.
    trials
        Trial onset bins of this bounce.
    against_none
        If given, the largest amplitude (template units) the bounce may have: the result is
        then each trial's log Bayes factor against "no bounce" instead.

    Returns
    -------
    numpy.ndarray
        ``-chi2 / 2`` at each trial less its best value, scaled by the dispersion of the
        best fit's residuals (a trial whose best amplitude would be negative gets the
        background-only fit); or the log Bayes factors.
    """
    n = power.size
    base = np.column_stack([np.ones(n), np.linspace(-1.0, 1.0, n),
                            _placed(shape, n, earlier)])
    # Weights 1 / P^2 from the locally smoothed power (the data, not the trial's model, so
    # every trial is weighted alike and the fits are linear).
    smooth = np.convolve(power, np.ones(5) / 5.0, mode="same")
    root = 1.0 / np.maximum(smooth, 1e-3 * max(float(power.mean()), 1e-300))
    bw = base * root[:, None]
    yw = power * root
    cw = _placed(shape, n, trials) * root[:, None]
    gram_inv = np.linalg.pinv(bw.T @ bw)
    by = bw.T @ yw
    beta = gram_inv @ by
    sse0 = max(float(yw @ yw - by @ beta), 0.0)
    g = bw.T @ cw
    # The trial column's part not explained by the background (Schur complement).
    s = np.einsum("ij,ij->j", cw, cw) - np.einsum("ij,ik,kj->j", g, gram_inv, g)
    proj = cw.T @ yw - g.T @ beta
    gain = np.where((s > 1e-12 * np.maximum(np.einsum("ij,ij->j", cw, cw), 1e-300))
                    & (proj > 0), proj**2 / np.maximum(s, 1e-300), 0.0)
    sse = np.maximum(sse0 - gain, 0.0)
    best = float(sse.min())
    dof = max(n - base.shape[1] - 1, 1)
    dispersion = dof / best if best > 0 else 1.0
    if against_none is not None:
        # Laplace approximation of the Bayes factor "a bounce at s" against "none", the
        # amplitude uniform between 0 and ``against_none`` (a bounce is not louder than
        # the one before it): the likelihood ratio times the Occam factor
        # sqrt(2 pi) sd(a) / a_max.
        sd_a = 1.0 / np.sqrt(dispersion * np.maximum(s, 1e-300))
        occam = np.log(np.sqrt(2 * np.pi) * sd_a / max(against_none, 1e-300))
        return np.where(gain > 0, 0.5 * dispersion * gain + np.minimum(occam, 0.0), 0.0)
    return -0.5 * dispersion * (sse - best)


@dataclass
class _Roll:
    """The roll's power envelope (bins of ``width`` samples), its onsets' sample positions
    ``pos`` in the excerpt, and the template from its loudest impact (whose onset lies
    ``offset`` samples into its bin; the template peaks ``peak_bins`` after it); the fitted
    windows' lengths in bins."""

    power: np.ndarray
    width: int
    pos: np.ndarray
    loudest: int
    offset: float
    shape: np.ndarray
    peak_bins: int
    before: int
    after_peak: int
    margin: int

    @classmethod
    def of(cls, times: np.ndarray, amplitude: np.ndarray, ex: Excerpt) -> _Roll | None:
        power, width = ex.band_power()
        sr = ex.sr
        pos = times * sr - ex.start  # sample positions in x
        loudest = int(np.argmax(amplitude))
        first_bin = int(pos[loudest] // width)
        before, after_peak, margin = (round(v / (width / sr)) for v in (_BEFORE_S, _AFTER_S,
                                                                        _MARGIN_S))
        end = pos[loudest + 1] - 0.001 * sr if loudest + 1 < times.size else math.inf
        length = int(min(end - pos[loudest], _TEMPLATE_S * sr) // width)
        shape = template(power, first_bin, length, before)
        if shape is None:
            return None
        return cls(power, width, pos, loudest, pos[loudest] - first_bin * width, shape,
                   int(np.argmax(shape)), before, after_peak, margin)


def retime_by_envelope(onsets: Roll, ex: Excerpt) -> Roll:
    """Move the onsets that the roll's envelope strongly places elsewhere (module docstring).

    Parameters
    ----------
    onsets
        The roll.
    ex
        The audio around it.

    Returns
    -------
    Roll
        The roll with the moved onsets refined again.
    """
    times, amplitude, snr_db, sigma = (np.array(c, dtype=float) for c in (
        onsets.time_s, onsets.amplitude, onsets.snr_db, onsets.sigma_s))
    if times.size < 2:
        return onsets
    sr = ex.sr
    roll = _Roll.of(times, amplitude, ex)
    if roll is None:
        return onsets
    power, width, pos, offset = roll.power, roll.width, roll.pos, roll.offset
    peak_bins, margin = roll.peak_bins, roll.margin
    for k in range(1, times.size):
        if k == roll.loudest:
            continue
        flight_bins = (pos[k] - pos[k - 1]) / width
        # A faint bounce shows up at the latest where its sound peaks, and an impact's
        # loudest stage comes within BACK_S of its start (a later peak of the template is
        # the room's); never look back past the middle of its flight.
        back = min(peak_bins + margin, int(0.5 * flight_bins), round(BACK_S / BIN_S))
        here = (pos[k] - offset) / width  # this onset on the template's bin grid
        lo = int(max(math.floor(here) - back - roll.before, (pos[k - 1] - offset) / width + margin,
                     0))
        # The next bounce's sound is not modelled: stop before it.
        nxt = pos[k + 1] if k + 1 < times.size else math.inf
        hi = int(min(math.floor(here) + peak_bins + roll.after_peak, (nxt - offset) / width - 2,
                     power.size))
        trials = np.arange(max(math.floor(here) - back, lo + 1), math.floor(here) + margin + 1)
        if trials.size < 2 or hi - lo < 8:
            continue
        prev = (pos[max(k - _EARLIER, 0): k] - offset) // width - lo
        ll = profile(power[lo:hi], roll.shape, prev.astype(int), trials - lo)
        # "Here": within a bin (the envelope's resolution) and two sigma of the onset.
        near = np.abs(trials - here) <= 1.0 + 2.0 * sigma[k] * sr / width
        if near.all() or not near.any():
            continue
        # The log of (mean likelihood elsewhere) / (mean likelihood here), without
        # underflow where one of them is far below the best trial.
        log_bf = (logsumexp(ll[~near]) - math.log(np.count_nonzero(~near))
                  - logsumexp(ll[near]) + math.log(np.count_nonzero(near)))
        if log_bf < STRONG:
            continue
        lik = np.exp(ll - ll.max())
        times[k], amplitude[k], snr_db[k], sigma[k] = _place(roll, trials, lik, ex,
                                                              flight_bins * width)
        pos[k] = times[k] * sr - ex.start
    return onsets.with_times(times, amplitude, snr_db, sigma)


def next_by_envelope(onsets: Roll, ex: Excerpt, dt: float, sd: float) -> Roll | None:
    """The next bounce after the roll ``onsets``, looked for by its whole sound where the
    flight law puts it (``dt`` after the last onset, Gaussian with sd ``sd``, seconds).

    The Bayes factor of "a bounce whose sound is the template, at an onset drawn from the
    prediction, with an amplitude up to the last bounce's" against "no bounce" must be
    at least e^STRONG. Returns the roll with the bounce appended, or None.
    """
    times, amplitude = onsets.time_s, onsets.amplitude
    sr = ex.sr
    roll = _Roll.of(times, amplitude, ex)
    if roll is None:
        return None
    power, width, pos, offset = roll.power, roll.width, roll.pos, roll.offset
    last = (pos[-1] - offset) / width
    mean, spread = dt * sr / width, sd * sr / width
    t_lo = max(math.floor(last + mean - 3 * spread), math.ceil(last + 0.5 * mean))
    # Flights do not grow.
    t_hi = math.floor(min(last + mean + 3 * spread, last + (pos[-1] - pos[-2]) / width))
    lo = int(max(t_lo - roll.before, last + roll.margin, 0))
    hi = int(min(t_hi + roll.peak_bins + roll.after_peak, power.size))
    trials = np.arange(max(t_lo, lo + 1), min(t_hi, hi - 4) + 1)
    if trials.size < 2:
        return None
    prev = ((pos[-_EARLIER:] - offset) // width - lo).astype(int)
    # The last bounce's amplitude in template units: the most this one can have.
    added = _excess(power, int((pos[-1] - offset) // width), roll.peak_bins + roll.after_peak,
                    roll.before)
    a_max = float(added.mean()) / max(float(roll.shape[: added.size].mean()), 1e-12) \
        if added.size else 0.0
    if not a_max > 0:
        return None
    log_bf = profile(power[lo:hi], roll.shape, prev, trials - lo, against_none=a_max)
    prior = -0.5 * ((trials - last - mean) / max(spread, 1.0)) ** 2
    post = log_bf + prior - logsumexp(prior)
    if logsumexp(post) < STRONG:
        return None
    found = _place(roll, trials, np.exp(post - post.max()), ex, mean * width)
    if not found[0] > onsets.time_s[-1]:
        return None  # placed back into the flight it should end: not a later bounce
    return onsets.with_onset(found[0], int(onsets.bounce[-1]) + 1, *found[1:])


def _place(roll: _Roll, trials: np.ndarray, weight: np.ndarray, ex: Excerpt, flight: float
           ) -> tuple[float, float, float, float]:
    """Time (s), amplitude, SNR and sigma of an onset placed by the change point within a
    bin of the best of the envelope's ``trials`` (``weight``: their likelihood or
    posterior); sigma includes the spread of that weight. ``flight`` (samples) before the
    onset bounds the whitening reference, as in :func:`~.sequence.retime`."""
    width, sr = roll.width, ex.sr
    best = int(trials[np.argmax(weight)])
    fit = max(64, min(round(0.006 * sr), round(0.4 * flight)))
    r = ex.refine(round(ex.start + best * width + roll.offset), pre=width + fit,
                  post=round(0.002 * sr), search=width, search_after=width)
    spread = float(np.sqrt(np.sum(weight * (trials - best) ** 2) / weight.sum())) * width
    sigma = math.hypot(r.sigma_s, max(spread, width / math.sqrt(12.0)) / sr)
    return r.sample / sr, r.amplitude, r.snr_db, sigma
