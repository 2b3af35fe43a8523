"""Reading one prior from the config: a number (fixed) or a ``{ dist = … }`` table."""

from __future__ import annotations

import math
from typing import Any

from drumroll.config.validate import check_keys, number, string, table
from drumroll.distributions import FAMILIES, Distribution, Fixed, OrZero, Truncated
from drumroll.errors import ConfigError
from drumroll.quantities import Quantity

#: Families whose own parameters bound them; their range must lie inside the physical range.
_BOUNDED = ("uniform", "loguniform", "beta")


def parse_prior(value: Any, spec: Quantity, key: str) -> Distribution:
    """The prior written at ``key`` for the parameter ``spec``, converted to SI units.

    Parameters
    ----------
    value
        A number (the parameter is fixed) or a table with ``dist`` and the family's
        parameters, in the user's units (``spec.unit``).
    spec
        The parameter: its unit and physical range.
    key
        Dotted config path, for messages (e.g. ``"priors.alpha"``).

    Returns
    -------
    Distribution
        A :class:`~drumroll.distributions.Fixed` value or a distribution truncated to the
        physical range, in SI units.
    """
    unit = f" {spec.unit}" if spec.unit else ""
    if not isinstance(value, dict):
        x = number(value, key)
        if not spec.contains(x):
            raise ConfigError(f"{key}: {x:g}{unit} is outside the physical range "
                              f"{spec.range_text()} of the {spec.description}")
        return Fixed(x * spec.to_si)
    value = table(value, key)
    if "dist" not in value:
        raise ConfigError(f"{key}: a distribution needs 'dist' (one of: "
                          f"{', '.join(FAMILIES)}), or give a number to fix the value")
    family = string(value["dist"], f"{key}.dist", FAMILIES)
    cls, required, optional = FAMILIES[family]
    check_keys(value, ("dist", *required, *optional, *(("p_zero",) if spec.may_be_absent
                                                          else ())), key)
    for name in required:
        if name not in value:
            raise ConfigError(f"{key}: the {family} distribution needs {name!r}")
    params = {name: float(number(value[name], f"{key}.{name}"))
              for name in (*required, *optional) if name in value}
    _check_family_parameters(family, params, key)
    if family in _BOUNDED:
        low, high = params.get("low", 0.0), params.get("high", 1.0)
        if low < spec.lower or high > spec.upper:
            raise ConfigError(f"{key}: the range [{low:g}, {high:g}]{unit} goes outside the "
                              f"physical range {spec.range_text()} of the {spec.description}")
    prior: Truncated = cls(**params)
    median_untruncated = prior.median()
    if not spec.contains(median_untruncated):
        raise ConfigError(f"{key}: this {family} prior is centred at {median_untruncated:g}"
                          f"{unit}, outside the physical range {spec.range_text()} of the "
                          f"{spec.description}")
    prior = prior.truncated(spec.lower, spec.upper)
    if not prior.mass > 1e-12:
        raise ConfigError(f"{key}: this prior puts no probability inside the physical range "
                          f"{spec.range_text()}")
    if "p_zero" in value:
        return _or_zero(prior, number(value["p_zero"], f"{key}.p_zero"), key).scaled(spec.to_si)
    return prior.scaled(spec.to_si)


def _or_zero(slab: Truncated, p_zero: float, key: str) -> OrZero:
    """``slab`` with an atom of probability ``p_zero`` at 0 (an effect that may be absent)."""
    if not 0.0 < p_zero < 1.0:
        raise ConfigError(f"{key}.p_zero: the probability of 0 must lie strictly between 0 "
                          f"and 1, got {p_zero:g} (for exactly 0, give the number 0)")
    if slab.support[0] != 0.0:
        raise ConfigError(f"{key}.p_zero: an atom at 0 needs a distribution that starts at 0 "
                          f"(this one starts at {slab.support[0]:g})")
    return OrZero(slab, p_zero=p_zero)


def _check_family_parameters(family: str, params: dict[str, float], key: str) -> None:
    """Scale parameters positive; ranges neither empty nor inverted."""
    for name in ("sigma", "a", "b"):
        if name in params and not params[name] > 0:
            raise ConfigError(f"{key}.{name}: must be positive, got {params[name]:g}")
    if "low" in params or "high" in params:
        low, high = params.get("low", 0.0), params.get("high", 1.0)
        if not low < high:
            word = "empty" if low == high else "inverted"
            raise ConfigError(f"{key}: the range is {word} (low = {low:g}, high = {high:g}); "
                              "low must be less than high")
        if family == "loguniform" and not low > 0:
            raise ConfigError(f"{key}.low: a loguniform range must start above 0, got {low:g}")
    if family == "lognormal" and not math.isfinite(math.exp(min(params["mu"], 700.0))):
        raise ConfigError(f"{key}.mu: too large")
