"""Prior distributions: a number fixes a parameter, a table gives a distribution.

Every distribution is truncated to an interval (the parameter's physical range intersected
with the family's own support) and offers what the samplers need, vectorised and built on
``scipy.special`` ufuncs so the hot path stays cheap: :meth:`Prior.logpdf` (emcee),
:meth:`Prior.ppf` (the unit-cube transform of nested sampling) and :meth:`Prior.sample`
(Monte Carlo propagation, starting points). :meth:`Prior.scaled` converts units
(millimetres to metres) at the config boundary.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import special

_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)


class Prior(ABC):
    """A one-dimensional prior on a parameter."""

    #: True for a fixed value: the parameter is not sampled.
    is_fixed: bool = False

    @abstractmethod
    def logpdf(self, x: ArrayLike) -> NDArray:
        """Log density at ``x`` (−inf outside the support), elementwise."""

    @abstractmethod
    def ppf(self, u: ArrayLike) -> NDArray:
        """Quantile function: maps uniform ``u`` in [0, 1] onto the prior."""

    @abstractmethod
    def scaled(self, factor: float) -> Prior:
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


@dataclass(frozen=True)
class Fixed(Prior):
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
class Truncated(Prior):
    """A continuous family truncated to ``[lower, upper]``.

    Subclasses give the family's log density, CDF and quantile function; this class adds the
    truncation, whose normalising mass is computed once.
    """

    lower: float = -math.inf
    upper: float = math.inf

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

    @abstractmethod
    def _logpdf(self, x: NDArray) -> NDArray: ...

    @abstractmethod
    def _cdf(self, x: ArrayLike) -> NDArray: ...

    @abstractmethod
    def _ppf(self, q: NDArray) -> NDArray: ...

    @abstractmethod
    def _scaled_params(self, factor: float) -> dict[str, float]: ...

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
        object.__setattr__(self, "natural_support", (self.low, self.high))
        super().__post_init__()

    def _logpdf(self, x):
        return np.full(np.shape(x), -math.log(self.high - self.low))

    def _cdf(self, x):
        return np.clip((np.asarray(x, float) - self.low) / (self.high - self.low), 0.0, 1.0)

    def _ppf(self, q):
        return self.low + q * (self.high - self.low)

    def _scaled_params(self, factor):
        return {"low": self.low * factor, "high": self.high * factor}

    def describe(self) -> str:
        return f"uniform(low={self.low:g}, high={self.high:g})"


@dataclass(frozen=True)
class LogUniform(Uniform):
    """Uniform in log x on [low, high] (0 < low < high): scale-free, for jitter and the like."""

    def _logpdf(self, x):
        return -np.log(x) - math.log(math.log(self.high / self.low))

    def _cdf(self, x):
        x = np.clip(np.asarray(x, float), self.low, self.high)
        return np.log(x / self.low) / math.log(self.high / self.low)

    def _ppf(self, q):
        return self.low * (self.high / self.low) ** q

    def describe(self) -> str:
        return f"loguniform(low={self.low:g}, high={self.high:g})"


@dataclass(frozen=True)
class Normal(Truncated):
    """Normal(mu, sigma), truncated to the parameter's physical range."""

    mu: float = 0.0
    sigma: float = 1.0

    def _logpdf(self, x):
        z = (x - self.mu) / self.sigma
        return -0.5 * z * z - math.log(self.sigma) - _LOG_SQRT_2PI

    def _cdf(self, x):
        return special.ndtr((np.asarray(x, float) - self.mu) / self.sigma)

    def _ppf(self, q):
        return self.mu + self.sigma * special.ndtri(q)

    def _scaled_params(self, factor):
        return {"mu": self.mu * factor, "sigma": self.sigma * factor}

    def describe(self) -> str:
        return f"normal(mu={self.mu:g}, sigma={self.sigma:g})"


@dataclass(frozen=True)
class HalfNormal(Truncated):
    """|Normal(0, sigma)|: a scale that is probably small, e.g. a release speed."""

    sigma: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "natural_support", (0.0, math.inf))
        super().__post_init__()

    def _logpdf(self, x):
        z = x / self.sigma
        return -0.5 * z * z - math.log(self.sigma) - _LOG_SQRT_2PI + math.log(2.0)

    def _cdf(self, x):
        return 2.0 * special.ndtr(np.maximum(np.asarray(x, float), 0.0) / self.sigma) - 1.0

    def _ppf(self, q):
        return self.sigma * special.ndtri(0.5 * (1.0 + q))

    def _scaled_params(self, factor):
        return {"sigma": self.sigma * factor}

    def describe(self) -> str:
        return f"halfnormal(sigma={self.sigma:g})"


@dataclass(frozen=True)
class LogNormal(Truncated):
    """exp(Normal(mu, sigma)): mu and sigma are the mean and sd of ln x."""

    mu: float = 0.0
    sigma: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "natural_support", (0.0, math.inf))
        super().__post_init__()

    def _logpdf(self, x):
        log_x = np.log(x)
        z = (log_x - self.mu) / self.sigma
        return -0.5 * z * z - math.log(self.sigma) - _LOG_SQRT_2PI - log_x

    def _cdf(self, x):
        x = np.asarray(x, float)
        with np.errstate(divide="ignore"):
            return special.ndtr((np.log(np.maximum(x, 0.0)) - self.mu) / self.sigma)

    def _ppf(self, q):
        return np.exp(self.mu + self.sigma * special.ndtri(q))

    def _scaled_params(self, factor):
        return {"mu": self.mu + math.log(factor)}

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
        object.__setattr__(self, "natural_support", (self.low, self.high))
        super().__post_init__()

    def _unit(self, x):
        return np.clip((np.asarray(x, float) - self.low) / (self.high - self.low), 0.0, 1.0)

    def _logpdf(self, x):
        y = self._unit(x)
        with np.errstate(divide="ignore", invalid="ignore"):
            return (special.xlogy(self.a - 1.0, y) + special.xlog1py(self.b - 1.0, -y)
                    - special.betaln(self.a, self.b) - math.log(self.high - self.low))

    def _cdf(self, x):
        return special.betainc(self.a, self.b, self._unit(x))

    def _ppf(self, q):
        return self.low + (self.high - self.low) * special.betaincinv(self.a, self.b, q)

    def _scaled_params(self, factor):
        return {"low": self.low * factor, "high": self.high * factor}

    def describe(self) -> str:
        return f"beta(a={self.a:g}, b={self.b:g}, low={self.low:g}, high={self.high:g})"


#: Distribution families by their config name, with required and optional parameters.
FAMILIES: dict[str, tuple[type[Truncated], tuple[str, ...], tuple[str, ...]]] = {
    "uniform": (Uniform, ("low", "high"), ()),
    "loguniform": (LogUniform, ("low", "high"), ()),
    "normal": (Normal, ("mu", "sigma"), ()),
    "halfnormal": (HalfNormal, ("sigma",), ()),
    "lognormal": (LogNormal, ("mu", "sigma"), ()),
    "beta": (Beta, ("a", "b"), ("low", "high")),
}
