"""Physics-aware selection of the bounce sequence among the candidates.

A freely bouncing object's flight times shrink roughly geometrically, T_k ≈ t_B α^k, with a
ratio that, if it changes at all, changes slowly (the exact pendulum, air drag, a speed-
dependent restitution). Echoes, the second burst of a double hit, ring-down wiggles, clicks
before the roll and noises after it all break that pattern.

The tracker is a beam search over paths of onsets, run in time order over stretches of
candidates separated by gaps longer than any flight (independent, so an hour of audio is
tracked in pieces). A path's score is a log-likelihood ratio, "bounce sequence" against
"unrelated sounds":

* every onset contributes its acoustic evidence, growing with its significance ``z`` and
  saturating (a loud click is certainly a sound, not certainly a bounce);
* every interval after the second is compared with the prediction from the path's smoothed
  interval ratio, with a Gaussian tolerance that widens with both onsets' timing
  uncertainties and with the interval ratio's natural jitter, against a background that is
  uniform in log interval; one missed (inaudible or masked) bounce may be bridged at a cost;
* a bounce is never louder than the one before it, and nothing between two bounces is
  louder than them (within the level measurement's scatter).

Only the ``beam`` best paths ending at each onset are kept, so the work per onset is bounded.

The best-scoring path is the roll. It starts at the first impact that fits and stops where
further candidates no longer add evidence, which is how the roll is followed into the noise
exactly as far as the recording supports.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from drumroll.onsets.candidates import Candidates


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
        Log odds against one bounce missing between two detected ones.
    beam
        Hypotheses kept per onset (the best paths ending there, whatever came before).
    louder_between_db
        Scatter allowed in the level measurement (the peak of the high-passed sound over the
        detection function's window after the onset) where the physics says "not louder":
        a bounce is slower than the one before it, and only that one's echoes, ring and
        double hits come between them, all quieter than it. So a path may neither get
        louder from bounce to bounce nor skip over a louder sound, which keeps it from
        hopping between rolls.
    min_onsets
        Fewest onsets that make a roll: three intervals give two ratios, one to predict and one
        to test.
    """

    min_interval_s: float = 0.002
    max_interval_s: float = 2.0
    min_ratio: float = 0.25
    ratio_jitter: float = 0.05
    smoothing: float = 0.5
    evidence_z: float = 6.0
    evidence_max: float = 1.5
    skip_penalty: float = 3.0
    min_onsets: int = 4
    louder_between_db: float = 6.0
    beam: int = 12


@dataclass
class Track:
    """The chosen sequence: ``index`` into the candidates, the path score, and a reason for
    every candidate left out."""

    index: np.ndarray
    score: float
    reasons: dict[int, str]


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


def track(c: Candidates, params: TrackParams | None = None) -> Track:
    """Choose the bounce sequence among the candidates (see the module docstring)."""
    p = params or TrackParams()
    n = len(c)
    if n == 0:
        return Track(np.zeros(0, dtype=np.int64), -math.inf, {})
    w = _evidence(c.z, p)
    best_path: list[int] = []
    best_score = -math.inf
    for lo, hi in stretches(c.time_s, p.max_interval_s):
        path, score = _Beam(c.time_s[lo:hi], w[lo:hi], c.sigma_s[lo:hi], c.level[lo:hi],
                            p).run()
        if path and score > best_score:
            best_path, best_score = [lo + i for i in path], score
    if not best_path:
        strongest = int(np.argmax(c.z))
        return Track(np.array([strongest]), float(w[strongest]), _reasons(c, [strongest]))
    return Track(np.asarray(best_path, dtype=np.int64), best_score, _reasons(c, best_path))


class _Beam:
    """Beam search over one stretch of candidates, in time order.

    A hypothesis is a path ending at some onset; for each onset the ``beam`` best paths ending
    there are kept (in flat arrays: score, running log ratio, last interval, end, previous
    onset, parent hypothesis). Extending to onset ``k`` looks back at every hypothesis whose
    end lies within the longest flight before ``k`` at once (vectorised), and the arrays are
    compacted now and then so that memory stays bounded however long the stretch is.
    """

    def __init__(self, t: np.ndarray, w: np.ndarray, sigma: np.ndarray, amp: np.ndarray,
                 p: TrackParams) -> None:
        self.t, self.w, self.p, self.amp = t, w, p, amp
        self.louder = 10.0 ** (p.louder_between_db / 20.0)
        self.sig2 = np.square(np.maximum(sigma, 1e-6))
        self.strong = np.flatnonzero(w >= 0)
        # Background: log(interval ratio) uniform over [log(min_ratio), log(2)], i.e. a
        # density of 1 / log_width.
        self.log_width = math.log(2.0 / p.min_ratio)
        self.first_gain = math.log(self.log_width / math.log(1.0 / p.min_ratio))
        cap = max(64, 8 * p.beam)
        self.h = {name: np.empty(cap) for name in ("score", "rho", "last")}
        self.h.update({name: np.empty(cap, dtype=np.int64) for name in ("end", "prev", "parent")})
        self.used = 0
        self.best = -1

    def run(self) -> tuple[list[int], float]:
        """The best path (onset indices in time order) and its score."""
        p, t = self.p, self.t
        first = 0  # first hypothesis whose end may still be extended
        for k in range(t.size):
            ends = self.h["end"]
            while first < self.used and t[k] - t[ends[first]] > p.max_interval_s:
                first += 1
            if self.used + p.beam > self.h["score"].size:  # before any index is handed out
                first = self._compact(first)
            props = [self._extend(k, first), self._seeds(k)]
            props = [q for q in props if q is not None]
            if not props:
                continue
            score, rho, last, prev, parent = (np.concatenate(col) for col in zip(*props,
                                                                              strict=True))
            if score.size > p.beam:
                top = np.argpartition(-score, p.beam - 1)[: p.beam]
                score, rho, last, prev, parent = (a[top] for a in (score, rho, last, prev,
                                                                    parent))
            first = self._append(k, score, rho, last, prev, parent, first)
        if self.best < 0:
            return [], -math.inf
        path = [int(self.h["end"][self.best])]
        hyp = self.best
        while hyp >= 0:
            path.append(int(self.h["prev"][hyp]))
            hyp = int(self.h["parent"][hyp])
        return sorted(set(path)), float(self.h["score"][self.best])

    def _extend(self, k: int, first: int) -> tuple | None:
        """Proposals extending the live hypotheses to onset ``k``."""
        p, t, h = self.p, self.t, self.h
        idx = np.arange(first, self.used)
        if idx.size == 0:
            return None
        j, i = h["end"][idx], h["prev"][idx]
        last, rho = h["last"][idx], h["rho"][idx]
        new = t[k] - t[j]
        ok = (new >= np.maximum(p.min_ratio * last, p.min_interval_s)) & (new <= 2.2 * last)
        # Between two consecutive bounces come only the last one's echoes, ring and double
        # hits, all quieter than it: a path that skips over a louder sound is not a roll.
        ok &= self._loudest_between(j, k) <= self.louder * np.maximum(self.amp[j], self.amp[k])
        # Each impact is slower than the one before it, so it is not louder (within the
        # measurement's scatter).
        ok &= self.amp[k] <= self.louder * self.amp[j]
        seed = np.isnan(rho)
        ok &= ~seed | (new <= last * math.exp(3.0 * p.ratio_jitter))
        if not ok.any():
            return None
        idx, j, i, last, rho, new, seed = (a[ok] for a in (idx, j, i, last, rho, new, seed))
        # One missing bounce may be bridged: new = last (r + r^2).
        r = np.exp(np.where(seed, 0.0, rho))
        tim2 = (self.sig2[j] + self.sig2[k]) / new**2 + (self.sig2[i] + self.sig2[j]) / last**2
        jit2 = p.ratio_jitter ** 2
        norm = 0.5 * math.log(2.0 * math.pi)
        gains = []
        for m in (0, 1):
            pred = last * (r if m == 0 else r + r * r)
            var = jit2 * (m + 1) + tim2
            gains.append(-0.5 * np.log(new / pred) ** 2 / var - 0.5 * np.log(var) - norm
                         + math.log(self.log_width) - m * p.skip_penalty)
        skip = gains[1] > gains[0]
        gain = np.where(seed, self.first_gain, np.maximum(gains[0], gains[1]))
        skip &= ~seed
        ratio = np.where(skip, (-1.0 + np.sqrt(1.0 + 4.0 * new / last)) / 2.0, new / last)
        step = np.where(skip, last * ratio * ratio, new)
        obs = np.log(ratio)
        rho_new = np.where(seed, obs, (1 - p.smoothing) * np.where(seed, 0.0, rho)
                           + p.smoothing * obs)
        score = h["score"][idx] + self.w[k] + gain
        return score, rho_new, step, j, idx

    def _loudest_between(self, j: np.ndarray, k: int) -> np.ndarray:
        """For each onset ``j`` before ``k``, the largest amplitude strictly between them."""
        lo = int(j.min())
        inner = self.amp[lo + 1: k]
        # suffix[m] = max(amp[lo + 1 + m: k]); a pair of neighbours has nothing in between.
        suffix = np.concatenate((np.maximum.accumulate(inner[::-1])[::-1], [0.0]))
        return suffix[j - lo]

    def _seeds(self, k: int) -> tuple | None:
        """New paths ``(i, k)``: a roll opens with two clearly significant onsets."""
        p, t = self.p, self.t
        if self.w[k] < 0:
            return None
        s = self.strong
        a = np.searchsorted(t[s], t[k] - p.max_interval_s, side="left")
        b = np.searchsorted(t[s], t[k] - p.min_interval_s, side="right")
        i = s[a:b]
        if i.size:
            i = i[(self._loudest_between(i, k)
                   <= self.louder * np.maximum(self.amp[i], self.amp[k]))
                  & (self.amp[k] <= self.louder * self.amp[i])]
        if i.size == 0:
            return None
        return (self.w[i] + self.w[k], np.full(i.size, np.nan), t[k] - t[i], i,
                np.full(i.size, -1, dtype=np.int64))

    def _append(self, k, score, rho, last, prev, parent, first) -> int:
        """Store the hypotheses ending at ``k`` (growing the arrays if needed)."""
        h = self.h
        if self.used + score.size > h["score"].size:
            for name, arr in h.items():
                grown = np.empty(2 * arr.size + score.size, dtype=arr.dtype)
                grown[: self.used] = arr[: self.used]
                h[name] = grown
        sl = slice(self.used, self.used + score.size)
        h["score"][sl], h["rho"][sl], h["last"][sl] = score, rho, last
        h["end"][sl], h["prev"][sl], h["parent"][sl] = k, prev, parent
        top = self.used + int(np.argmax(score))
        if self.best < 0 or h["score"][top] > h["score"][self.best]:
            self.best = top
        self.used += score.size
        return first

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


def _reasons(c: Candidates, kept: list[int]) -> dict[int, str]:
    """Why each candidate not in ``kept`` was left out."""
    return explain(c.time_s, c.time_s[kept], [i for i in range(len(c)) if i not in set(kept)])


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
            if gap < 0.25 * span:
                out[idx] = f"echo or double hit ({1e3 * gap:.1f} ms after an impact)"
            else:
                out[idx] = "off the bounce pattern (ring-down or noise)"
    return out
