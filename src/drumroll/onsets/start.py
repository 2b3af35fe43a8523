"""Where an impact's sound starts: the same point of every impact's sound, loud or faint.

The change point of :mod:`.refine` finds where a sound steps out of what it lands in. So
where in its sound an onset is found depends on what it lands in: an impact's sound builds
up over a millisecond or more (a stick's click, then the head's and the snare wires'
response, the loudest stage a few ms in), and only the part above the background is seen.
Two cases make that a level-dependent error, which biases the first flight and α:

* **The first impact lands in silence**, the others in the ring of the bounces before. Its
  change point is at its very first sound; theirs where their sound exceeds the ring, a
  fraction of a millisecond later (0.6 ms for a snare whose first 0.5 ms are 30 dB under
  its peak). :func:`first_in_ring` times the first impact as if it had landed in the ring
  the next bounces land in: their recorded background, scaled to the first impact's level,
  is added to it and the change point found again. The shift this causes is the lag the
  others have; for a sound that starts at its loudest (a click, a ball) it is nil.
* **A faint bounce whose first stages are weaker than what it lands in** is found at its
  loud stage, up to 5 ms late (a snare's wires slap about one head period after contact),
  with a small ``sigma_s`` because that later step is sharp. :func:`start_of_sound` looks
  for an earlier start where the roll says the bounce should be: only an onset later than
  the prediction of the bounces before it (:func:`law_prior`, by more than :data:`LATE`
  predictive sd) is searched. In the stretch before it (up to :data:`BACK_S`, and 40 % of
  the flight) the power envelope above :data:`~.excerpt.BAND_HZ` is tested, bin by bin, for
  a first stage: a rise of the log power over :data:`_STAGE_S` against the background just
  before the stretch (its median and its MAD, which includes the ring's own bursts, the
  likelihood tempered by the bins' autocorrelation). Each place's Bayes factor against
  "background until the onset" (the stage's level uniform over 60 dB: the Occam factor of
  a Laplace approximation), weighed by the prior, must beat staying by e^:data:`STRONG`.
  The onset is then placed to the sample by the change point within a bin of the rise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drumroll.onsets.excerpt import Excerpt
from drumroll.onsets.numerics import log_ndtr, logsumexp
from drumroll.onsets.prediction import flight_predictor
from drumroll.onsets.refine import STRONG, Refined
from drumroll.onsets.roll import Roll
from drumroll.stats import student_t_logpdf_fixed

#: Longest stretch before a change point searched for earlier stages of the same sound: an
#: impact's loudest stage comes within a few ms of its start.
BACK_S = 0.008

#: How late a faint bounce's change point can be: at its loud stage, up to 5 ms after its
#: start (a snare's wires slap about one head period after contact; module docstring).
LOUD_STAGE_S = 0.005

#: An onset this many predictive sd later than the roll puts it is searched for an earlier
#: start.
LATE = 2.0

#: Background stretch the level before a rise is measured on (seconds).
_REFERENCE_S = 0.004

#: Stretch after an onset whose loudest bin is the sound's own level (seconds).
_OWN_S = 0.003

#: Shortest first stage of an impact's sound (seconds): a start is a rise that lasts this
#: long (a one-bin spike is noise; a stick's click and the head's first response last about
#: a millisecond before the next stage).
_STAGE_S = 0.001

#: Range over which the level of a first stage is a priori uniform (dB).
_LEVEL_RANGE_DB = 60.0

#: Bounces after the first whose recorded background the first impact is timed in.
_RINGING = 4

#: Stretch of an impact's sound, from its onset, and of the background before it, whose
#: power envelopes the first impact is aligned on (seconds).
_ALIGN_S, _BEFORE_ALIGN_S = 0.010, 0.002

#: Floor on the scatter (natural log) of one flight about its recent trend. One step of
#: the trend of six flights predicts the corpus's and the real ping-pong's next impact
#: with 84 % of the errors within one predictive sd and 97 % within two at 0.5 %.
_PRIOR_JITTER = 0.005

#: Recent flights the prediction is fitted to, and the fewest that make one (a line and two
#: degrees of freedom for its scatter).
_HISTORY, _MIN_FLIGHTS = 6, 4

#: Prior probability that the first impact has no lag under the next bounces' ring
#: (:func:`ring_lag`): as likely as not.
_NO_LAG = 0.5

#: Degrees of freedom of an alignment's error (:func:`ring_lag`), as of the other priors
#: on onset times here (:class:`StartPrior`).
_ALIGN_DOF = 4.0

#: Factor, either way, within which the sds of the alignments are known (:func:`ring_lag`).
_SD_FACTOR = 3.0

#: Least margin (:func:`margin_db`) of a bounce whose recorded background the first impact
#: is timed in: a tenfold power, where the envelope shows the sound's shape above its
#: background rather than the noise's.
_CLEAR_DB = 10.0


@dataclass(frozen=True)
class StartPrior:
    """Where the roll puts an onset: a Student t (4 degrees of freedom, heavy tails for a
    trend that may be off) about ``mean_s`` with scale ``sd_s`` (seconds, absolute)."""

    mean_s: float
    sd_s: float

    def log_density(self, t: np.ndarray | float) -> np.ndarray | float:
        """Log density (up to a constant) at time(s) ``t``."""
        z = (np.asarray(t) - self.mean_s) / max(self.sd_s, 1e-6)
        return student_t_logpdf_fixed(z * z, 4.0)


def with_floor(sigma_s: np.ndarray, floor_s: float) -> np.ndarray:
    """Onsets' ``sigma_s`` with a lossy file's timing floor ``floor_s`` (seconds;
    :func:`~drumroll.audio.timing.timing_floor`) added in quadrature: a codec moves every
    onset by about that much (the table's ``sigma_s`` gets it at the end), and the flight
    law's prediction from those onsets is that much less sure. Unchanged for 0 (lossless
    audio)."""
    return sigma_s if floor_s == 0.0 else np.hypot(sigma_s, floor_s)


def off_sd(prior: StartPrior, sigma_s: float, floor_s: float) -> float:
    """The sd an onset with timing uncertainty ``sigma_s`` is tested against, off the law's
    prediction ``prior`` (made with the floor, :func:`with_floor`): the prediction's own sd,
    and in a lossy file (``floor_s`` > 0) also the onset's, floor included, since its own
    timing error is in the residual too. A lossless file's onsets are tested against the
    prediction's sd alone, as before."""
    if floor_s == 0.0:
        return prior.sd_s
    return float(np.hypot(prior.sd_s, with_floor(np.float64(sigma_s), floor_s)))


def law_prior(roll: Roll, bounce: int, floor_s: float = 0.0) -> StartPrior | None:
    """Where the roll's onsets put bounce number ``bounce`` (after them): their recent
    flights continued (:func:`~.prediction.flight_predictor`, with the scatter measured on
    them and a floor of :data:`_PRIOR_JITTER`). A local line, not the whole roll's law: a
    smooth law fitted to a long roll and continued is off by more than its own scatter says
    wherever the real law is not of its form (a pendulum released with speed, a ball whose
    restitution drifts), while one step of the recent trend is not. None for fewer than
    :data:`_MIN_FLIGHTS` recent flights: a line through fewer leaves too few to measure the
    scatter about it. A lossy file's timing floor ``floor_s`` is added to the onsets'
    ``sigma_s`` (:func:`with_floor`)."""
    if int(np.count_nonzero(np.diff(roll.bounce)[-_HISTORY:] == 1)) < _MIN_FLIGHTS:
        return None
    predict = flight_predictor(roll.time_s, roll.bounce, with_floor(roll.sigma_s, floor_s),
                               _HISTORY, ratio_jitter=_PRIOR_JITTER)
    if predict is None:
        return None
    dt, s_log = predict(int(bounce - roll.bounce[-1]))
    return StartPrior(float(roll.time_s[-1] + dt), s_log * dt)


def margin_db(ex: Excerpt, onset: int) -> float:
    """How far the sound starting at absolute sample ``onset`` stands out of what it lands
    in, in the power envelope: its loudest bin over :data:`_OWN_S` after the onset over the
    median of the :data:`_REFERENCE_S` before it, dB."""
    power, w = ex.band_power()
    at = (onset - ex.start) // w
    n_own, n_ref = max(round(_OWN_S * ex.sr) // w, 1), max(round(_REFERENCE_S * ex.sr) // w, 1)
    own = power[max(at, 0): at + n_own]
    ref = power[max(at - n_ref, 0): max(at, 0)]
    if own.size == 0 or ref.size == 0:
        return 0.0
    # Floored both ways: a sound gated to exact zeros after its onset (a noise gate) stands
    # out by nothing, not by log(0).
    return float(10.0 * np.log10(max(float(own.max()), 1e-300)
                                 / max(float(np.median(ref)), 1e-300)))


def common_margin_db(ex: Excerpt, roll: Roll) -> float | None:
    """The margin (:func:`margin_db`) three in four of the roll's onsets reach: stages of a
    sound fainter than this under its own level are not looked for, since in the ring of the
    bounces before most onsets would not show them (a ping-pong ball's approach, 25 dB
    under its impact). None for fewer than three onsets."""
    if len(roll) < 3:
        return None
    return float(np.quantile([margin_db(ex, round(t * ex.sr)) for t in roll.time_s], 0.25))


def rise_evidence(ex: Excerpt, onset: int, reach: int, margin: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray] | None:
    """Where the sound starting at absolute sample ``onset`` may have started earlier,
    within the ``reach`` samples before it: the candidate starts (absolute samples, one per
    bin) and the log Bayes factor of "its first stage starts there" against "background
    until the onset" at each (module docstring), or None when the stretch is too short.
    With a ``margin`` (dB), power more than that under the sound's own loudest bin counts
    as background."""
    power, w = ex.band_power()
    db = 10.0 * np.log10(power + 1e-300)
    end = (onset - ex.start) // w  # the bin holding the onset is not searched
    n = reach // w
    n_ref = max(round(_REFERENCE_S * ex.sr) // w, 8)
    n_own = max(round(_OWN_S * ex.sr) // w, 1)
    n_stage = max(round(_STAGE_S * ex.sr) // w, 1)
    if n < n_stage + 1 or end - n - n_ref < 0 or end + n_own > db.size:
        return None
    seg = db[end - n: end]
    ref = db[end - n - n_ref: end - n]
    # The background's scatter, and how far neighbouring bins move together (a ring's slow
    # beats and bursts): the likelihood of independent bins is tempered by the
    # autocorrelation time (1 + rho) / (1 - rho) of an AR(1) sequence.
    s = max(1.4826 * float(np.median(np.abs(ref - np.median(ref)))), 1.0)
    centred = ref - ref.mean()
    rho = min(max(float(centred[1:] @ centred[:-1]) / max(float(centred @ centred), 1e-12),
                  0.0), 0.9)
    temper = (1.0 + rho) / (1.0 - rho)
    if margin is not None:
        floor = float(db[end: end + n_own].max()) - margin
        seg, ref = np.maximum(seg, floor), np.maximum(ref, floor)
    mu0 = float(np.median(ref))
    c = np.concatenate(([0.0], np.cumsum(seg - mu0)))
    j = np.arange(0, n - n_stage + 1)
    shift = (c[j + n_stage] - c[j]) / n_stage  # the first stage's level over the background
    # The stage's level, uniform over [0, range] dB, integrated out (exactly: a Gaussian
    # measurement of it with sd s_m): a stage fainter than the background's scatter is
    # possible too, and costs only the prior mass of so faint a level.
    s_m = s * math.sqrt(temper / n_stage)
    log_bf = (0.5 * (shift / s_m) ** 2 + math.log(math.sqrt(2.0 * math.pi) * s_m
                                                  / _LEVEL_RANGE_DB)
              + _log_normal_mass(-shift / s_m, (_LEVEL_RANGE_DB - shift) / s_m))
    return ex.start + (end - n + j) * w, log_bf


def _log_normal_mass(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """log(Φ(b) - Φ(a)) for a < b, without cancellation in either tail."""
    # In the upper tail Φ(b) - Φ(a) = Φ(-a) - Φ(-b), whose logs are not both near 0.
    upper = a > 0
    hi = np.where(upper, log_ndtr(-a), log_ndtr(b))
    lo = np.where(upper, log_ndtr(-b), log_ndtr(a))
    with np.errstate(divide="ignore"):
        return hi + np.log(-np.expm1(lo - hi))


def start_of_sound(ex: Excerpt, r: Refined, flight: float | None, margin: float | None,
                   prior: StartPrior | None) -> Refined:
    """The onset ``r`` (absolute sample) moved to an earlier start of its sound where it is
    later than the roll puts it and the evidence is strong (module docstring).

    Parameters
    ----------
    ex
        The audio around the roll.
    r
        The onset as the change point placed it.
    flight
        Time since the onset before it (None for a roll's first): the search never reaches
        back past 40 % of it.
    margin
        The roll's common margin (:func:`common_margin_db`).
    prior
        Where the bounces before it put this one; without one the onset stays.
    """
    sr = ex.sr
    if prior is None or r.sample / sr - prior.mean_s <= LATE * prior.sd_s:
        return r
    reach_s = BACK_S if flight is None else min(BACK_S, 0.4 * flight)
    rise = rise_evidence(ex, r.sample, round(reach_s * sr), margin)
    if rise is None:
        return r
    starts, log_bf = rise
    # Each place's posterior weight against staying where the onset is: the places' prior
    # odds are the ratio of the prior's densities there (one bin each), their likelihood
    # ratios the Bayes factors.
    post = log_bf + prior.log_density(starts / sr)
    if float(logsumexp(post)) - prior.log_density(r.sample / sr) < STRONG:
        return r
    sample = int(starts[int(np.argmax(post))])
    weight = np.exp(post - post.max())
    spread = float(np.sqrt(np.sum(weight * (starts - sample) ** 2) / weight.sum())) / sr
    _, w = ex.band_power()
    fit = max(64, min(round(0.006 * sr), round(0.3 * (flight or 1.0) * sr)))
    moved = ex.refine(sample, pre=w + fit, post=round(0.002 * sr), search=w, search_after=w)
    sigma = math.hypot(moved.sigma_s, w / sr / math.sqrt(12.0), spread)
    return Refined(moved.sample, moved.amplitude, moved.snr_db, sigma, moved.rise_s,
                   moved.level)


def time_at_start(roll: Roll, ex: Excerpt) -> Roll:
    """Every onset of the roll after the third moved to an earlier start of its sound where
    it is later than the bounces before it put it (:func:`start_of_sound`), in time order
    (so each prediction uses the bounces before it as already corrected)."""
    margin = common_margin_db(ex, roll)
    sr = ex.sr
    out = roll
    for j in range(3, len(roll)):
        onset = round(out.time_s[j] * sr)
        r = Refined(onset, out.amplitude[j], out.snr_db[j], out.sigma_s[j], 0.0)
        moved = start_of_sound(ex, r, out.time_s[j] - out.time_s[j - 1], margin,
                               law_prior(out.subset(slice(0, j)), int(out.bounce[j]),
                                         ex.floor_s))
        if moved.sample != onset:
            out = _replaced(out, j, moved, sr)
    return out


def on_course(roll: Roll, off: float, floor_s: float = 0.0) -> Roll:
    """The roll without the onsets, after its third, that lie more than ``off`` predictive
    sd from where the onsets before them put them (:func:`law_prior`): a sound that is not
    that bounce, or the bounce timed where its start cannot be told (:func:`off_sd`; a lossy
    file's timing floor ``floor_s`` is allowed for). Bounce numbers are kept, so a dropped
    onset is a gap."""
    keep = np.ones(len(roll), dtype=bool)
    for j in range(3, len(roll)):
        kept = roll.subset(np.flatnonzero(keep[:j]))
        prior = law_prior(kept, int(roll.bounce[j]), floor_s)
        if prior is not None and abs(roll.time_s[j] - prior.mean_s) > off * off_sd(
                prior, float(roll.sigma_s[j]), floor_s):
            keep[j] = False
    return roll.subset(np.flatnonzero(keep))


def first_in_ring(roll: Roll, ex: Excerpt) -> Roll:
    """The roll's first onset timed as the next bounces are, which land in the ring of the
    ones before (module docstring).

    For each of the next :data:`_RINGING` bounces, the first impact's power envelope above
    :data:`~.excerpt.BAND_HZ` is seen through that bounce's background (the median power in
    the :data:`_REFERENCE_S` before it, scaled by the first impact's level over its own) and
    aligned, to the sample, with that bounce's envelope from its onset on (least squares of
    the log power over :data:`_ALIGN_S`, the level difference fitted). The bounce's onset
    less the aligned offset is where the first impact's onset is on the same point of its
    sound; the lag these alignments show (:func:`ring_lag`, which weighs how well they
    agree against a lag of nil) moves it, and its uncertainty goes into its ``sigma_s``.
    For a sound that starts at its loudest the shift is nil; for one whose first stages are
    under the ring (a snare, a lossy codec's pre-echo) it is their length. Only bounces that
    stand out of their background by :data:`_CLEAR_DB` are aligned on.
    """
    found, sds, lo, hi = ring_alignments(roll, ex)
    if found.size == 0:
        return roll
    sr = ex.sr
    shift, sd = ring_lag(found, sds, lo, hi)
    cols = [np.array(c, dtype=float) for c in (roll.time_s, roll.amplitude, roll.snr_db,
                                               roll.sigma_s)]
    cols[0][0] += shift / sr
    cols[3][0] = math.hypot(cols[3][0], sd / sr)
    return roll.with_times(*cols)


def ring_lag(found: np.ndarray, sd: np.ndarray, lo: int, hi: int) -> tuple[float, float]:
    """The first impact's lag under the next bounces' ring, from their alignments ``found``
    with their sds ``sd`` (:func:`ring_alignments`; samples, searched over ``lo`` to
    ``hi``): nil where a lag is no more likely than not, else its posterior median given
    that there is one; and the root-mean-square error of that estimate (samples).

    Each alignment is the lag plus an error of its own sd, as a Student t
    (:data:`_ALIGN_DOF` degrees of freedom: now and then a bounce's own sound is not the
    first impact's and its alignment is off by more). The sds are the stated ones times a
    factor common to all that is only known to within :data:`_SD_FACTOR` either way
    (uniform in its log): a bounce's ``sigma_s`` and a fit's spread may be conservative or
    optimistic, and how well several alignments agree says by how much. The lag is a priori
    as likely nil as not (:data:`_NO_LAG`): nil where the sound starts at its loudest, or
    where the first impact's change point is already at the same point of its sound as the
    next ones'; otherwise anywhere in the range searched, uniform in the log of its size from
    one sample to either end of the range (no scale of a first stage preferred). Whether
    there is a lag is decided by its posterior probability, how long by the posterior given
    that there is one (a median of the whole posterior would fall between nil and the lag
    the alignments show, where neither puts it): alignments that agree to within their
    precision move the onset (a snare's first 0.6 ms under the ring, or a consistent two
    samples), alignments as imprecise as they are far from nil, or that disagree, leave it.
    """
    f = np.asarray(found, dtype=float)
    if f.size == 0 or hi <= lo:
        return 0.0, 0.0
    factor = np.geomspace(1.0 / _SD_FACTOR, _SD_FACTOR, 25)
    scale = np.maximum(factor[:, None] * np.asarray(sd, dtype=float)[None, :],
                       1.0 / math.sqrt(12.0))  # (factors, alignments)
    # The lags: every sample of the range, and an eighth of a sample near each alignment
    # (where precise alignments make the likelihood a fraction of a sample wide).
    fine = (np.round(f)[:, None] + np.arange(-3.0, 3.0, 0.125)[None, :]).ravel()
    lag = np.unique(np.concatenate((np.arange(lo, hi + 1.0), fine[(fine >= lo) & (fine <= hi)])))
    grid = np.append(lag, 0.0)  # the slab's lags, then the nil lag
    z = (f[None, None, :] - grid[:, None, None]) / scale[None]
    ll = np.sum(student_t_logpdf_fixed(z * z, _ALIGN_DOF, np.log(scale)[None]), axis=2)
    top = ll.max(axis=1, keepdims=True)
    log_like = top[:, 0] + np.log(np.mean(np.exp(ll - top), axis=1))  # the factor integrated out
    prior = np.gradient(lag) / np.maximum(np.abs(lag), 1.0)  # each lag's share of the range
    log_prior = np.append(np.log(prior / prior.sum() * (1.0 - _NO_LAG)), math.log(_NO_LAG))
    post = log_like + log_prior
    weight = np.exp(post - post.max())
    weight /= weight.sum()
    shift = 0.0
    if weight[-1] < 0.5:  # a lag is more likely than not: its median given that it lags
        shift = float(lag[np.searchsorted(np.cumsum(weight[:-1]), 0.5 * (1.0 - weight[-1]))])
    return shift, math.sqrt(float(np.sum(weight * (grid - shift) ** 2)))


def ring_alignments(roll: Roll, ex: Excerpt) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Each of the next :data:`_RINGING` bounces' alignment of the first impact
    (:func:`first_in_ring`): the shift (samples) that puts the first onset at the same point
    of its sound as that bounce's onset is of its own (empty where none can be made), its sd
    (samples), and the least and greatest shift searched.

    An alignment's sd has two parts, in quadrature: how sharply the fit places it (the
    spread of the profile likelihood of the shift, the residuals Gaussian with their variance
    fitted and the bins' correlation tempering them as in :func:`rise_evidence`), and the
    bounce's own ``sigma_s`` (its onset is where the alignment is measured from)."""
    none = (np.zeros(0, dtype=np.int64), np.zeros(0), 0, 0)
    if len(roll) < 3:
        return none
    sr = ex.sr
    _, w = ex.band_power()
    y2 = ex.band_energy()
    before = round(_BEFORE_ALIGN_S * sr) // w
    n_bins = round(_ALIGN_S * sr) // w
    reach = round(BACK_S * sr)
    rel = np.arange(-before, n_bins) * w  # bin starts relative to an onset

    def envelope(start: np.ndarray) -> np.ndarray:
        """Mean power of the bins starting at ``start`` (absolute samples)."""
        i = np.clip(start - ex.start, 0, y2.size - 1 - w)
        return (y2[i + w] - y2[i]) / w

    n0 = round(roll.time_s[0] * sr)
    # (Never as far as the middle of the first flight: the bounces keep their order.)
    shifts = np.arange(-round(0.001 * sr),
                       min(reach, round(0.5 * (roll.time_s[1] - roll.time_s[0]) * sr) - 1) + 1)
    if n0 - ex.start + shifts[0] - before * w < 0 or n0 + reach + n_bins * w > ex.stop:
        return none
    first = envelope(n0 + shifts[:, None] + rel[None, :])  # (shifts, bins)
    level0 = float(envelope(n0 + np.arange(n_bins) * w).max())
    found, sds = [], []
    for j in range(1, min(_RINGING, len(roll) - 1) + 1):
        nj = round(roll.time_s[j] * sr)
        n_ref = round(_REFERENCE_S * sr) // w
        if (nj - (before + n_ref) * w < ex.start or nj + n_bins * w > ex.stop
                or margin_db(ex, nj) < _CLEAR_DB):
            continue
        target = envelope(nj + rel)
        ring = float(np.median(envelope(nj - np.arange(1, n_ref + 1) * w)))
        level_j = float(target[before:].max())
        if not (level0 > 0 and level_j > 0):
            continue
        seen_power = first + ring * level0 / level_j
        if not (np.all(target > 0) and np.all(seen_power > 0)):
            # Digital silence in a bin (a file whose noise lies under its last bit, a phone's
            # noise gate): the logs compared here do not exist, so this bounce aligns nothing.
            continue
        seen = np.log(seen_power)
        resid = seen - np.log(target)[None, :]
        resid -= resid.mean(axis=1, keepdims=True)  # the level difference, fitted
        ssr = np.maximum(np.sum(resid**2, axis=1), 1e-300)
        best = int(np.argmin(ssr))
        r = resid[best]
        rho = min(max(float(r[1:] @ r[:-1]) / max(float(r @ r), 1e-12), 0.0), 0.9)
        # The profile likelihood of the shift: minus half the bins (tempered) times the log
        # of the residual sum of squares.
        log_like = -0.5 * rel.size * (1.0 - rho) / (1.0 + rho) * np.log(ssr / ssr[best])
        weight = np.exp(log_like)
        spread = math.sqrt(float(np.sum(weight * (shifts - shifts[best]) ** 2) / weight.sum()))
        found.append(int(shifts[best]))
        sds.append(math.hypot(spread, float(roll.sigma_s[j]) * sr))
    return np.array(found, dtype=np.int64), np.array(sds), int(shifts[0]), int(shifts[-1])




def _replaced(roll: Roll, j: int, r: Refined, sr: int) -> Roll:
    """The roll with onset ``j`` replaced by ``r`` (absolute sample)."""
    cols = [np.array(c, dtype=float) for c in (roll.time_s, roll.amplitude, roll.snr_db,
                                               roll.sigma_s)]
    for c, v in zip(cols, (r.sample / sr, r.amplitude, r.snr_db, r.sigma_s), strict=True):
        c[j] = v
    return roll.with_times(*cols)
