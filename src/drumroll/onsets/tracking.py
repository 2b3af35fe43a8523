"""The rolls among the candidates: whole candidate sequences scored as a bouncer's.

A freely bouncing object's flight times shrink roughly geometrically, T_k ≈ t_B α^k, with a
ratio that, if it changes at all, changes slowly (the exact pendulum, air drag, a speed-
dependent restitution). Its impacts slow down, so their sound usually, but not always, gets
fainter: where a stick lands on the head, its tilt, the microphone and masking all change one
bounce's loudness. Echoes, the second burst of a double hit, ring-down wiggles, clicks before
the roll and noises after it fit neither pattern.

The tracker scores every candidate sequence by its log-likelihood ratio, "the impacts of one
bouncer, numbered k = 0, 1, 2, … with some of them unheard" against "unrelated sounds". Each
term is evidence, none is a rule:

* **acoustic**: every onset's significance ``z`` over the noise, saturating (a loud click is
  certainly a sound, not certainly a bounce): faint candidates must be carried by the rest;
* **timing**: every flight against the prediction from the path's running interval ratio,
  Gaussian in the log flight with a scatter that grows with both onsets' timing
  uncertainties and the ratio's natural jitter, against a background uniform in log
  interval. Flights do not grow: the predicted ratio is at most 1, no flight is longer
  than the path's first (beyond the scatter of a ratio) nor than ``max_interval_s``. While
  the bouncer is in the air it makes no sound, so every candidate heard during a flight
  (past its first quarter, where the last impact's own echoes and double hits are) is an
  unrelated sound; with n of them about, one landing where the next bounce is predicted is
  n times likelier, and the flight's timing evidence is divided by that (the look-elsewhere
  effect: in a stretch of many rolls the loud impacts of one roll no longer chain with
  those of the next into a slow "bouncer");
* **missed bounces**: one step may bridge up to ``max_skip`` unheard bounces (a masked or
  faint one is not the end of the roll), each at a cost, and the onsets after the gap are
  numbered accordingly;
* **level**: every onset's level (dB) against the path's running level trend, with a heavy-
  tailed (Student t) scatter, against a background uniform over a wide range: a bounce
  louder than the one before it costs a little, one 30 dB louder a lot.

The search is a beam search over paths in time order, over stretches of candidates separated
by gaps longer than any flight (independent, so an hour of audio is tracked in pieces), keeping
the ``beam`` best paths ending at each onset. The best path is a roll; it starts where the
evidence starts and stops where further candidates no longer add to it. A recording may hold
several rolls: the search is repeated on the candidates outside the rolls found so far for as
long as a path scores above zero. A path with three flights in a row that do not shrink is a
steady pulse, no bouncer's (a metronome, a clock: :func:`pulse_log_odds`, its bar raised by
the number of places on the path it was looked for, :func:`in_steady_pulse`); its sounds are
set aside and the rest searched again. A stretch of many rolls with short pauses between them is
searched in windows of a minute (each looking half a minute further, so that a roll starting
in it is seen whole): work and memory grow with the recording's length, not its square.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from drumroll.onsets.candidates import Candidates
from drumroll.stats import student_t_logpdf_fixed


@dataclass(frozen=True)
class TrackParams:
    """Settings of the bounce tracker (times in seconds).

    Attributes
    ----------
    min_interval_s, max_interval_s
        Shortest and longest flight time considered. The longest bounds the first flight
        (a drumstick's is 0.1–0.5 s, a ball dropped from a metre about 0.9 s).
    min_ratio
        Smallest ratio of consecutive flights (restitution) considered.
    ratio_jitter
        Typical scatter (natural log) of one interval ratio about the path's running ratio.
    smoothing
        Weight of the newest ratio in the running ratio (1: only the last ratio counts).
    evidence_z
        Significance at which a candidate's acoustic evidence is neutral: fainter candidates
        must be carried by their timing.
    evidence_max
        Cap on one candidate's acoustic evidence (log units).
    skip_penalty
        Log odds against one bounce going unheard between two heard ones.
    max_skip
        Most unheard bounces in a row that one step of a path may bridge (at most 7).
    level_scatter_db, level_dof
        Scale and degrees of freedom of the Student t scatter of one onset's level (dB)
        about the path's running trend.
    level_range_db
        Width of the range over which an unrelated sound's level is taken as uniform.
    level_smoothing
        Weight of the newest level change in the running level trend.
    min_onsets
        Fewest onsets that make a roll: three intervals give two ratios, one to predict and one
        to test.
    beam
        Hypotheses kept per onset (the best paths ending there, whatever came before).
    """

    min_interval_s: float = 0.002
    max_interval_s: float = 2.0
    min_ratio: float = 0.25
    ratio_jitter: float = 0.05
    smoothing: float = 0.5
    evidence_z: float = 6.0
    evidence_max: float = 1.5
    skip_penalty: float = 3.0
    max_skip: int = 3
    level_scatter_db: float = 6.0
    level_dof: float = 3.0
    level_range_db: float = 60.0
    level_smoothing: float = 0.3
    min_onsets: int = 4
    beam: int = 12


@dataclass
class Track:
    """One roll the tracker chose: ``index`` into the candidates (time order), each onset's
    bounce number, and the path's score."""

    index: np.ndarray
    bounce: np.ndarray
    score: float


def _evidence(z: np.ndarray, p: TrackParams) -> np.ndarray:
    return np.minimum(z - p.evidence_z, p.evidence_max)


def stretches(t: np.ndarray, max_gap: float) -> list[tuple[int, int]]:
    """Split sorted times into independent stretches ``[start, stop)`` at gaps longer than
    ``max_gap``: no flight is that long, so no roll spans such a gap."""
    if t.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(t) > max_gap) + 1
    edges = [0, *cuts.tolist(), t.size]
    return list(itertools.pairwise(edges))


def level_db(level: np.ndarray) -> np.ndarray:
    """Levels in dB (a zero or missing level is far below anything heard)."""
    level = np.asarray(level, dtype=float)
    return 20.0 * np.log10(np.where(np.isfinite(level) & (level > 0), level, 1e-12))


def track(c: Candidates, params: TrackParams | None = None) -> list[Track]:
    """Every roll among the candidates, best first (see the module docstring).

    Rolls do not overlap: after a roll is found, the candidates from its first onset to
    where its flights would have died out are set aside, and the candidates before and after
    them are searched in turn (each on its own: no roll spans the one set aside) until no
    path scores above zero. A long stretch is searched window by window
    (:func:`_windows`), so the work grows with the recording's length, not with its square.
    """
    p = params or TrackParams()
    if len(c) == 0:
        return []
    lev = level_db(c.level)
    found: list[Track] = []
    for lo, hi in stretches(c.time_s, p.max_interval_s):
        found += _windows(c.time_s, c.z, c.sigma_s, lev, lo, hi, p)
    found.sort(key=lambda tr: -tr.score)
    return found


def _windows(t: np.ndarray, z: np.ndarray, sigma: np.ndarray, lev: np.ndarray, lo: int,
             hi: int, p: TrackParams) -> list[Track]:
    """The rolls of the stretch ``[lo, hi)``, searched in windows of :data:`WINDOW_S` with
    :data:`OVERLAP_S` more after each: the rolls that start in a window are kept, those
    that start in the overlap are found again, whole, in the next window, which starts
    past the sound of the rolls kept. A stretch shorter than a window and its overlap is
    searched in one piece."""
    out: list[Track] = []
    start = lo
    while hi - start >= 2:
        cut = start + int(np.searchsorted(t[start:hi], t[start] + WINDOW_S, side="left"))
        stop = start + int(np.searchsorted(t[start:hi], t[start] + WINDOW_S + OVERLAP_S,
                                           side="left"))
        last = stop >= hi
        rolls = _best_first(t, z, sigma, lev, start, hi if last else stop, p)
        if last:
            return out + [tr for tr, _ in rolls]
        kept = [(tr, span) for tr, span in rolls if tr.index[0] < cut]
        out += [tr for tr, _ in kept]
        start = max([cut, *(span.stop for _, span in kept)])
    return out


def _best_first(t: np.ndarray, z: np.ndarray, sigma: np.ndarray, lev: np.ndarray, lo: int,
                hi: int, p: TrackParams) -> list[tuple[Track, slice]]:
    """The rolls of the candidates ``[lo, hi)``, best first, each with the candidates set
    aside as its sound (:func:`_span`)."""
    found: list[tuple[Track, slice]] = []
    todo = [np.arange(lo, hi)]
    while todo:
        idx = todo.pop()
        if idx.size < 2:
            continue
        path, bounce, score = _Beam(t[idx], z[idx], sigma[idx], lev[idx], p).run()
        if len(path) < 2 or score <= 0:
            continue
        chosen = idx[np.asarray(path)]
        pulse = in_steady_pulse(t[chosen], bounce, sigma[chosen], p)
        if pulse.any():
            # A steady pulse, no bouncer's (a metronome, a ticking clock), all of the path
            # or a stretch of it that led into a roll: its sounds are set aside as unrelated
            # to any roll, and the others searched again (as a roll's span, it would have set
            # aside every roll it runs through).
            todo.append(np.setdiff1d(idx, chosen[pulse], assume_unique=True))
            continue
        span = _span(t, chosen, int(idx[0]), int(idx[-1]) + 1)
        found.append((Track(chosen, bounce, score), span))
        todo += [idx[idx < span.start], idx[idx >= span.stop]]
    return found


#: Log odds at which onsets are taken for a steady pulse rather than a bouncer
#: (:func:`pulse_log_odds`): "strong" on Kass & Raftery's scale, as elsewhere in the extractor.
PULSE_ODDS = 3.0


def in_steady_pulse(t: np.ndarray, bounce: np.ndarray, sigma: np.ndarray, p: TrackParams
                    ) -> np.ndarray:
    """Which onsets of a path (times ``t``, numbers ``bounce``) lie in a steady pulse: every
    three flights in a row (the fewest that a roll has, ``min_onsets`` − 1) that, taken
    alone, are a pulse (:func:`pulse_log_odds`) with posterior log odds of at least
    :data:`PULSE_ODDS`. A bouncer's flights shrink at every impact, so no stretch of a roll is
    a pulse, while a path may follow a pulse into a roll (the running ratio, at 1 along the
    pulse, turns to the roll's).

    The path is searched for such a stretch at each of its N windows, so the prior odds of a
    pulse at any one of them are 1/N of those of a pulse somewhere on the path (even, here):
    a window's Bayes factor must reach :data:`PULSE_ODDS` + ln N. Without that, a real roll
    was cut at the first of its many windows that came out flat by chance: the real
    ping-pong's tail through a phone's codec (three flights of 35.6, 33.1 and 35.3 ms, log
    odds 3.2 among 45 windows) lost its last 19 impacts.
    """
    out = np.zeros(t.size, bool)
    flights = max(p.min_onsets - 1, 3)
    starts = [i for i in range(t.size - flights)
              if np.all(np.diff(bounce[i: i + flights + 1]) == 1)]
    if not starts:
        return out
    bar = PULSE_ODDS + math.log(len(starts))
    for i in starts:
        window = slice(i, i + flights + 1)
        if pulse_log_odds(t[window], bounce[window], sigma[window], p) >= bar:
            out[window] = True
    return out


def pulse_log_odds(t: np.ndarray, bounce: np.ndarray, sigma: np.ndarray, p: TrackParams
                   ) -> float:
    """ln of the Bayes factor "a steady pulse" against "a bouncer" for a path's onsets ``t``
    numbered ``bounce``, from the slope s of its log flights against their bounce numbers.

    A free bouncer loses energy at every impact: its flights shrink, ln T_k = c + s k with
    s = ln(ratio) < 0, and nothing in its physics prefers one ratio to another, so s is
    uniform over [ln(min_ratio), 0]. A pulse (a metronome, a clock, any periodic sound)
    repeats its interval: s = 0 exactly. The slope's estimate is Gaussian about s with the
    standard error of a least-squares line through the log flights (their scatter about it,
    at least what the onsets' timing gives). A precisely flat path is a pulse: "bouncer"
    spreads its prior over slopes the data rule out (the Occam factor). A path that shrinks,
    or is too short or too rough to tell, is not: of 200 four-onset stretches of rolls with a
    ratio of 0.98 and onsets timed to 1 ms, 1 % reach :data:`PULSE_ODDS` (0.97: none; 0.99,
    which no free bouncer reaches: 31 %); of rolls of six or more onsets, none.
    """
    steps = np.flatnonzero(np.diff(bounce) == 1)
    if steps.size < 3:
        return -math.inf
    flights = t[steps + 1] - t[steps]
    if np.any(flights <= 0):
        return -math.inf
    y, k = np.log(flights), bounce[steps + 1].astype(float)
    k_centred = k - k.mean()
    sxx = float(k_centred @ k_centred)
    slope = float(k_centred @ (y - y.mean())) / sxx
    resid = y - y.mean() - slope * k_centred
    timing = float(np.mean((sigma[steps + 1] ** 2 + sigma[steps] ** 2) / flights**2))
    scatter = max(float(resid @ resid) / (y.size - 2), timing, 1e-12)
    se = math.sqrt(scatter / sxx)
    lowest = math.log(p.min_ratio)
    bouncer = (_normal_cdf(-slope / se) - _normal_cdf((lowest - slope) / se)) / -lowest
    pulse = math.exp(-0.5 * (slope / se) ** 2) / (math.sqrt(2.0 * math.pi) * se)
    return math.log(max(pulse, 1e-300)) - math.log(max(bouncer, 1e-300))


def _normal_cdf(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


#: Share of a flight, after its first onset, where candidates are that onset's own echoes
#: and double hits (:func:`explain` calls them so), not sounds unrelated to the roll.
ECHO_SHARE = 0.25

#: Length of the windows a long stretch of candidates is searched in (seconds), and how
#: far past its end each window looks, so that a roll that starts in it is seen whole.
WINDOW_S, OVERLAP_S = 60.0, 30.0


def _span(t: np.ndarray, chosen: np.ndarray, lo: int, hi: int) -> slice:
    """Candidates belonging to the sound of the roll ``chosen``: from its first onset to
    where its flights, continued at their last ratio, would have died out."""
    first, last = t[chosen[0]], t[chosen[-1]]
    end = last
    if chosen.size >= 3:
        f1, f0 = t[chosen[-1]] - t[chosen[-2]], t[chosen[-2]] - t[chosen[-3]]
        r = min(f1 / f0, 0.95) if f0 > 0 else 0.5
        end = last + f1 * r / (1.0 - r)
    a = lo + int(np.searchsorted(t[lo:hi], first - 1e-3, side="left"))
    b = lo + int(np.searchsorted(t[lo:hi], end + 0.05, side="right"))
    return slice(a, max(b, int(chosen[-1]) + 1))


class _Beam:
    """Beam search over one stretch of candidates, in time order.

    A hypothesis is a path ending at some onset; for each onset the ``beam`` best paths ending
    there are kept (in flat arrays: score, running log ratio, last single flight, running
    level change per bounce, end, previous onset, bounce number of the end, parent
    hypothesis). Extending to onset ``k`` looks back at every hypothesis whose end lies within
    the longest reach before ``k`` at once (vectorised), and the arrays are compacted now and
    then so that memory stays bounded however long the stretch is.
    """

    _FLOAT = ("score", "rho", "last", "dlev", "first", "until")
    _INT = ("end", "prev", "bounce", "parent")

    def __init__(self, t: np.ndarray, z: np.ndarray, sigma: np.ndarray, lev: np.ndarray,
                 p: TrackParams) -> None:
        self.t, self.z, self.p, self.lev = t, z, p, lev
        self.w = w = _evidence(z, p)
        self.sig2 = np.square(np.maximum(sigma, 1e-6))
        self.strong = np.flatnonzero(w >= 0)
        # Timing background: log(interval ratio) uniform over [log(min_ratio), log(2)].
        self.log_width = math.log(2.0 / p.min_ratio)
        self.first_gain = math.log(self.log_width / math.log(1.0 / p.min_ratio))
        # Level: Student t about the trend against a uniform background.
        self.lev_background = math.log(p.level_range_db)
        # How far back a step may reach: the longest flight, times the unheard bounces.
        self.reach = p.max_interval_s * (p.max_skip + 1)
        cap = max(64, 8 * p.beam)
        self.h = {name: np.empty(cap) for name in self._FLOAT}
        self.h.update({name: np.empty(cap, dtype=np.int64) for name in self._INT})
        self.used = 0
        self.best = -1

    def level_gain(self, e: np.ndarray) -> np.ndarray:
        """Log-likelihood ratio of a level ``e`` dB off the trend."""
        s = self.p.level_scatter_db
        return (student_t_logpdf_fixed((e / s) ** 2, self.p.level_dof, math.log(s))
                + self.lev_background)

    def run(self) -> tuple[list[int], np.ndarray, float]:
        """The best path (onset indices in time order), its bounce numbers and its score."""
        p, t = self.p, self.t
        first = 0  # first hypothesis whose end may still be extended
        for k in range(t.size):
            ends = self.h["end"]
            while first < self.used and t[k] - t[ends[first]] > self.reach:
                first += 1
            if self.used + p.beam > self.h["score"].size:  # before any index is handed out
                first = self._compact(first)
            props = [q for q in (self._extend(k, first), self._seeds(k)) if q is not None]
            if not props:
                continue
            cols = [np.concatenate(col) for col in zip(*props, strict=True)]
            if cols[0].size > p.beam:
                top = np.argpartition(-cols[0], p.beam - 1)[: p.beam]
                cols = [a[top] for a in cols]
            self._append(k, *cols)
        if self.best < 0:
            return [], np.zeros(0, dtype=np.int64), -math.inf
        h = self.h
        path = [(int(h["end"][self.best]), int(h["bounce"][self.best]))]
        hyp = self.best
        while hyp >= 0:
            parent = int(h["parent"][hyp])
            if parent < 0:  # the seed: its first onset is bounce 0
                path.append((int(h["prev"][hyp]), 0))
            else:
                path.append((int(h["end"][parent]), int(h["bounce"][parent])))
            hyp = parent
        path.reverse()
        return ([i for i, _ in path], np.array([b for _, b in path], dtype=np.int64),
                float(h["score"][self.best]))

    def _extend(self, k: int, first: int) -> tuple | None:
        """Proposals extending the live hypotheses to onset ``k``, each with the number of
        unheard bounces between that fits best."""
        p, t, h = self.p, self.t, self.h
        idx = first + np.flatnonzero(h["until"][first: self.used] >= t[k])
        if idx.size == 0:
            return None
        j, i = h["end"][idx], h["prev"][idx]
        last, rho = h["last"][idx], h["rho"][idx]
        new = t[k] - t[j]
        seed = np.isnan(rho)
        r = np.exp(np.minimum(np.where(seed, 0.0, rho), 0.0))
        # Predicted intervals over 1 … max_skip + 1 flights: last (r + r^2 + … + r^(m+1)).
        steps = np.arange(1, p.max_skip + 2)
        pred = last[:, None] * np.cumsum(r[:, None] ** steps[None, :], axis=1)
        ok = new >= np.maximum(p.min_ratio * last * np.where(seed, 1.0, r), p.min_interval_s)
        # After a seed the ratio is unknown: one flight, and flights do not grow.
        ok &= ~seed | (new <= last * math.exp(3.0 * p.ratio_jitter))
        ok &= seed | (new <= pred[:, -1] * math.exp(4.0 * p.ratio_jitter
                                                     * math.sqrt(p.max_skip + 1)))
        if not ok.any():
            return None
        idx, j, i, last, rho, new, seed, pred = (a[ok] for a in (idx, j, i, last, rho, new,
                                                                   seed, pred))
        tim2 = (self.sig2[j] + self.sig2[k]) / new**2 + (self.sig2[i] + self.sig2[j]) / last**2
        var = p.ratio_jitter ** 2 * steps[None, :] + tim2[:, None]
        gains = (-0.5 * np.log(new[:, None] / pred) ** 2 / var - 0.5 * np.log(var)
                 - 0.5 * math.log(2.0 * math.pi) + math.log(self.log_width)
                 - (steps[None, :] - 1) * p.skip_penalty
                 - np.log1p(self._rivals(j, k, pred, var) * self.log_width))
        gains[seed, 1:] = -np.inf
        first_flight = h["first"][idx]
        ceiling = self._ceiling(first_flight)
        gains[new[:, None] > steps[None, :] * ceiling[:, None]] = -np.inf
        m_best = np.argmax(gains, axis=1)
        gain = np.where(seed, self.first_gain, gains[np.arange(m_best.size), m_best])
        # The ratio this step observed (over m + 1 flights), and the single flight it ends.
        ratio = new / last
        skipped = m_best > 0
        if skipped.any():
            ratio[skipped] = _step_ratio(ratio[skipped], m_best[skipped] + 1)
        step = last * ratio ** (m_best + 1)
        obs = np.log(ratio)
        rho_new = np.where(seed, obs, (1 - p.smoothing) * np.where(seed, 0.0, rho)
                           + p.smoothing * obs)
        dl = (self.lev[k] - self.lev[j]) / (m_best + 1)
        dlev = h["dlev"][idx]
        lev_gain = self.level_gain(self.lev[k] - self.lev[j] - (m_best + 1) * dlev)
        dlev_new = (1 - p.level_smoothing) * dlev + p.level_smoothing * dl
        score = h["score"][idx] + self.w[k] + gain + lev_gain
        ok = np.isfinite(score)
        if not ok.any():
            return None
        return (score[ok], rho_new[ok], step[ok], dlev_new[ok], first_flight[ok], j[ok],
                (h["bounce"][idx] + m_best + 1)[ok], idx[ok])

    def _rivals(self, j: np.ndarray, k: int, pred: np.ndarray, var: np.ndarray) -> np.ndarray:
        """How many candidates were heard while the bouncer was in the air and could not be
        this bounce, per hypothesis ending at onset ``j`` and number of flights: those past
        the first :data:`ECHO_SHARE` of the flight (onset ``j``'s own echoes and double hits)
        and more than 3 sd before where the bounce is predicted (never onset ``k`` itself or
        later).

        Both ends are set by the prediction, not by onset ``k``, so every candidate of one
        arrival faces the same rivals: counting up to ``k`` made an earlier candidate of the
        same sound (noise just before a faint impact) look less crowded by one rival, and the
        tracker took it (12 dB, 22 kHz: two onsets 2–3 ms early in four rolls).
        """
        t, start_j = self.t, self.t[j][:, None]
        first = np.searchsorted(t, start_j + ECHO_SHARE * pred[:, :1], side="right")
        end = np.minimum(start_j + pred * np.exp(-3.0 * np.sqrt(var)), t[k])
        return np.maximum(np.searchsorted(t, end, side="left") - first, 0)

    def _seeds(self, k: int) -> tuple | None:
        """New paths ``(i, k)``: a roll opens with two clearly significant onsets."""
        p, t = self.p, self.t
        if self.w[k] < 0:
            return None
        s = self.strong
        a = np.searchsorted(t[s], t[k] - p.max_interval_s, side="left")
        b = np.searchsorted(t[s], t[k] - p.min_interval_s, side="right")
        i = s[a:b]
        if i.size == 0:
            return None
        score = self.w[i] + self.w[k] + self.level_gain(self.lev[k] - self.lev[i])
        return (score, np.full(i.size, np.nan), t[k] - t[i], np.zeros(i.size), t[k] - t[i], i,
                np.ones(i.size, dtype=np.int64), np.full(i.size, -1, dtype=np.int64))

    def _append(self, k, score, rho, last, dlev, first, prev, bounce, parent) -> None:
        """Store the hypotheses ending at ``k`` (growing the arrays if needed)."""
        h = self.h
        if self.used + score.size > h["score"].size:
            for name, arr in h.items():
                grown = np.empty(2 * arr.size + score.size, dtype=arr.dtype)
                grown[: self.used] = arr[: self.used]
                h[name] = grown
        sl = slice(self.used, self.used + score.size)
        h["score"][sl], h["rho"][sl], h["last"][sl], h["dlev"][sl] = score, rho, last, dlev
        h["first"][sl] = first
        h["until"][sl] = self.t[k] + self._longest_step(rho, last, first) + 1e-9
        h["end"][sl], h["prev"][sl], h["bounce"][sl], h["parent"][sl] = k, prev, bounce, parent
        top = self.used + int(np.argmax(score))
        if self.best < 0 or h["score"][top] > h["score"][self.best]:
            self.best = top
        self.used += score.size

    def _longest_step(self, rho: np.ndarray, last: np.ndarray, first: np.ndarray
                      ) -> np.ndarray:
        """The longest step :meth:`_extend` lets each hypothesis make (seconds), so that those
        that cannot reach an onset are not scored against it."""
        p = self.p
        seed = np.isnan(rho)
        r = np.exp(np.minimum(np.where(seed, 0.0, rho), 0.0))
        sums = np.sum(r[:, None] ** np.arange(1, p.max_skip + 2)[None, :], axis=1)
        longest = np.where(seed, last * math.exp(3.0 * p.ratio_jitter),
                           last * sums * math.exp(4.0 * p.ratio_jitter
                                                  * math.sqrt(p.max_skip + 1)))
        return np.minimum(longest, (p.max_skip + 1) * self._ceiling(first))

    def _ceiling(self, first: np.ndarray) -> np.ndarray:
        """The longest single flight of a path whose first flight was ``first``: flights do
        not grow (beyond the scatter of a ratio), and none is longer than
        ``max_interval_s``."""
        p = self.p
        return np.minimum(first * math.exp(3.0 * p.ratio_jitter), p.max_interval_s)

    def _compact(self, first: int) -> int:
        """Drop hypotheses that neither can be extended nor lie on a kept path, and make room
        for the live ones to double (so compaction stays rare)."""
        h = self.h
        keep = np.zeros(self.used, dtype=bool)
        keep[first: self.used] = True
        if self.best >= 0:
            keep[self.best] = True
        frontier = np.flatnonzero(keep)
        while frontier.size:
            par = h["parent"][frontier]
            par = par[par >= 0]
            par = par[~keep[par]]
            keep[par] = True
            frontier = np.unique(par)
        new_index = np.cumsum(keep) - 1
        kept = np.flatnonzero(keep)
        for name in h:
            h[name][: kept.size] = h[name][kept]
        par = h["parent"][: kept.size]
        h["parent"][: kept.size] = np.where(par >= 0, new_index[np.maximum(par, 0)], -1)
        self.best = int(new_index[self.best]) if self.best >= 0 else -1
        first = int(new_index[first]) if first < self.used else kept.size
        self.used = kept.size
        if 2 * self.used + self.p.beam > h["score"].size:
            for name, arr in h.items():
                grown = np.empty(4 * self.used + self.p.beam, dtype=arr.dtype)
                grown[: self.used] = arr[: self.used]
                h[name] = grown
        return first


def _step_ratio(q: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The ratio r with r + r² + … + r^n = q (one step over n > 1 flights, the first of them
    ``q`` times the last known flight): the sum grows with r, so it is inverted by
    interpolation in a table (to 0.05 % of r, finer than any ratio's scatter)."""
    r = np.empty(q.size)
    for m in np.unique(n):
        at = n == m
        r[at] = np.interp(q[at], _SUMS[int(m)], _RATIOS)
    return r


#: The table :func:`_step_ratio` inverts: sums r + … + r^n for n up to 8 over a grid of r.
_RATIOS = np.linspace(1e-3, 2.0, 4001)
_SUMS = {n: np.sum(_RATIOS[None, :] ** np.arange(1, n + 1)[:, None], axis=0)
         for n in range(2, 9)}


def explain(t: np.ndarray, kept_t: np.ndarray, left_out: list[int]) -> dict[int, str]:
    """Why each candidate ``left_out`` (indices into the candidate times ``t``) is not one of
    the roll's onsets ``kept_t`` (sorted)."""
    out: dict[int, str] = {}
    for idx in left_out:
        if t[idx] < kept_t[0]:
            out[idx] = "before the roll"
        elif t[idx] > kept_t[-1]:
            out[idx] = "after the roll"
        else:
            k = min(int(np.searchsorted(kept_t, t[idx])) - 1, kept_t.size - 2)
            gap = t[idx] - kept_t[k]
            span = kept_t[k + 1] - kept_t[k]
            if gap < ECHO_SHARE * span:
                out[idx] = f"echo or double hit ({1e3 * gap:.1f} ms after an impact)"
            else:
                out[idx] = "off the bounce pattern (ring-down or noise)"
    return out
