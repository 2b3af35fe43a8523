"""Bayesian evidence, for log Bayes factors between models: importance sampling from a
density fitted to the posterior draws, validated by its own Pareto-k diagnostic, and nested
sampling (dynesty, repartitioned onto a reference density placed on the same draws) where
that diagnostic fails or when asked for.

The likelihood and priors are exactly those emcee samples (:class:`LogPosterior`); with
Gaussian noise T0 is marginalised over the same flat window in every model, so that constant
cancels in a Bayes factor.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import special

from drumroll.inference.coordinates import AtomGeometry, SamplerCoordinates
from drumroll.inference.posterior import LogPosterior
from drumroll.inference.psis import pareto_k
from drumroll.stats import student_t_log_norm

#: dynesty's floor for points the physics forbids (it needs a finite number).
_FLOOR = -1e300


@dataclass(frozen=True)
class Evidence:
    """ln Z of one model and its numerical uncertainty.

    Attributes
    ----------
    log_z, log_z_err
        ln Z and the estimate of its error (dynesty's, or the importance weights' spread).
    n_calls
        Likelihood evaluations used.
    ess
        Effective sample size of the importance weights (None for nested sampling).
    method
        ``"nested"`` (dynesty) or ``"importance"``.
    pareto_k
        Importance sampling's diagnostic: the shape k̂ of a generalised Pareto fitted to the
        largest weights (PSIS; Vehtari et al. 2024). Above :data:`PARETO_K_MAX` the weights'
        variance is effectively infinite and neither ln Z nor its error can be trusted.
    """

    log_z: float
    log_z_err: float
    n_calls: int
    ess: float | None = None
    method: str = "nested"
    pareto_k: float | None = None

    @property
    def trusted(self) -> bool:
        """Whether the estimate passes its own diagnostic (nested sampling always does;
        importance sampling when k̂ ≤ :data:`PARETO_K_MAX` and the weights' ESS is at least
        :data:`MIN_IMPORTANCE_ESS` of the draws)."""
        return self.failure is None

    @property
    def failure(self) -> str | None:
        """Why the estimate cannot be trusted, in words (None when it can)."""
        if self.method != "importance":
            return None
        if self.pareto_k is None or not self.pareto_k <= PARETO_K_MAX:
            k = "undefined" if self.pareto_k is None else f"{self.pareto_k:.2f}"
            return (f"importance weights' Pareto k = {k} > {PARETO_K_MAX} "
                    "(a few draws carry the estimate: the proposal misses part of the "
                    "posterior, e.g. a mode the chain never visited)")
        if self.ess is None or not self.ess >= MIN_IMPORTANCE_ESS * self.n_calls:
            return (f"importance weights' ESS {self.ess:.0f} is under "
                    f"{MIN_IMPORTANCE_ESS:.0%} of {self.n_calls} draws")
        return None


#: Largest Pareto k̂ of the importance weights that is trusted (Vehtari et al. 2024: above
#: 0.7 the estimate's error is unbounded in practice; at 20,000 draws their sample-size
#: dependent threshold, 1 − 1/log10(S) = 0.77, is looser).
PARETO_K_MAX = 0.7
#: Smallest importance-weight ESS trusted, as a fraction of the draws: a proposal fitted to
#: the posterior gives 30–60 % in these models; a few percent means it fits badly.
MIN_IMPORTANCE_ESS = 0.05
#: Importance sampling's defensive component (Hesterberg 1995): this share of the proposal is
#: a Student-t this many times wider than the posterior. It bounds the weights wherever the
#: posterior is broader than the kernel density, and sends draws far enough that a mode the
#: chain missed a few sd away is hit and shows in the weights' Pareto k.
DEFENSIVE_WEIGHT = 0.2
DEFENSIVE_INFLATE = 3.0
#: Importance draws, and draws added when their Pareto k is too high to judge (see
#: :func:`importance_evidence`).
IMPORTANCE_DRAWS = 8000
IMPORTANCE_MORE_DRAWS = 12_000
#: Kernels of the importance proposal's density, and their Student-t degrees of freedom.
KERNEL_CENTRES = 600
KERNEL_NU = 5.0
#: What ``[sampler] evidence`` may say.
EVIDENCE_MODES = ("auto", "nested", "none")


#: Tail weight (degrees of freedom) and width (× the posterior's sd) of nested sampling's
#: reference density: heavier-tailed and twice as wide as the posterior, so it covers it.
REFERENCE_NU = 4.0
REFERENCE_INFLATE = 2.0


class ReferenceProblem:
    """The nested-sampling problem repartitioned onto a reference density fitted to the
    posterior (Chen, Feroz & Hobson 2019, "Bayesian posterior repartitioning").

    Nested sampling only ever needs the product L(θ) π(θ): for any proper density π̃,
    Z = ∫ L π dθ = ∫ (L π / π̃) π̃ dθ. Here θ is the sampler coordinate z of
    :class:`SamplerCoordinates` (so L π carries |det ∂x/∂z|), and π̃ is a product of Student-t
    densities (ν = :data:`REFERENCE_NU`) in the whitened coordinates w = C⁻¹(z − m), with m
    the posterior mean and C C^T :data:`REFERENCE_INFLATE`² times the posterior covariance:
    z = m + C w, w_i = t_ν⁻¹(u_i), π̃(z) = Π t_ν(w_i) / |det C|. The integrand, and so Z, is
    exactly the same as under the prior; what changes is the information H = KL(posterior ‖
    reference), about 4–5 nats instead of the prior's 20–30, so dynesty needs ~5× fewer
    iterations, and its random walks move in a space where the posterior is round. A poor
    reference (say, an unconverged chain) costs efficiency, not correctness: the heavy tails
    reach every point of the prior's support.

    Parameters
    ----------
    log_posterior
        The normalised log prior plus the log-likelihood.
    posterior_samples
        Draws from the posterior (any shape ending in ndim), e.g. ``Chain.samples``.
    nu, inflate
        The reference's tail weight and width (× the posterior's sd).
    atoms
        The coordinates' geometry of effects that may be absent (``Chain.atoms``: the
        sampler's, where the posterior is compact).
    """

    def __init__(self, log_posterior: LogPosterior | Callable[[NDArray], float],
                 posterior_samples: NDArray, nu: float = REFERENCE_NU,
                 inflate: float = REFERENCE_INFLATE, atoms: tuple[AtomGeometry, ...] = ()
                 ) -> None:
        self.log_posterior = log_posterior
        space = getattr(log_posterior, "space", None)
        # Any callable of one point (prior × likelihood) is integrated in its own coordinates.
        self.coordinates = (SamplerCoordinates(space, log_posterior.data, atoms)
                            if space is not None else None)
        self.nu = nu
        samples = np.asarray(posterior_samples, float)
        samples = samples.reshape(-1, samples.shape[-1])
        z = self.coordinates.to_sampler(samples) if self.coordinates is not None else samples
        z = z[np.all(np.isfinite(z), axis=1)]
        self.ndim = z.shape[1]
        self.mean = z.mean(axis=0)
        self.chol = np.linalg.cholesky(np.atleast_2d(np.cov(z, rowvar=False)) * inflate**2)
        # Independent Student-t columns, whitened by the Cholesky factor.
        self.log_norm = (self.ndim * student_t_log_norm(nu)
                         - float(np.log(np.diag(self.chol)).sum()))

    def prior_transform(self, u: NDArray) -> NDArray:
        """The unit cube onto the whitened coordinates w (independent Student-t's)."""
        return special.stdtrit(self.nu, u)

    def log_likelihood(self, w: NDArray) -> float:
        """ln(L π |det ∂x/∂z| / π̃) at one w; a finite floor where the prior or the physics
        forbids the point."""
        z = self.mean + self.chol @ w
        if self.coordinates is None:
            value = float(np.asarray(self.log_posterior(z)).reshape(-1)[0])
        else:
            mapped = self.coordinates.to_parameters_one(z)
            if mapped is None:
                return _FLOOR
            x, log_det, impacts = mapped
            space = self.log_posterior.space
            log_prior = space.log_prior_one(x)
            if log_prior == -math.inf:
                return _FLOOR
            value = log_prior + self.log_posterior.log_likelihood_one(x, impacts) + log_det
        if not math.isfinite(value):
            return _FLOOR
        log_reference = self.log_norm - 0.5 * (self.nu + 1.0) * float(
            np.log1p(w * w * (1.0 / self.nu)).sum())
        return value - log_reference


def compute_evidence(log_posterior: LogPosterior, posterior_samples: NDArray, seed: int = 0,
                     n_live: int = 200, dlogz: float = 0.5, sample: str = "rwalk",
                     walks: int | None = None, atoms: tuple[AtomGeometry, ...] = ()
                     ) -> Evidence:
    """ln Z = ln ∫ L(θ) π(θ) dθ by static nested sampling (dynesty) on
    :class:`ReferenceProblem`.

    Parameters
    ----------
    log_posterior
        Supplies the prior, the likelihood (its one-point path) and the dimension.
    posterior_samples
        Posterior draws (emcee's) that place the reference density.
    seed
        Seed of dynesty's generator.
    n_live
        Live points; the error of ln Z falls as 1/sqrt(n_live).
    dlogz
        Stop when the evidence still in the live points is below this (ln Z units); dynesty
        then adds the live points' own contribution, so 0.5 changes ln Z by much less than
        its error.
    sample, walks
        dynesty's sampling method and random-walk length (dynesty's default 20 + ndim when
        None); multi-ellipsoid bounds.
    atoms
        As for :class:`ReferenceProblem`.
    """
    import dynesty  # only when nested sampling runs

    problem = ReferenceProblem(log_posterior, posterior_samples, atoms=atoms)
    sampler = dynesty.NestedSampler(problem.log_likelihood, problem.prior_transform,
                                    problem.ndim, nlive=n_live, bound="multi",
                                    sample=sample, walks=walks,
                                    rstate=np.random.default_rng(seed))
    sampler.run_nested(dlogz=dlogz, print_progress=False)
    results = sampler.results
    return Evidence(log_z=float(results.logz[-1]), log_z_err=float(results.logzerr[-1]),
                    n_calls=int(np.sum(results.ncall)), method="nested")


def importance_evidence(log_posterior: LogPosterior | Callable[[NDArray], NDArray],
                        posterior_samples: NDArray, rng: np.random.Generator,
                        n: int = IMPORTANCE_DRAWS, more: int = IMPORTANCE_MORE_DRAWS,
                        centres: int = KERNEL_CENTRES, nu: float = KERNEL_NU,
                        defensive: float = DEFENSIVE_WEIGHT,
                        defensive_inflate: float = DEFENSIVE_INFLATE,
                        batch: int = 4096, atoms: tuple[AtomGeometry, ...] = ()) -> Evidence:
    """ln Z by importance sampling from a kernel density of the posterior draws.

    The draws are mapped to :class:`SamplerCoordinates` z and whitened by their mean and
    covariance; the proposal q is a kernel density estimate on ``centres`` of them (Student-t
    kernels with ``nu`` degrees of freedom, bandwidth by Scott's rule, h = (4/(d+2))^(1/(d+4))
    M^(−1/(d+4))), mixed with a share ``defensive`` of one Student-t ``defensive_inflate``
    times wider than the draws (Hesterberg 1995's defensive mixture). Then
    Z = E_q[p(x(z)) |det ∂x/∂z| / q(z)] over fresh draws of q. A kernel density follows what a
    single Student-t cannot (the jitter's flat shelf down to its prior's lower end, T0's
    heavy-tailed offset under Student-t noise): on the README's roll a fitted Student-t left
    Pareto k̂ ≈ 0.8 in the small-angle pendulum and the power law; this gives 0.1–0.6.

    The error is the weights' standard error relative to their mean, δ ln Z ≈ sd(w) /
    (mean(w) √S); ``ess`` = (Σw)²/Σw² says how well q matches; the Pareto k̂ of the largest
    weights (:func:`~drumroll.inference.psis.pareto_k`) says whether they have the finite
    variance that error assumes (:attr:`Evidence.trusted`). When k̂ exceeds
    :data:`PARETO_K_MAX` after ``n`` draws, ``more`` are added before it is judged (k̂ is
    itself estimated from the largest 3√S weights, and S matters). A part of the posterior
    the chain never reached (a second mode) shows as a few defensive draws landing there with
    enormous weights: k̂ and the ESS flag it. A part so far away that no draw of q lands there
    cannot be seen by this or any estimator built on the draws; nested sampling's
    heavy-tailed reference reaches it.

    Parameters
    ----------
    log_posterior
        The normalised prior times the likelihood (any callable on ``(batch, ndim)`` works;
        with a ``space`` attribute its sampler coordinates are used).
    posterior_samples
        Draws from the posterior, any shape ending in ndim (e.g. ``Chain.samples``).
    rng
        Source of the proposal draws.
    n, more
        Importance draws, and how many are added when k̂ is too high after ``n``.
    centres, nu
        Kernels of the density and their tail weight.
    defensive, defensive_inflate
        Share and width (× the draws' spread) of the defensive component.
    batch
        Draws per vectorised posterior call.
    atoms
        The coordinates' geometry of effects that may be absent (``Chain.atoms``): in the
        sampler's own coordinates the posterior is compact where in the prior's an absent
        contact time spreads over a 3 ms plateau beside a slab a tenth as wide, which the
        kernels followed too poorly for their own diagnostic (k̂ > 0.7, then nested sampling
        at a hundred times the cost).
    """
    samples = np.asarray(posterior_samples, float)
    samples = samples.reshape(-1, samples.shape[-1])
    space = getattr(log_posterior, "space", None)
    coordinates = (SamplerCoordinates(space, getattr(log_posterior, "data", None), atoms)
                   if space is not None else None)
    z = coordinates.to_sampler(samples) if coordinates is not None else samples
    z = z[np.all(np.isfinite(z), axis=1)]
    ndim = z.shape[1]
    mean = z.mean(axis=0)
    chol = np.linalg.cholesky(np.atleast_2d(np.cov(z, rowvar=False)))
    white = np.linalg.solve(chol, (z - mean).T).T
    kernels = white[rng.choice(len(white), size=min(centres, len(white)), replace=False)]
    n_kernels = len(kernels)
    width = (4.0 / (ndim + 2.0)) ** (1.0 / (ndim + 4.0)) * n_kernels ** (-1.0 / (ndim + 4.0))
    squared_norms = np.einsum("ij,ij->i", kernels, kernels)
    log_t = student_t_log_norm(nu, ndim)
    log_shares = (math.log1p(-defensive) - ndim * math.log(width) - math.log(n_kernels),
                  math.log(defensive) - ndim * math.log(defensive_inflate))
    log_jacobian = float(np.log(np.diag(chol)).sum())

    def log_weights(m: int) -> NDArray:
        """log w of ``m`` fresh draws of q."""
        out = np.empty(m)
        for first in range(0, m, batch):
            size = min(batch, m - first)
            from_defence = rng.random(size) < defensive
            u = rng.standard_normal((size, ndim)) * np.sqrt(nu / rng.chisquare(nu, size))[:, None]
            w = np.where(from_defence[:, None], defensive_inflate * u,
                         kernels[rng.integers(n_kernels, size=size)] + width * u)
            norms = np.einsum("ij,ij->i", w, w)
            # log of each kernel's density at each draw, (size, kernels), in place: the
            # largest arrays of the estimate, and its time.
            terms = w @ kernels.T
            terms *= -2.0
            terms += norms[:, None]
            terms += squared_norms
            np.maximum(terms, 0.0, out=terms)
            terms *= 1.0 / (nu * width**2)
            np.log1p(terms, out=terms)
            terms *= -0.5 * (nu + ndim)
            log_kernel = _logsumexp_rows(terms)
            log_wide = -0.5 * (nu + ndim) * np.log1p(norms / (nu * defensive_inflate**2))
            log_q = (log_t - log_jacobian
                     + np.logaddexp(log_shares[0] + log_kernel, log_shares[1] + log_wide))
            draws = mean + w @ chol.T
            if coordinates is not None:
                x, log_det = coordinates.to_parameters(draws)
            else:
                x, log_det = draws, 0.0
            log_p = np.asarray(log_posterior(x), float) + log_det
            out[first:first + size] = np.where(np.isfinite(log_p), log_p - log_q, -np.inf)
        return out

    log_w = log_weights(n)
    k = pareto_k(log_w)
    if not k <= PARETO_K_MAX and more > 0:
        log_w = np.concatenate([log_w, log_weights(more)])
        k = pareto_k(log_w)
    return weighted_evidence(log_w, k)


def weighted_evidence(log_w: NDArray, k: float | None = None) -> Evidence:
    """ln Z = ln mean(w) of importance weights given by their logarithms (−inf allowed), its
    error sd(w) / (mean(w) √S), their ESS (Σw)²/Σw² and Pareto k̂ (computed here unless
    given)."""
    if k is None:
        k = pareto_k(log_w)
    top = np.max(log_w)
    if not np.isfinite(top):
        return Evidence(log_z=-math.inf, log_z_err=math.inf, n_calls=int(log_w.size), ess=0.0,
                        method="importance", pareto_k=math.inf)
    w = np.exp(log_w - top)
    total = w.sum()
    log_z = top + math.log(total / w.size)
    log_z_err = float(np.std(w) * math.sqrt(w.size) / total)  # sd(w) / (mean(w) sqrt(S))
    return Evidence(log_z=float(log_z), log_z_err=log_z_err, n_calls=int(w.size),
                    ess=float(total**2 / np.sum(w * w)), method="importance", pareto_k=k)


def _logsumexp_rows(terms: NDArray) -> NDArray:
    """log Σ exp along each row of finite ``terms`` (overwritten): scipy's ``logsumexp``
    without its checks for infinities, complex numbers and array backends, which took as long
    as the sum itself."""
    top = terms.max(axis=1)
    terms -= top[:, None]
    np.exp(terms, out=terms)
    return np.log(terms.sum(axis=1)) + top


def choose_evidence(log_posterior: LogPosterior, posterior_samples: NDArray,
                    mode: str = "auto", seed: int = 0, n_live: int = 200,
                    atoms: tuple[AtomGeometry, ...] = ()) -> tuple[Evidence, Evidence | None]:
    """ln Z the way ``[sampler] evidence`` asks, and the other estimate when one was made.

    ``"auto"``: importance sampling (:func:`importance_evidence`, 8,000–20,000 draws); when
    its diagnostic fails (:attr:`Evidence.failure`), nested sampling
    (:func:`compute_evidence`) instead, the importance estimate returned as the second value.
    ``"nested"``: nested sampling, with importance sampling as an independent cross-check.

    Returns
    -------
    used, other
        The estimate to use, and the other one (None when only one was computed).
    """
    if mode not in ("auto", "nested"):
        raise ValueError(f"unknown evidence mode {mode!r}")
    cheap = importance_evidence(log_posterior, posterior_samples,
                                np.random.default_rng(seed + 1), atoms=atoms)
    if mode == "auto" and cheap.trusted:
        return cheap, None
    nested = compute_evidence(log_posterior, posterior_samples, seed=seed, n_live=n_live,
                              atoms=atoms)
    return nested, cheap
