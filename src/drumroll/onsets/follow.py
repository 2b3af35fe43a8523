"""Following a tracked roll into the noise: a targeted search where the next bounce must be.

The first pass keeps only candidates that are significant against the whole recording
(``z >= 5``): a threshold set for the number of frames in a file. Once the roll is tracked,
physics says where the next impact must fall: the flights shrink roughly geometrically, so a
straight line through the logarithms of the recent flight times predicts the next one, with
an uncertainty from the scatter about that line and from the onsets' own timing errors. Only
that window is searched, so the detection threshold is set for the window's size: a false
alarm rate per window, not per file, taken from the tail of the detection function's own
distribution around the roll (an exponential peaks-over-threshold fit, so no constant is tuned
to one kind of recording). When intervals are short, the detection function is recomputed with
windows shorter than the interval, so the previous bounce does not mask the next. The walk
stops where the evidence in the predicted window is no longer significant. A masked bounce
ends the walk: the onsets after it could not be numbered.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from drumroll.onsets.candidates import (
    FLOOR_PER_SAMPLE,
    combined_z,
    plateau,
    refine_window,
    settle_samples,
)
from drumroll.onsets.odf import OdfParams, band_filters, frame_energy, wide_filter


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
    """

    false_alarm: float = 0.01
    width_sigmas: float = 3.0
    history: int = 6
    ratio_jitter: float = 0.05
    tail_quantile: float = 0.95
    min_snr_db: float = 0.0


@dataclass
class Found:
    """Onsets added by the targeted search (parallel lists)."""

    time_s: list[float]
    amplitude: list[float]
    snr_db: list[float]
    sigma_s: list[float]


class Excerpt:
    """Raw samples around the roll, their band energies, and detection functions on demand.

    Parameters
    ----------
    x
        Mono samples.
    start
        Absolute sample index of ``x[0]``.
    sample_rate
        Samples per second.
    odf
        Detection-function settings (the bands and the hop of the first pass).
    """

    def __init__(self, x: np.ndarray, start: int, sample_rate: int, odf: OdfParams) -> None:
        self.x, self.start, self.sr, self.odf = x, start, sample_rate, odf
        self.hop = odf.hop(sample_rate)
        # Frames on the absolute grid of the first pass.
        self.skip = (-start) % self.hop
        self.f0 = (start + self.skip) // self.hop
        self.energy = []
        for filt in band_filters(odf, sample_rate):
            self.energy.append(frame_energy(filt(x)[self.skip:], self.hop))
        sos = wide_filter(odf, sample_rate).sos
        self.settle = settle_samples(sos, sample_rate)
        self.ba = signal.sos2tf(sos)
        self.segment = odf.frames(0.25, sample_rate)
        self._z: dict[tuple[int, int], np.ndarray] = {}

    @property
    def n_frames(self) -> int:
        """Frames in the excerpt."""
        return int(self.energy[0].size)

    def frame(self, t: float) -> int:
        """Excerpt frame index holding time ``t`` (seconds, absolute)."""
        return int(np.floor(t * self.sr / self.hop)) - self.f0

    def z(self, pre: int, post: int) -> np.ndarray:
        """The standardised detection function with ``pre``/``post`` frame windows."""
        key = (pre, post)
        if key not in self._z:
            n = self.n_frames
            inner = slice(min(pre, n), max(n - post, 0))
            self._z[key] = combined_z(self.energy, pre, post, self.segment, inner,
                                      FLOOR_PER_SAMPLE * self.hop)
        return self._z[key]


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


def follow(times: list[float], sigmas: list[float], ex: Excerpt, p: FollowParams,
           min_interval_s: float, stop_s: float) -> Found:
    """Extend the roll ``times`` (at least three onsets) forward, window by window.

    Parameters
    ----------
    times, sigmas
        Onsets so far (seconds, absolute) and their timing uncertainties.
    ex
        The audio around the roll.
    p
        Settings.
    min_interval_s
        Shortest flight considered: the walk ends when the prediction falls below it.
    stop_s
        Never look past this time.
    """
    t = list(times)
    sig = list(sigmas)
    out = Found([], [], [], [])
    hop_s = ex.hop / ex.sr
    tails: dict[tuple[int, int], tuple[float, float, float]] = {}
    ref = _reference_frames(np.asarray(times), ex)
    while len(t) >= 3:
        pred = flight_predictor(np.asarray(t), np.asarray(sig), p)
        if pred is None:
            break
        dt, s_log = pred(1)
        if dt < min_interval_s or t[-1] + dt > stop_s:
            break
        got = _search(t[-1], dt, s_log, ex, p, tails, hop_s, ref)
        if got is None:
            break
        time_s, r = got
        t.append(time_s)
        sig.append(r.sigma_s)
        out.time_s.append(time_s)
        out.amplitude.append(r.amplitude)
        out.snr_db.append(r.snr_db)
        out.sigma_s.append(r.sigma_s)
    return out


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


def flight_predictor(t: np.ndarray, sig: np.ndarray, p: FollowParams):
    """A function ``n -> (interval to the n-th next onset, its log-scale sigma)`` from a
    straight-line fit to the logarithms of the recent flights, or None."""
    flights = np.diff(t)[-p.history:]
    if flights.size < 2 or np.any(flights <= 0):
        return None
    y = np.log(flights)
    k = np.arange(flights.size, dtype=float)
    # Timing errors of both ends enter each log flight.
    s_end = sig[-flights.size - 1:]
    var_t = (s_end[1:] ** 2 + s_end[:-1] ** 2) / flights**2
    var = var_t + p.ratio_jitter**2
    wts = 1.0 / var
    kbar = np.sum(wts * k) / wts.sum()
    sxx = np.sum(wts * (k - kbar) ** 2)
    slope = np.sum(wts * (k - kbar) * (y - np.sum(wts * y) / wts.sum())) / max(sxx, 1e-12)
    slope = min(slope, 0.0)  # flights do not grow
    icpt = np.sum(wts * (y - slope * k)) / wts.sum()
    resid = y - (icpt + slope * k)
    dof = max(flights.size - 2, 1)
    s2 = max(float(np.sum(wts * resid**2) / dof), 1.0)  # variance scale: >1 if misfitting
    w_sum = float(wts.sum())
    last_var = float(sig[-1]) ** 2

    def at(n: int) -> tuple[float, float]:
        ks = flights.size + np.arange(n, dtype=float)
        flight = np.exp(icpt + slope * ks)
        # The line's own uncertainty is shared by the n flights; each flight's scatter is not.
        sd_line = np.sqrt(s2 * (1.0 / w_sum + (ks - kbar) ** 2 / max(sxx, 1e-12)))
        total = float(flight.sum())
        var_abs = float(np.sum(flight * sd_line)) ** 2 \
            + float(np.sum(flight**2)) * s2 * p.ratio_jitter**2 + last_var
        return total, math.sqrt(var_abs) / total

    return at


def _search(t_last: float, dt: float, s_log: float, ex: Excerpt, p: FollowParams,
            tails: dict, hop_s: float, ref: np.ndarray):
    """Test the window around ``t_last + dt``; the refined onset if significant, else None.
    ``ref`` flags the frames whose detection function is the noise reference."""
    half = max(p.width_sigmas * s_log * dt, 2 * hop_s)
    lo_t, hi_t = t_last + dt - half, t_last + dt + half
    # Windows shorter than the flight, so the previous bounce is not in the reference.
    pre = max(1, min(ex.odf.frames(ex.odf.pre_s, ex.sr), int(0.6 * dt / hop_s)))
    post = max(1, min(ex.odf.frames(ex.odf.post_s, ex.sr), int(0.3 * dt / hop_s)))
    lo_t = max(lo_t, t_last + 2 * hop_s + post * hop_s)
    if hi_t <= lo_t:
        return None
    z = ex.z(pre, post)
    a, b = max(ex.frame(lo_t), pre), min(ex.frame(hi_t) + 1, ex.n_frames - post)
    if b <= a:
        return None
    key = (pre, post)
    if key not in tails:
        tails[key] = _tail(z[ref], p.tail_quantile)
    u, q_u, beta = tails[key]
    width = b - a
    # P(max of `width` tail frames > x) = false_alarm, frames taken as independent.
    per_frame = -math.expm1(math.log1p(-p.false_alarm) / width)
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
    r = refine_window(ex.x, ex.start, (ex.f0 + at) * ex.hop, ex.sr, ex.ba, ex.settle,
                      pre=back + fit, post=margin, search=back, search_after=margin)
    if r.snr_db < p.min_snr_db:  # there is a sound, but not one that can be timed
        return None
    return r.sample / ex.sr, r
