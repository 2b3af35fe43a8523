"""Physics-aware selection of the bounce sequence among the candidates.

A freely bouncing object's flight times shrink roughly geometrically, T_k ≈ t_B α^k, with a
ratio that, if it changes at all, changes slowly (the exact pendulum, air drag, a speed-
dependent restitution). Echoes, the second burst of a double hit, ring-down wiggles, clicks
before the roll and noises after it all break that pattern.

The tracker is a dynamic programme over pairs of consecutive onsets ``(i, j)``. A path's score
is a log-likelihood ratio, "bounce sequence" against "unrelated sounds":

* every onset contributes its acoustic evidence, growing with its significance ``z`` and
  saturating (a loud click is certainly a sound, not certainly a bounce);
* every interval after the second is compared with the prediction from the path's smoothed
  interval ratio, with a Gaussian tolerance that widens with both onsets' timing
  uncertainties and with the interval ratio's natural jitter, against a background that is
  uniform in log interval; one missed (inaudible or masked) bounce may be bridged at a cost.

The best-scoring path is the roll. It starts at the first impact that fits and stops where
further candidates no longer add evidence, which is how the roll is followed into the noise
exactly as far as the recording supports.
"""

from __future__ import annotations

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
        Hypotheses kept per pair of consecutive onsets.
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
    beam: int = 4


@dataclass
class Track:
    """The chosen sequence: ``index`` into the candidates, the path score, and a reason for
    every candidate left out."""

    index: np.ndarray
    score: float
    reasons: dict[int, str]


def _evidence(z: np.ndarray, p: TrackParams) -> np.ndarray:
    return np.minimum(z - p.evidence_z, p.evidence_max)


def track(c: Candidates, params: TrackParams | None = None) -> Track:
    """Choose the bounce sequence among the candidates (see the module docstring)."""
    p = params or TrackParams()
    n = len(c)
    if n == 0:
        return Track(np.zeros(0, dtype=np.int64), -math.inf, {})
    t = c.time_s
    w = _evidence(c.z, p)
    sig2 = np.square(np.maximum(c.sigma_s, 1e-6))
    log_width = math.log(2.0 / p.min_ratio)  # background range of log(interval ratio)
    jit2 = p.ratio_jitter ** 2
    norm = 0.5 * math.log(2.0 * math.pi)

    # Each state (i, j) keeps its ``beam`` best hypotheses (score, previous hypothesis,
    # running log ratio or nan, last interval, state): the running ratio depends on the
    # path, so the single best predecessor is not enough when a path starts on a stray sound.
    states: dict[tuple[int, int], list[tuple]] = {}
    by_end: list[list[tuple[int, int]]] = [[] for _ in range(n)]

    def offer(key: tuple[int, int], hyp: tuple) -> None:
        hyps = states.get(key)
        if hyps is None:
            states[key] = [hyp]
            by_end[key[1]].append(key)
        elif len(hyps) < p.beam:
            hyps.append(hyp)
        else:
            worst = min(range(len(hyps)), key=lambda h: hyps[h][0])
            if hyp[0] > hyps[worst][0]:
                hyps[worst] = hyp

    # A roll opens with its loudest bounces: only clearly significant pairs may start one.
    strong = np.flatnonzero(w >= 0)
    for i in strong.tolist():
        for j in strong[(t[strong] >= t[i] + p.min_interval_s)
                        & (t[strong] <= t[i] + p.max_interval_s)].tolist():
            offer((i, j), (w[i] + w[j], None, math.nan, t[j] - t[i], (i, j)))

    first_gain = math.log(log_width / math.log(1.0 / p.min_ratio))
    for j in range(n):
        for key in by_end[j]:
            i = key[0]
            for hyp in states[key]:
                score, _, rho, last, _ = hyp
                lo = np.searchsorted(t, t[j] + max(p.min_ratio * last, p.min_interval_s))
                hi = np.searchsorted(t, t[j] + 2.2 * last, side="right")
                if hi <= lo:
                    continue
                ks = np.arange(lo, hi)
                new = t[ks] - t[j]
                if math.isnan(rho):
                    # First ratio: only the prior on the restitution (a ratio in
                    # [min_ratio, 1]) speaks, against the background.
                    ok = new <= last * math.exp(3.0 * p.ratio_jitter)
                    gain = np.where(ok, first_gain, -np.inf)
                    m_best = np.zeros(ks.size, dtype=np.int64)
                else:
                    r = math.exp(rho)
                    tim2 = (sig2[j] + sig2[ks]) / new**2 + (sig2[i] + sig2[j]) / last**2
                    gains = []
                    for m in (0, 1):
                        pred = last * sum(r ** q for q in range(1, m + 2))
                        var = jit2 * (m + 1) + tim2
                        dev = np.log(new / pred)
                        gains.append(-0.5 * dev**2 / var - 0.5 * np.log(var) - norm + log_width
                                     - m * p.skip_penalty)
                    stacked = np.vstack(gains)
                    m_best = np.argmax(stacked, axis=0)
                    gain = stacked.max(axis=0)
                total = score + w[ks] + gain
                for k, tot, m, dt in zip(ks.tolist(), total.tolist(), m_best.tolist(),
                                         new.tolist(), strict=True):
                    if tot == -math.inf:
                        continue
                    if m == 0:
                        step, obs = dt, math.log(dt / last)
                    else:  # one bounce bridged: dt = last (r + r^2), solve for r
                        ratio = (-1.0 + math.sqrt(1.0 + 4.0 * dt / last)) / 2.0
                        step, obs = last * ratio * ratio, math.log(ratio)
                    rho_new = obs if math.isnan(rho) else \
                        (1 - p.smoothing) * rho + p.smoothing * obs
                    offer((j, k), (tot, hyp, rho_new, step, (j, k)))

    if not states:
        strongest = int(np.argmax(c.z))
        return Track(np.array([strongest]), float(w[strongest]), _reasons(c, [strongest]))
    best = max((h for hyps in states.values() for h in hyps), key=lambda h: h[0])
    path: list[int] = [best[4][1]]
    hyp = best
    while hyp is not None:
        path.append(hyp[4][0])
        hyp = hyp[1]
    index = sorted(set(path))
    return Track(np.asarray(index, dtype=np.int64), float(best[0]), _reasons(c, index))


def _reasons(c: Candidates, kept: list[int]) -> dict[int, str]:
    """Why each candidate not in ``kept`` was left out."""
    t = c.time_s
    kept_t = t[kept]
    out: dict[int, str] = {}
    kept_set = set(kept)
    for idx in range(len(c)):
        if idx in kept_set:
            continue
        if t[idx] < kept_t[0]:
            out[idx] = "before the roll"
        elif t[idx] > kept_t[-1]:
            out[idx] = "after the roll"
        else:
            k = int(np.searchsorted(kept_t, t[idx])) - 1
            gap = t[idx] - kept_t[k]
            span = kept_t[k + 1] - kept_t[k]
            if gap < 0.25 * span:
                out[idx] = f"echo or double hit ({1e3 * gap:.1f} ms after an impact)"
            else:
                out[idx] = "off the bounce pattern (ring-down or noise)"
    return out
