"""The prior families: a number fixes a parameter, a table gives a distribution.

One base module, below both the config (which parses ``[priors]`` into these) and inference
(which evaluates them), so neither imports the other.

Every distribution is truncated to an interval (the parameter's physical range intersected
with the family's own support) and offers what the samplers need, vectorised and built on
``scipy.special`` ufuncs so the hot path stays cheap: :meth:`Distribution.logpdf` (emcee),
:meth:`Distribution.ppf` (the unit-cube transform of nested sampling) and
:meth:`Distribution.sample` (Monte Carlo propagation, starting points).
:meth:`Distribution.scaled` converts units (millimetres to metres) at the config boundary.

Each family's density, CDF and quantile function are written once, as static kernels that
take the family's parameters as arguments (:attr:`Truncated.params` names them): a prior
calls them with its own parameters, and :class:`~drumroll.inference.prior_table.PriorTable`
calls them once per family with the parameters of all its columns as vectors.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


class Distribution(ABC):
    """A one-dimensional prior on a parameter (a fixed value or a truncated family)."""

    #: True for a fixed value: the parameter is not sampled.
    is_fixed: bool = False

    @abstractmethod
    def logpdf(self, x: ArrayLike) -> NDArray:
        """Log density at ``x`` (−inf outside the support), elementwise."""

    @abstractmethod
    def ppf(self, u: ArrayLike) -> NDArray:
        """Quantile function: maps uniform ``u`` in [0, 1] onto the prior."""

    @abstractmethod
    def scaled(self, factor: float) -> Distribution:
        """The distribution of ``factor × X`` (``factor > 0``): a change of units."""

    @abstractmethod
    def describe(self) -> str:
        """A short human description, e.g. ``normal(mu=131, sigma=2)``."""

    @property
    @abstractmethod
    def support(self) -> tuple[float, float]:
        """The closed interval outside which the density is zero."""

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...]) -> NDArray:
        """``size`` independent draws, by inverse-CDF sampling."""
        return self.ppf(rng.random(size))

    def median(self) -> float:
        """The prior median: a representative value for checks and defaults."""
        return float(self.ppf(0.5))

    def widened(self, factor: float) -> Distribution | None:
        """The same family ``factor`` times as wide (a prior-width sensitivity check), or None
        where the family has no width to scale (a fixed value, a beta).

        A range keeps its lower end (the physical one, for the scale parameters priors are
        written on) and scales its length, in log x for a log-uniform; a normal, half-normal
        or log-normal scales its σ. The physical truncation is kept.
        """
        return None


@dataclass(frozen=True)
class Fixed(Distribution):
    """A parameter held at ``value``."""

    value: float
    is_fixed: bool = field(default=True, init=False)

    def logpdf(self, x: ArrayLike) -> NDArray:
        return np.where(np.asarray(x) == self.value, 0.0, -np.inf)

    def ppf(self, u: ArrayLike) -> NDArray:
        return np.full(np.shape(u), self.value)

    def scaled(self, factor: float) -> Fixed:
        return Fixed(self.value * factor)

    def describe(self) -> str:
        return f"{self.value:g} (fixed)"

    @property
    def support(self) -> tuple[float, float]:
        return (self.value, self.value)


@dataclass(frozen=True)
class Truncated(Distribution):
    """A continuous family truncated to ``[lower, upper]``.

    Subclasses give the family's log density, CDF and quantile function as static kernels of
    the family's parameters (:meth:`density`, :meth:`cdf`, :meth:`quantile`, with
    :attr:`params` naming those parameters in order); this class adds the truncation, whose
    normalising mass is computed once.
    """

    lower: float = -math.inf
    upper: float = math.inf

    #: The family's parameters, in the order its kernels take them.
    params: tuple[str, ...] = field(default=(), init=False, repr=False)

    #: Whether the density is the same everywhere inside the support (evaluated once).
    flat: bool = field(default=False, init=False, repr=False)

    #: The family's own support, before truncation.
    natural_support: tuple[float, float] = field(default=(-math.inf, math.inf), init=False,
                                                 repr=False)

    def __post_init__(self) -> None:
        lo = max(self.lower, self.natural_support[0])
        hi = min(self.upper, self.natural_support[1])
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        cdf_lo, cdf_hi = float(self._cdf(lo)), float(self._cdf(hi))
        object.__setattr__(self, "_cdf_lo", cdf_lo)
        object.__setattr__(self, "_mass", cdf_hi - cdf_lo)
        object.__setattr__(self, "_log_mass", math.log(cdf_hi - cdf_lo)
                           if cdf_hi > cdf_lo else -math.inf)
        # A point inside the support, substituted outside it so the density never warns.
        object.__setattr__(self, "_inside", float(self.ppf(0.5)) if cdf_hi > cdf_lo else lo)

    @property
    def mass(self) -> float:
        """Probability of the untruncated family inside ``[lower, upper]``."""
        return self._mass

    @staticmethod
    @abstractmethod
    def density(x: NDArray, *params: ArrayLike) -> NDArray:
        """The family's log density (untruncated) at ``x`` inside its support."""

    @staticmethod
    @abstractmethod
    def cdf(x: ArrayLike, *params: ArrayLike) -> NDArray:
        """The family's CDF (untruncated)."""

    @staticmethod
    @abstractmethod
    def quantile(q: NDArray, *params: ArrayLike) -> NDArray:
        """The family's quantile function (untruncated)."""

    @abstractmethod
    def _scaled_params(self, factor: float) -> dict[str, float]: ...

    @property
    def param_values(self) -> tuple[float, ...]:
        """This prior's values of :attr:`params`."""
        return tuple(getattr(self, name) for name in self.params)

    @property
    def log_mass(self) -> float:
        """log of :attr:`mass`: the truncation's normalising constant."""
        return self._log_mass

    def _logpdf(self, x: NDArray) -> NDArray:
        return self.density(x, *self.param_values)

    def _cdf(self, x: ArrayLike) -> NDArray:
        return self.cdf(x, *self.param_values)

    def _ppf(self, q: NDArray) -> NDArray:
        return self.quantile(q, *self.param_values)

    def logpdf(self, x: ArrayLike) -> NDArray:
        x = np.asarray(x, float)
        inside = (x >= self.lower) & (x <= self.upper)
        if inside.all():  # the usual case inside a sampler: no substitution needed
            return self._logpdf(x) - self._log_mass
        return np.where(inside, self._logpdf(np.where(inside, x, self._inside))
                        - self._log_mass, -np.inf)

    def ppf(self, u: ArrayLike) -> NDArray:
        q = self._cdf_lo + np.asarray(u, float) * self._mass
        return np.clip(self._ppf(q), self.lower, self.upper)

    def scaled(self, factor: float) -> Truncated:
        if not factor > 0:
            raise ValueError("a change of units needs a positive factor")
        return replace(self, lower=self.lower * factor, upper=self.upper * factor,
                       **self._scaled_params(factor))

    @property
    def support(self) -> tuple[float, float]:
        return (self.lower, self.upper)

    def truncated(self, lower: float, upper: float) -> Truncated:
        """The same family truncated further to ``[lower, upper]``."""
        return replace(self, lower=max(lower, self.lower), upper=min(upper, self.upper))


@dataclass(frozen=True)
class Uniform(Truncated):
    """Uniform on [low, high]."""

    low: float = 0.0
    high: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", ("low", "high"))
        object.__setattr__(self, "flat", type(self) is Uniform)
        object.__setattr__(self, "natural_support", (self.low, self.high))
        super().__post_init__()

    @staticmethod
    def density(x, low, high):
        return -np.log(high - low) + np.zeros_like(x)

    @staticmethod
    def cdf(x, low, high):
        return np.clip((np.asarray(x, float) - low) / (high - low), 0.0, 1.0)

    @staticmethod
    def quantile(q, low, high):
        return low + q * (high - low)

    def _scaled_params(self, factor):
        return {"low": self.low * factor, "high": self.high * factor}

    def widened(self, factor: float) -> Uniform:
        high = self.quantile(factor, self.low, self.high)
        return replace(self, high=float(high), upper=math.inf)

    def describe(self) -> str:
        return f"uniform(low={self.low:g}, high={self.high:g})"


@dataclass(frozen=True)
class LogUniform(Uniform):
    """Uniform in log x on [low, high] (0 < low < high): scale-free, for jitter and the like."""

    @staticmethod
    def density(x, low, high):
        return -np.log(x) - np.log(np.log(high / low))

    @staticmethod
    def cdf(x, low, high):
        x = np.clip(np.asarray(x, float), low, high)
        return np.log(x / low) / np.log(high / low)

    @staticmethod
    def quantile(q, low, high):
        return low * (high / low) ** q

    def describe(self) -> str:
        return f"loguniform(low={self.low:g}, high={self.high:g})"


@dataclass(frozen=True)
class Normal(Truncated):
    """Normal(mu, sigma), truncated to the parameter's physical range."""

    mu: float = 0.0
    sigma: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", ("mu", "sigma"))
        super().__post_init__()

    @staticmethod
    def density(x, mu, sigma):
        z = (x - mu) / sigma
        with np.errstate(over="ignore"):  # z² past 1e308: a density of −inf, as it should be
            return -0.5 * z * z - np.log(sigma) - _LOG_SQRT_2PI

    @staticmethod
    def cdf(x, mu, sigma):
        return special.ndtr((np.asarray(x, float) - mu) / sigma)

    @staticmethod
    def quantile(q, mu, sigma):
        return mu + sigma * special.ndtri(q)

    def _scaled_params(self, factor):
        return {"mu": self.mu * factor, "sigma": self.sigma * factor}

    def widened(self, factor: float) -> Truncated:
        return replace(self, sigma=self.sigma * factor)

    def describe(self) -> str:
        return f"normal(mu={self.mu:g}, sigma={self.sigma:g})"


@dataclass(frozen=True)
class HalfNormal(Truncated):
    """|Normal(0, sigma)|: a scale that is probably small, e.g. a release speed."""

    sigma: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", ("sigma",))
        object.__setattr__(self, "natural_support", (0.0, math.inf))
        super().__post_init__()

    @staticmethod
    def density(x, sigma):
        z = x / sigma
        # A scale sampled in its logarithm reaches x ~ 1e200 on a long jump: z² overflows to
        # a density of −inf, as it should be.
        with np.errstate(over="ignore"):
            return -0.5 * z * z - np.log(sigma) - _LOG_SQRT_2PI + math.log(2.0)

    @staticmethod
    def cdf(x, sigma):
        return 2.0 * special.ndtr(np.maximum(np.asarray(x, float), 0.0) / sigma) - 1.0

    @staticmethod
    def quantile(q, sigma):
        return sigma * special.ndtri(0.5 * (1.0 + q))

    def _scaled_params(self, factor):
        return {"sigma": self.sigma * factor}

    def widened(self, factor: float) -> Truncated:
        return replace(self, sigma=self.sigma * factor)

    def describe(self) -> str:
        return f"halfnormal(sigma={self.sigma:g})"


@dataclass(frozen=True)
class LogNormal(Truncated):
    """exp(Normal(mu, sigma)): mu and sigma are the mean and sd of ln x."""

    mu: float = 0.0
    sigma: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", ("mu", "sigma"))
        object.__setattr__(self, "natural_support", (0.0, math.inf))
        super().__post_init__()

    @staticmethod
    def density(x, mu, sigma):
        log_x = np.log(x)
        z = (log_x - mu) / sigma
        return -0.5 * z * z - np.log(sigma) - _LOG_SQRT_2PI - log_x

    @staticmethod
    def cdf(x, mu, sigma):
        x = np.asarray(x, float)
        with np.errstate(divide="ignore"):
            return special.ndtr((np.log(np.maximum(x, 0.0)) - mu) / sigma)

    @staticmethod
    def quantile(q, mu, sigma):
        return np.exp(mu + sigma * special.ndtri(q))

    def _scaled_params(self, factor):
        return {"mu": self.mu + math.log(factor)}

    def widened(self, factor: float) -> Truncated:
        return replace(self, sigma=self.sigma * factor)

    def describe(self) -> str:
        return f"lognormal(mu={self.mu:g}, sigma={self.sigma:g})"


@dataclass(frozen=True)
class Beta(Truncated):
    """Beta(a, b) stretched onto [low, high] (default [0, 1])."""

    a: float = 1.0
    b: float = 1.0
    low: float = 0.0
    high: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "params", ("a", "b", "low", "high"))
        object.__setattr__(self, "natural_support", (self.low, self.high))
        super().__post_init__()

    @staticmethod
    def _unit(x, low, high):
        return np.clip((np.asarray(x, float) - low) / (high - low), 0.0, 1.0)

    @staticmethod
    def density(x, a, b, low, high):
        y = Beta._unit(x, low, high)
        with np.errstate(divide="ignore", invalid="ignore"):
            return (special.xlogy(a - 1.0, y) + special.xlog1py(b - 1.0, -y)
                    - special.betaln(a, b) - np.log(high - low))

    @staticmethod
    def cdf(x, a, b, low, high):
        return special.betainc(a, b, Beta._unit(x, low, high))

    @staticmethod
    def quantile(q, a, b, low, high):
        return low + (high - low) * special.betaincinv(a, b, q)

    def _scaled_params(self, factor):
        return {"low": self.low * factor, "high": self.high * factor}

    def describe(self) -> str:
        return f"beta(a={self.a:g}, b={self.b:g}, low={self.low:g}, high={self.high:g})"


@dataclass(frozen=True)
class OrZero(Distribution):
    """Exactly 0 with probability ``p_zero``, else drawn from ``slab``: an effect that may be
    absent (a spike-and-slab prior), such as the contact time of an impact that is
    instantaneous.

    Samplers need a density, not an atom, so the parameter is sampled as a coordinate u whose
    negative half stands for the atom: u is uniform on [−``width``, 0) with mass ``p_zero``
    and follows the slab (times 1 − ``p_zero``) on [0, ∞); the parameter is
    :meth:`parameter_of` (u) = max(u, 0). The likelihood is the same everywhere on u < 0, so the
    posterior mass there is the posterior probability of "absent", weighed against "present"
    by the data's evidence, and the evidence integrates over both. ``width`` changes nothing
    but how the sampler moves (the slab's own width, by default).

    A plain slab starting at 0 cannot say "absent": where the data cannot tell 0 from a small
    value, its posterior piles against 0 and its mean sits inside the slab, and every
    parameter correlated with it is pulled along (``benchmarks/scatter_coverage.py``: α one
    sd low in rolls with instantaneous impacts under U(0, 3 ms)).
    """

    slab: Truncated
    p_zero: float = 0.5
    width: float = 0.0

    def __post_init__(self) -> None:
        if self.slab.support[0] != 0.0:
            raise ValueError("the slab of an atom at 0 must start at 0")
        if not 0.0 < self.p_zero < 1.0:
            raise ValueError("p_zero must lie strictly between 0 and 1")
        if not self.width > 0.0:
            low, high = self.slab.support
            width = high - low if math.isfinite(high) else float(self.slab.ppf(0.99))
            object.__setattr__(self, "width", width)

    @staticmethod
    def parameter_of(u: ArrayLike) -> NDArray:
        """The parameter of a sampled coordinate: 0 for u < 0 (the atom), u otherwise."""
        return np.maximum(u, 0.0)

    def logpdf(self, x: ArrayLike) -> NDArray:
        x = np.asarray(x, float)
        absent = math.log(self.p_zero / self.width)
        with np.errstate(divide="ignore", invalid="ignore"):
            present = math.log1p(-self.p_zero) + self.slab.logpdf(np.maximum(x, 0.0))
        return np.where(x < 0.0, np.where(x >= -self.width, absent, -np.inf), present)

    def ppf(self, u: ArrayLike) -> NDArray:
        u = np.asarray(u, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            slab = self.slab.ppf(np.clip((u - self.p_zero) / (1.0 - self.p_zero), 0.0, 1.0))
        return np.where(u < self.p_zero, self.width * (u / self.p_zero - 1.0), slab)

    def scaled(self, factor: float) -> OrZero:
        return replace(self, slab=self.slab.scaled(factor), width=self.width * factor)

    def widened(self, factor: float) -> OrZero | None:
        slab = self.slab.widened(factor)
        return None if slab is None else replace(self, slab=slab)

    def describe(self) -> str:
        return f"{self.slab.describe()} or 0 with probability {self.p_zero:g}"

    @property
    def support(self) -> tuple[float, float]:
        return (-self.width, self.slab.support[1])


#: Distribution families by their config name, with required and optional parameters.
FAMILIES: dict[str, tuple[type[Truncated], tuple[str, ...], tuple[str, ...]]] = {
    "uniform": (Uniform, ("low", "high"), ()),
    "loguniform": (LogUniform, ("low", "high"), ()),
    "normal": (Normal, ("mu", "sigma"), ()),
    "halfnormal": (HalfNormal, ("sigma",), ()),
    "lognormal": (LogNormal, ("mu", "sigma"), ()),
    "beta": (Beta, ("a", "b"), ("low", "high")),
}
