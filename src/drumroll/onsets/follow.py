"""Following a roll into the noise: a targeted search where the next bounce must be.

The first pass keeps only candidates that are significant against the whole recording
(``z >= 5``): a threshold set for the number of frames in a file. Once a roll is tracked,
physics says where its next impact must fall: the flights shrink roughly geometrically, so a
straight line through the logarithms of the recent flight times (against their bounce
numbers) predicts the next one, with an uncertainty from the scatter about that line and from
the onsets' own timing errors. Only that window is searched, so the detection threshold is set
for the window's size: a false alarm rate per window, not per file, taken from the tail of
the detection function's own distribution around the roll (an exponential peaks-over-threshold
fit, so no constant is tuned to one kind of recording). When intervals are short, the
detection function is recomputed with windows shorter than the interval, so the previous
bounce does not mask the next.

A window with nothing significant in it is one unheard bounce, not the end of the roll: the
search moves on to where the bounce after it would be, numbering on, and gives up only after
``max_skip + 1`` windows in a row are empty (the false alarm rate of each further window is
divided by the windows tried, so giving a faded roll more chances does not add onsets after
its end). The same test run once before the first onset, where the flights continued back
would put an earlier impact, finds a first impact the first pass missed.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from drumroll.onsets.candidates import plateau
from drumroll.onsets.excerpt import Excerpt
from drumroll.onsets.prediction import flight_predictor
from drumroll.onsets.refine import Refined
from drumroll.onsets.roll import Roll
from drumroll.onsets.start import (
    StartPrior,
    common_margin_db,
    law_prior,
    off_sd,
    start_of_sound,
    with_floor,
)

#: Predictive sd (of the bounces before) beyond which a sound found in a window is not
#: that window's bounce.
OFF_LAW = 4.0


@dataclass(frozen=True)
class FollowParams:
    """Settings of the targeted search.

    Attributes
    ----------
    false_alarm
        Probability that noise alone passes the test in one predicted window.
    width_sigmas
        Half-width of the searched window in predictive standard deviations.
    history
        Recent flights the geometric trend is fitted to.
    ratio_jitter
        Floor on the scatter (natural log) of one flight about the trend.
    tail_quantile
        Quantile of the detection function above which its tail is fitted.
    min_snr_db
        Least own-sound-to-background ratio (:attr:`~.refine.Refined.snr_db`) of an onset
        that is reported: an impact quieter than the ring and noise it lands in is heard
        (the window is significant) but its start cannot be told to the sample.
    max_skip
        Unheard bounces in a row after which the search stops.
    min_interval_s
        Shortest flight looked for.
    """

    false_alarm: float = 0.01
    width_sigmas: float = 3.0
    history: int = 6
    ratio_jitter: float = 0.05
    tail_quantile: float = 0.95
    min_snr_db: float = 0.0
    max_skip: int = 2
    min_interval_s: float = 0.002


def follow(roll: Roll, ex: Excerpt, p: FollowParams, stop_s: float) -> Roll:
    """Extend ``roll`` (at least three onsets) forward, window by window (module docstring).

    Parameters
    ----------
    roll
        The roll so far.
    ex
        The audio around the roll.
    p
        Settings.
    stop_s
        Never look past this time.
    """
    search = _Search(ex, p, roll)
    n = 1
    while len(roll) >= 3:
        pred = flight_predictor(roll.time_s, roll.bounce, with_floor(roll.sigma_s, ex.floor_s),
                                p.history, p.ratio_jitter)
        if pred is None:
            break
        dt, s_log = pred(n)
        single = dt - (pred(n - 1)[0] if n > 1 else 0.0)
        if single < p.min_interval_s or roll.time_s[-1] + dt > stop_s:
            break
        got = search(roll.time_s[-1], dt, s_log, p.false_alarm / n,
                     prior=law_prior(roll, int(roll.bounce[-1]) + n, ex.floor_s))
        if got is None:
            n += 1
            if n > p.max_skip + 1:
                break
            continue
        time_s, r = got
        roll = roll.with_onset(time_s, int(roll.bounce[-1]) + n, r.amplitude, r.snr_db,
                               r.sigma_s, r.level)
        n = 1
    return roll


class _Search:
    """Tests of predicted windows on one excerpt (the noise reference and the tail fits are
    shared between the windows)."""

    def __init__(self, ex: Excerpt, p: FollowParams, roll: Roll) -> None:
        self.ex, self.p = ex, p
        self.ref = _reference_frames(roll.time_s, ex)
        self.margin = common_margin_db(ex, roll)
        self.tails: dict[tuple[int, int], tuple[float, float, float]] = {}
        self.hop_s = ex.hop / ex.sr

    def __call__(self, t_from: float, dt: float, s_log: float, false_alarm: float, *,
                 prior: StartPrior | None = None) -> tuple[float, Refined] | None:
        """Test the window around ``t_from + dt``; the refined onset if significant (moved
        to the start of its sound where it is later than ``prior``,
        :func:`~.start.start_of_sound`), else None."""
        ex, p, hop_s = self.ex, self.p, self.hop_s
        centre = t_from + dt
        half = max(p.width_sigmas * s_log * dt, 2 * hop_s)
        lo_t, hi_t = centre - half, centre + half
        # Windows shorter than the flight, so the neighbouring bounce is not in the reference.
        pre = max(1, min(ex.odf.frames(ex.odf.pre_s, ex.sr), int(0.6 * dt / hop_s)))
        post = max(1, min(ex.odf.frames(ex.odf.post_s, ex.sr), int(0.3 * dt / hop_s)))
        lo_t = max(lo_t, t_from + 2 * hop_s + post * hop_s)
        if hi_t <= lo_t:
            return None
        z = ex.z(pre, post)
        a, b = max(ex.frame(lo_t), pre), min(ex.frame(hi_t) + 1, ex.n_frames - post)
        if b <= a:
            return None
        key = (pre, post)
        if key not in self.tails:
            self.tails[key] = _tail(z[self.ref], p.tail_quantile)
        u, q_u, beta = self.tails[key]
        width = b - a
        # P(max of `width` tail frames > x) = false_alarm, frames taken as independent.
        per_frame = -math.expm1(math.log1p(-false_alarm) / width)
        x_star = u + beta * math.log(q_u / per_frame)
        f = a + int(np.argmax(z[a:b]))
        if z[f] < x_star:
            return None
        # Locate as the first pass does: the short-window detection function's peak on the
        # plateau, then the change point from 2 ms before the plateau to 2 ms after that peak.
        first, last = plateau(z, f, post)
        post_loc = min(ex.odf.frames(0.001, ex.sr), post)
        g = max(first - post_loc, 0)
        at = g + int(np.argmax(ex.z(pre, post_loc)[g: last + 1]))
        margin = round(0.002 * ex.sr)
        back = margin + (at - first) * ex.hop
        # The refinement's reference starts after the previous bounce's click where it can.
        fit = max(64, min(round(0.008 * ex.sr) - margin, round(0.5 * dt * ex.sr)))
        r = ex.refine((ex.f0 + at) * ex.hop, pre=back + fit, post=margin, search=back,
                      search_after=margin)
        if r.snr_db < p.min_snr_db and not _resonant(r.sample / ex.sr, r, prior, p):
            return None  # there is a sound, but not one that can be timed
        r = start_of_sound(ex, r, dt, self.margin, prior)
        if r.sample / ex.sr < t_from + p.min_interval_s:
            # Timed back into the flight it should end (the refinement searches before
            # the window): not a later bounce.
            return None
        if prior is not None and abs(r.sample / ex.sr - prior.mean_s) > OFF_LAW * off_sd(
                prior, r.sigma_s, ex.floor_s):
            # Far from where the bounces before put this one: a sound that is not it, or
            # the bounce timed where it cannot be told (the window counts as unheard).
            return None
        return r.sample / ex.sr, r


def _resonant(t: float, r: Refined, prior: StartPrior | None, p: FollowParams) -> bool:
    """Whether an onset quieter than the whitened ring it lands in can be timed all the
    same: where each impact excites the same resonance as the ring (a wood block, a ball's
    shell), the ring's prediction also predicts much of the new impact away. Such an onset
    counts if its sound as recorded stands out (``raw_snr_db``) and it lies where the
    bounces before it put it (within two predictive sd): a mistimed faint impact does not.
    ``t`` is the onset's time (s)."""
    return (prior is not None and r.raw_snr_db >= p.min_snr_db
            and abs(t - prior.mean_s) <= 2.0 * prior.sd_s)


def _tail(z: np.ndarray, q: float) -> tuple[float, float, float]:
    """Exponential fit to the upper tail of ``z``: threshold ``u`` (the ``q`` quantile),
    exceedance probability ``1 - q`` and scale ``beta``.

    The scale comes from the median excess (``beta ln 2`` for an exponential tail), so the
    roll's own impacts, a few frames far out in the tail, do not inflate it.
    """
    u = float(np.quantile(z, q))
    excess = z[z > u] - u
    beta = float(np.median(excess)) / math.log(2.0) if excess.size else 1.0
    return u, 1.0 - q, max(beta, 1e-3)


def _reference_frames(t: np.ndarray, ex: Excerpt) -> np.ndarray:
    """Frames where the detection function shows the roll's background and nothing else:
    the middle halves of the flights between known onsets (the ring-down, the noise; an
    echo or double hit there only makes the threshold more conservative). Before the roll
    when it is too short to give enough of them."""
    ref = np.zeros(ex.n_frames, dtype=bool)
    for a, b in itertools.pairwise(t):
        lo, hi = ex.frame(a + 0.25 * (b - a)), ex.frame(a + 0.75 * (b - a))
        ref[max(lo, 0): max(hi, 0)] = True
    if np.count_nonzero(ref) < 200:
        ref[: max(ex.frame(t[0]) - 40, 0)] = True
    if not ref.any():
        ref[:] = True
    return ref
