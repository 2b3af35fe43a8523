"""The few numerical routines onset detection needs from scipy, in numpy and :mod:`math`.

Importing :mod:`scipy.special` costs a fifth of a second and :mod:`scipy.optimize` half of
one, more than the detector spends on a short recording; these three are all it used of
them. Each computes what scipy computes (the tests compare them with scipy, which stays a
dependency of the inference):

* :func:`logsumexp`: ``scipy.special.logsumexp`` of a 1-D array, with the largest term taken
  out of the sum as scipy takes it out (so the result is the same to rounding);
* :func:`log_ndtr`: ``scipy.special.log_ndtr``, log Φ(a) to a relative 1e-13 or better from
  ``erfc`` (``log1p`` of the complement above -1) and, below -20, the asymptotic series;
* :func:`cauchy_least_squares`: ``scipy.optimize.least_squares(fun, x0, jac,
  loss="cauchy", method="trf")`` without bounds: the same trust-region reflective
  iteration, step for step, so it stops at the same solution.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

_EPS = float(np.finfo(float).eps)


def logsumexp(a: np.ndarray) -> float:
    """log(sum(exp(a))) of a 1-D array without overflow or underflow.

    As ``scipy.special.logsumexp``: the largest terms (``m`` of them, equal) are kept out of
    the sum, ``log1p(sum(exp(a_i - max)) / m) + log(m) + max``, which is accurate when one
    term dominates; an empty array gives -inf, and where that form is not finite (an
    infinite or NaN term) the plain ``log(sum(exp(a)))`` is returned, as scipy does.
    """
    a = np.asarray(a, dtype=np.float64).ravel()
    if a.size == 0:
        return -math.inf
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        a_max = a.max()
        at_max = a == a_max
        m = np.float64(np.count_nonzero(at_max))  # 0 if the maximum is NaN
        s = np.sum(np.exp(np.where(at_max, -np.inf, a) - a_max))
        s = s if s == 0 else s / m
        out = float(np.log1p(s) + np.log(m) + a_max)
        if not math.isfinite(out):
            out = float(np.log(np.sum(np.exp(a))))
    return out


def _log_ndtr(a: float) -> float:
    """log Φ(a) for one value (:func:`log_ndtr`)."""
    if math.isnan(a):
        return math.nan
    t = a * math.sqrt(0.5)
    if a > -1.0:
        # Φ(a) = 1 - erfc(t)/2: log1p keeps the upper tail's tiny complement exact.
        return math.log1p(-0.5 * math.erfc(t))
    if a > -20.0:
        # Φ(a) = erfc(-t)/2, computed without cancellation (erfc is accurate in its tail).
        return math.log(0.5 * math.erfc(-t))
    # Far lower tail: Φ(a) = φ(a)/(-a) · (1 - 1/a² + 3/a⁴ - 15/a⁶ + …), summed until the
    # terms stop changing the total (Φ itself underflows below about -38).
    log_lhs = -0.5 * a * a - math.log(-a) - 0.5 * math.log(2 * math.pi)
    last, total, numerator, factor, step, sign = 0.0, 1.0, 1.0, 1.0, 1.0 / (a * a), 1
    i = 0
    while abs(last - total) > _EPS:
        i += 1
        last = total
        sign = -sign
        factor *= step
        numerator *= 2 * i - 1
        total += sign * numerator * factor
    return log_lhs + math.log(total)


_log_ndtr_ufunc = np.frompyfunc(_log_ndtr, 1, 1)


def log_ndtr(a: np.ndarray | float) -> np.ndarray | float:
    """log Φ(a), the log of the standard normal distribution function, accurate in both
    tails (``scipy.special.log_ndtr``); elementwise on arrays."""
    if np.ndim(a) == 0:
        return _log_ndtr(float(a))
    return _log_ndtr_ufunc(np.asarray(a, dtype=np.float64)).astype(np.float64)


def cauchy_least_squares(fun: Callable[[np.ndarray], np.ndarray],
                         jac: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, *,
                         ftol: float = 1e-8, xtol: float = 1e-8, gtol: float = 1e-8,
                         max_nfev: int | None = None) -> tuple[np.ndarray, float]:
    """Minimise ``0.5 * sum(log1p(fun(x)**2))`` (Cauchy loss, scale 1) from ``x0``.

    The unbounded trust-region reflective iteration of ``scipy.optimize.least_squares(fun,
    x0, jac=jac, loss="cauchy", method="trf")`` with its defaults (exact trust-region
    subproblem by SVD, unit ``x_scale``, ``max_nfev`` = 100 × parameters), step for step.

    Parameters
    ----------
    fun
        Residuals at ``x`` (1-D, as many as wanted).
    jac
        Their Jacobian ``(residuals, parameters)``.
    x0
        Starting point.
    ftol, xtol, gtol
        Stopping tolerances, as scipy's.
    max_nfev
        Most evaluations of ``fun``.

    Returns
    -------
    x, cost
        The solution and the loss there (scipy's ``sol.x`` and ``sol.cost``).
    """
    x = np.atleast_1d(np.asarray(x0, dtype=float)).copy()
    n = x.size
    max_nfev = 100 * n if max_nfev is None else max_nfev
    f = np.asarray(fun(x), dtype=float)
    if not np.all(np.isfinite(f)):
        raise ValueError("Residuals are not finite in the initial point.")
    nfev = 1
    jmat = np.asarray(jac(x), dtype=float)
    cost = _cauchy_cost(f)
    jmat, fs = _scale_for_cauchy(jmat, f)
    g = jmat.T.dot(fs)
    delta = float(np.linalg.norm(x))
    if delta == 0:
        delta = 1.0
    alpha = 0.0  # Levenberg-Marquardt parameter, carried between steps
    status = None
    while True:
        if np.linalg.norm(g, ord=np.inf) < gtol:
            status = 1
        if status is not None or nfev == max_nfev:
            break
        u, s, vt = np.linalg.svd(jmat, full_matrices=False)
        v = vt.T
        uf = u.T.dot(fs)
        reduction = -1.0
        while reduction <= 0 and nfev < max_nfev:
            step, alpha = _trust_region_step(n, jmat.shape[0], uf, s, v, delta, alpha)
            jstep = jmat.dot(step)
            predicted = -(0.5 * np.dot(jstep, jstep) + np.dot(step, g))
            x_new = x + step
            f_new = np.asarray(fun(x_new), dtype=float)
            nfev += 1
            step_norm = float(np.linalg.norm(step))
            if not np.all(np.isfinite(f_new)):
                delta = 0.25 * step_norm
                continue
            cost_new = _cauchy_cost(f_new)
            reduction = cost - cost_new
            # Trust radius: shrink after a poor step, grow after a good one to its edge.
            if predicted > 0:
                ratio = reduction / predicted
            elif predicted == reduction == 0:
                ratio = 1.0
            else:
                ratio = 0.0
            delta_new = delta
            if ratio < 0.25:
                delta_new = 0.25 * step_norm
            elif ratio > 0.75 and step_norm > 0.95 * delta:
                delta_new = delta * 2.0
            ftol_ok = reduction < ftol * cost and ratio > 0.25
            xtol_ok = step_norm < xtol * (xtol + float(np.linalg.norm(x)))
            if ftol_ok or xtol_ok:
                status = 4 if ftol_ok and xtol_ok else (2 if ftol_ok else 3)
                break
            alpha *= delta / delta_new
            delta = delta_new
        if reduction > 0:
            x, f, cost = x_new, f_new, cost_new
            jmat, fs = _scale_for_cauchy(np.asarray(jac(x), dtype=float), f)
            g = jmat.T.dot(fs)
    return x, float(cost)


def _cauchy_cost(f: np.ndarray) -> float:
    """Half the summed Cauchy loss log(1 + f²)."""
    return 0.5 * np.sum(np.log1p(f**2))


def _scale_for_cauchy(jmat: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Jacobian and residuals rescaled so that the Gauss-Newton model of the Cauchy loss
    is an ordinary least-squares one (scipy's ``scale_for_robust_loss_function``)."""
    z = f**2
    t = 1 + z
    rho1, rho2 = 1 / t, -1 / t**2
    scale = rho1 + 2 * rho2 * f**2
    scale[scale < _EPS] = _EPS
    scale **= 0.5
    return jmat * scale[:, np.newaxis], f * (rho1 / scale)


def _trust_region_step(n: int, m: int, uf: np.ndarray, s: np.ndarray, v: np.ndarray,
                       delta: float, alpha: float, rtol: float = 0.01, max_iter: int = 10
                       ) -> tuple[np.ndarray, float]:
    """The step minimising the linear model within radius ``delta``, and the
    Levenberg-Marquardt parameter that gives it (scipy's ``solve_lsq_trust_region``, by
    More's Newton iteration on the step's norm)."""

    def phi_and_derivative(a: float) -> tuple[float, float]:
        denom = s**2 + a
        p_norm = np.linalg.norm(suf / denom)
        return p_norm - delta, -np.sum(suf**2 / denom**3) / p_norm

    suf = s * uf
    full_rank = s[-1] > _EPS * m * s[0] if m >= n else False
    if full_rank:
        p = -v.dot(uf / s)
        if np.linalg.norm(p) <= delta:
            return p, 0.0
    alpha_upper = np.linalg.norm(suf) / delta
    if full_rank:
        phi, phi_prime = phi_and_derivative(0.0)
        alpha_lower = -phi / phi_prime
    else:
        alpha_lower = 0.0
    if not full_rank and alpha == 0:
        alpha = max(0.001 * alpha_upper, (alpha_lower * alpha_upper)**0.5)
    for _ in range(max_iter):
        if alpha < alpha_lower or alpha > alpha_upper:
            alpha = max(0.001 * alpha_upper, (alpha_lower * alpha_upper)**0.5)
        phi, phi_prime = phi_and_derivative(alpha)
        if phi < 0:
            alpha_upper = alpha
        ratio = phi / phi_prime
        alpha_lower = max(alpha_lower, alpha - ratio)
        alpha -= (phi + delta) * ratio / delta
        if np.abs(phi) < rtol * delta:
            break
    p = -v.dot(suf / (s**2 + alpha))
    p *= delta / np.linalg.norm(p)
    return p, alpha
