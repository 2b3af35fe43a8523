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

The same law also says where the roll ends (:func:`until_the_law_breaks`): each onset is
predicted from the onsets before it alone, and the roll is reported up to the first one
the prediction rules out. That is usually a faint bounce whose change point is its sound's
build-up, a few ms late, with nothing in the waveform to say so; the ones after it could
not be trusted either.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from drumroll.onsets.candidates import refine_window
from drumroll.onsets.refine import Prior

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


def _law(p: np.ndarray, n: int, quadratic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Onset times of the law with parameters ``p`` (t0, a, b[, c]) and their Jacobian."""
    i = np.arange(n - 1, dtype=float)
    c = p[3] if quadratic else 0.0
    f = np.exp(p[1] + p[2] * i + c * i * i)
    t = p[0] + np.concatenate(([0.0], np.cumsum(f)))
    cols = [np.ones(n), t - p[0], np.concatenate(([0.0], np.cumsum(i * f)))]
    if quadratic:
        cols.append(np.concatenate(([0.0], np.cumsum(i * i * f))))
    return t, np.stack(cols, axis=1)


def _robust_fit(times: np.ndarray, weight: np.ndarray, p0: list[float], quadratic: bool
                ) -> tuple[np.ndarray, float]:
    """Cauchy-loss fit of the law; returns the parameters and the loss (half the Cauchy
    deviance of the residuals scaled by ``1 / weight``)."""
    n = times.size

    def resid(p):
        return (_law(p, n, quadratic)[0] - times) / weight

    def jac(p):
        return _law(p, n, quadratic)[1] / weight[:, None]

    sol = optimize.least_squares(resid, p0, jac=jac, loss="cauchy", method="trf")
    return sol.x, float(sol.cost)


@dataclass(frozen=True)
class _LawFit:
    """A fitted law: parameters, whether the drift term is in, the roll's scatter, the
    squared timing uncertainties it was fitted with and the residual degrees of freedom."""

    params: np.ndarray
    quadratic: bool
    scatter: float
    sig2: np.ndarray
    dof: int

    def at(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The law's first ``n`` onset times and their Jacobian."""
        return _law(self.params, n, self.quadratic)

    def covariance(self) -> np.ndarray | None:
        """Covariance of the parameters (linearised weighted least squares)."""
        jmat = self.at(self.sig2.size)[1]
        jw = jmat / np.sqrt(self.sig2 + self.scatter**2)[:, None]
        try:
            return np.linalg.inv(jw.T @ jw)
        except np.linalg.LinAlgError:
            return None


def _fit_law(times: np.ndarray, sigmas: np.ndarray, start: _LawFit | None = None
             ) -> _LawFit | None:
    """Robust fit of the flight law; None if the flights do not shrink roughly geometrically.
    ``start``, a fit to fewer onsets of the same roll, is where the search starts.

    Each onset's residual is scaled by its own uncertainty combined with the roll's scatter
    (measured as the MAD of the residuals, corrected for the parameters fitted); the loss is
    Cauchy's, so a mistimed onset hardly pulls. The drift of the ratio (``c``) is kept only
    when it pays for itself by the Bayesian information criterion on the Cauchy deviance.
    """
    n = times.size
    flights = np.diff(times)
    if n < 4 or np.any(flights <= 0):
        return None
    ratio = float(np.median(flights[1:] / flights[:-1]))
    if not 0.0 < ratio < 1.5:
        return None
    sig2 = np.square(np.maximum(sigmas, 1e-6))
    scatter = 0.0 if start is None else start.scatter
    p = np.array([times[0], np.log(flights[0]), np.log(ratio)]) if start is None \
        else start.params
    quadratic = False
    # The scatter weights the fit, the fit sets the scatter; a warm start has the former.
    for _ in range(1 if start is not None else 2):
        weight = np.sqrt(sig2 + scatter**2)
        p, cost = _robust_fit(times, weight, list(p[:3]), False)
        quadratic = False
        if n >= _MIN_ONSETS:
            p2, cost2 = _robust_fit(times, weight, [*p[:3], 0.0], True)
            if 2.0 * (cost - cost2) > np.log(n):
                p, quadratic = p2, True
        r = times - _law(p, n, quadratic)[0]
        dof = max(n - p.size, 1)
        scatter = _MAD_TO_SIGMA * float(np.median(np.abs(r))) * np.sqrt(n / dof)
    scatter = max(scatter, float(np.sqrt(np.median(sig2))))
    return _LawFit(p, quadratic, scatter, sig2, dof)


def fit_sequence(times: np.ndarray, sigmas: np.ndarray) -> SequenceFit | None:
    """Robust fit of the flight law to onset ``times`` with timing uncertainties ``sigmas``
    (see :func:`_fit_law`). Returns None for fewer than :data:`_MIN_ONSETS` onsets or
    flights that do not shrink."""
    if times.size < _MIN_ONSETS:
        return None
    fit = _fit_law(times, sigmas)
    cov = None if fit is None else fit.covariance()
    if cov is None:
        return None
    law, jmat = fit.at(times.size)
    var_fit = np.einsum("ij,jk,ik->i", jmat, cov, jmat)
    return SequenceFit(law, np.sqrt(fit.scatter**2 + np.maximum(var_fit, 0.0)), fit.dof)


def until_the_law_breaks(times: np.ndarray, *columns: np.ndarray, keep_at_least: int = 4,
                         false_alarm: float = 0.01) -> tuple[np.ndarray, ...]:
    """The roll up to (not including) the first onset that the law of the onsets before it
    does not predict.

    Onset ``j`` is predicted from onsets ``0 ... j - 1`` alone: the smooth law fitted to
    them (:func:`_fit_law`) extrapolated one bounce, with a Student t predictive (the
    roll's scatter so far, the fit's own uncertainty there and the onset's ``sigma_s``;
    degrees of freedom those of the scatter). A bouncer cannot leave its law between two
    bounces, so an onset outside the predictive's central ``1 - false_alarm`` is a
    different sound, a bounce timed at its sound's build-up rather than its start, or the
    next bounce after a missed one: either way what follows cannot be numbered and timed
    with confidence, and the roll is reported up to it. Few onsets make a wide predictive,
    so the test bites only where the roll so far pins the law down.

    ``false_alarm`` is the chance that a roll which does follow its law (with Gaussian
    scatter) is cut anywhere: each onset is tested at ``false_alarm`` over the number of
    tests (Bonferroni), so a long roll is not cut more often than a short one.
    ``columns[-1]`` must be ``sigma_s``.
    """
    sigma = columns[-1]
    first = max(keep_at_least, 4)
    level = false_alarm / max(times.size - first, 1)
    cut = stats.t.ppf(1.0 - 0.5 * level, np.arange(1, times.size + 1))
    fit = None
    for j in range(first, times.size):
        fit = _fit_law(times[:j], sigma[:j], fit)
        if fit is None:
            continue
        law, jmat = fit.at(j + 1)
        # The classical prediction interval of least squares, exact for Gaussian scatter:
        # the onsets so far passed this test, so their plain residual variance is the
        # scale (the robust one of the fit is biased low on a few residuals), floored at
        # their typical timing uncertainty.
        typical = float(np.median(fit.sig2))
        s2 = max(float(np.sum((times[:j] - law[:j]) ** 2)) / fit.dof, typical)
        try:
            cov = s2 * np.linalg.inv(jmat[:j].T @ jmat[:j])
        except np.linalg.LinAlgError:
            continue
        row = jmat[j]
        # The scatter already holds a typical onset's timing error; only an excess of this
        # onset's own widens the predictive further.
        excess = max(sigma[j] ** 2 - typical, 0.0)
        sd = np.sqrt(s2 + max(float(row @ cov @ row), 0.0) + excess)
        if abs(times[j] - law[j]) > cut[fit.dof - 1] * sd:
            return tuple(col[:j] for col in (times, *columns))
    return (times, *columns)


def retime(times: np.ndarray, sigmas: np.ndarray, x: np.ndarray, start: int,
           sample_rate: int, ba: tuple[np.ndarray, np.ndarray], settle: int, *,
           outlier: float = 0.05) -> tuple[np.ndarray, ...] | None:
    """Place every onset at its posterior given the roll's law (see the module docstring).

    Parameters
    ----------
    times, sigmas
        The roll's onsets (seconds, absolute) and their timing uncertainties.
    x, start
        Raw samples around the roll; ``x[0]`` is absolute sample ``start``.
    sample_rate, ba, settle
        As :func:`~.candidates.refine_window` needs them (the wide high-pass, its settling).
    outlier
        Prior probability that a bounce is off the law by more than its scatter.

    Returns
    -------
    tuple of numpy.ndarray or None
        Time, amplitude, SNR and sigma columns, or None when no law could be fitted.
    """
    law = fit_sequence(times, sigmas)
    if law is None:
        return None
    sr = sample_rate
    margin = round(0.001 * sr)
    out = []
    for j, (t, mu, sd) in enumerate(zip(times, law.time_s, law.sd_s, strict=True)):
        reach = max(4.0 * sd * sr, margin)
        lo = round(min(t, mu) * sr - reach)
        hi = round(max(t, mu) * sr + reach)
        # The whitening reference: up to 6 ms before the searched stretch, never reaching
        # back past the middle of the flight before it.
        flight = times[j] - times[j - 1] if j else 0.05
        fit = max(64, min(round(0.006 * sr), round(0.5 * flight * sr) - (hi - lo) // 2))
        guess = (lo + hi) // 2
        prior = Prior(mean=mu * sr, sd=sd * sr, outlier=outlier, width=hi - lo,
                      dof=law.dof)
        r = refine_window(x, start, guess, sr, ba, settle, pre=guess - lo + fit,
                          post=2 * margin, search=guess - lo, search_after=hi - guess,
                          prior=prior)
        out.append((r.sample / sr, r.amplitude, r.snr_db, r.sigma_s))
    return tuple(np.asarray(col, dtype=float) for col in zip(*out, strict=True))
