"""Numbers as a physicist writes them: ``0.86 ± 0.01``, the value rounded to its error."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from drumroll.inference.results import STRAY_KEY
from drumroll.reporting.document import Content, Number, content, number, plain_text, pointer

if TYPE_CHECKING:
    from drumroll.inference.results import ModelAverage, NumberingAverage, ParameterSummary


def error_decimals(err: float, significant: int | None = None) -> int:
    """Decimal places that keep one or two significant digits of ``err``.

    Parameters
    ----------
    err
        The uncertainty (> 0).
    significant
        Significant digits of the error to keep; by default two when its leading digit is 1
        or 2 (so 0.014 stays 0.014, not 0.01), otherwise one (the Particle Data Group habit).

    Returns
    -------
    int
        Number of decimals (negative to round to tens, hundreds, …).
    """
    exponent = math.floor(math.log10(abs(err)))
    if significant is None:
        leading = round(abs(err) / 10.0**exponent, 6)  # 0.3 must not read as 2.999…
        significant = 2 if leading < 3 else 1
    return significant - 1 - exponent


#: Relative size below which an error is floating-point round-off (about 4500 ulp).
_ROUND_OFF = 1e-12


def format_value_error(value: float, err: float, significant: int | None = None,
                       unit: str = "") -> str:
    """``value ± err`` with the error rounded to one or two significant digits.

    >>> format_value_error(0.2509, 0.0061)
    '0.251 ± 0.006'
    >>> format_value_error(0.8612, 0.0123)
    '0.861 ± 0.012'
    >>> format_value_error(131.2, 2.0, significant=1, unit="mm")
    '131 ± 2 mm'

    An error at the level of floating-point round-off of the value (the spread of a fixed
    value computed by different routes) is no error: the value is given alone.
    """
    suffix = f" {unit}" if unit else ""
    if not math.isfinite(value):
        return f"{value}{suffix}"
    if not (math.isfinite(err) and err > _ROUND_OFF * abs(value)):
        return f"{value:.4g}{suffix}"
    decimals = error_decimals(err, significant)
    if decimals > 0:
        return f"{value:.{decimals}f} ± {err:.{decimals}f}{suffix}"
    step = 10.0 ** (-decimals)
    return f"{round(value / step) * step:.0f} ± {round(err / step) * step:.0f}{suffix}"


def value_error_number(value: float, err: float, source: str | None = None,
                       error_source: str | None = None, significant: int | None = None
                       ) -> Number:
    """``value ± err`` as :func:`format_value_error` writes it, as a report's
    :class:`~drumroll.reporting.document.Number` (the error kept only where it is shown)."""
    text = format_value_error(value, err, significant)
    shown = " ± " in text
    return number(value, text, source, error=err if shown else None,
                  error_source=error_source if shown else None)


def _alpha_and_t_b(parameters: dict[str, ParameterSummary], place: str) -> Content:
    """``α = 0.9002 ± 0.0004, t_B = 0.19908 ± 0.00010 s`` of an average's ``parameters``,
    each number naming its place (``place``: the average's key in ``summary.json``)."""
    parts: list[Content] = []
    for name, symbol, unit in (("alpha", "α", ""), ("t_b", "t_B", " s")):
        p = parameters.get(name)
        if p is not None and p.mean is not None and p.sd is not None:
            source = pointer(place, "parameters", name)
            parts.append((f"{symbol} = ", value_error_number(
                p.mean, p.sd, f"{source}/mean", f"{source}/sd"), unit))
    return content(*[(", " if i else "", part) for i, part in enumerate(parts)])


def model_average_content(average: ModelAverage | None) -> Content | None:
    """The stacking-weighted α and t_B (:class:`~drumroll.inference.results.ModelAverage`)
    as report content, each number naming its place in ``summary.json``; None without
    one."""
    if average is None or not average.parameters:
        return None
    weights: list[Content] = [
        (f"{m} ", number(w, f"{w:.2f}", pointer("model_average", "weights", m)))
        for m, w in average.weights.items()]
    listed = content(*[(", " if i else "", part) for i, part in enumerate(weights)])
    return content(_alpha_and_t_b(average.parameters, "model_average"),
                   " (stacking weights: ", listed, ")")


def numbering_average_content(average: NumberingAverage | None) -> Content | None:
    """The main model's α and t_B averaged over the first onset's numberings
    (:class:`~drumroll.inference.results.NumberingAverage`), with each numbering's weight,
    as report content; None without one."""
    if average is None or not average.parameters:
        return None
    weights: list[Content] = [
        (f"{numbering_name(m)} ", number(w, f"{w:.2f}",
                                          pointer("numbering_average", "probabilities", m)))
        for m, w in average.probabilities.items()]
    listed = content(*[(", " if i else "", part) for i, part in enumerate(weights)])
    return content(_alpha_and_t_b(average.parameters, "numbering_average"),
                   " (weights: ", listed, ")")


def numbering_name(key: str) -> str:
    """A numbering in words from its key in ``summary.json``: ``1 missed`` (impacts missed
    before the first onset), ``first onset no impact`` ("stray")."""
    return "first onset no impact" if key == STRAY_KEY else f"{key} missed"


def first_onset_as(key: str) -> str:
    """What a numbering takes the first onset for, from its key: ``impact 1``, ``no impact
    of the roll`` ("stray")."""
    return "no impact of the roll" if key == STRAY_KEY else f"impact {key}"


def numbering_average_text(average: NumberingAverage | None) -> str | None:
    """One line for :func:`numbering_average_content`, e.g. ``α = 0.9214 ± 0.0005, t_B =
    0.2530 ± 0.0009 s (weights: 0 missed 0.08, 1 missed 0.92)``; None without one."""
    parts = numbering_average_content(average)
    return None if parts is None else plain_text(parts)


def model_average_text(average: ModelAverage | None) -> str | None:
    """One line for the stacking-weighted α and t_B (:class:`~drumroll.inference.results.
    ModelAverage`), e.g. ``α = 0.9002 ± 0.0004, t_B = 0.19908 ± 0.00010 s (stacking weights:
    pendulum 0.77, small-angle 0.23, powerlaw 0.00)``; None without one."""
    parts = model_average_content(average)
    return None if parts is None else plain_text(parts)
