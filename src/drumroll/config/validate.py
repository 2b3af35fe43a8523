"""Small checks that turn a bad config value into one clear line naming its key.

Section parsers (here and in other stages, e.g. the simulator's ``[simulate]``) build on these
so that every message has the same shape: ``priors.alpha: <what is wrong>``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping
from typing import Any

from drumroll.errors import ConfigError, UnknownKey


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest choice, or a list of the valid ones."""
    choices = sorted(choices)
    close = difflib.get_close_matches(word, choices, n=1, cutoff=0.6)
    if close:
        return f" (did you mean {close[0]!r}?)"
    return f" (expected one of: {', '.join(choices)})" if choices else ""


def check_keys(table: Mapping[str, Any], allowed: Iterable[str], where: str) -> None:
    """Reject any key of ``table`` not in ``allowed``, suggesting the nearest valid one."""
    allowed = tuple(allowed)
    for key in table:
        if key not in allowed:
            raise UnknownKey(f"{join(where, key)}: unknown key{did_you_mean(key, allowed)}",
                             where, key)


def join(where: str, key: str) -> str:
    """Dotted path of ``key`` inside section ``where`` ('' for the top level)."""
    return f"{where}.{key}" if where else key


def type_name(value: Any) -> str:
    """TOML's name for the type of ``value``, for messages."""
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "an array", dict: "a table"}.get(type(value), type(value).__name__)


def number(value: Any, key: str, *, positive: bool = False, nonnegative: bool = False,
           integer: bool = False) -> float:
    """``value`` as a finite number, or a :class:`ConfigError` naming ``key``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"{key}: expected a number, got {type_name(value)} ({value!r})")
    if integer and not isinstance(value, int):
        raise ConfigError(f"{key}: expected a whole number, got {value!r}")
    if not math.isfinite(value):
        raise ConfigError(f"{key}: expected a finite number, got {value!r}")
    if positive and not value > 0:
        raise ConfigError(f"{key}: must be positive, got {value!r}")
    if nonnegative and not value >= 0:
        raise ConfigError(f"{key}: must not be negative, got {value!r}")
    return value


def string(value: Any, key: str, choices: Iterable[str] | None = None) -> str:
    """``value`` as a string (one of ``choices`` if given), or a :class:`ConfigError`."""
    if not isinstance(value, str):
        raise ConfigError(f"{key}: expected a string, got {type_name(value)} ({value!r})")
    if choices is not None:
        choices = tuple(choices)
        if value not in choices:
            raise ConfigError(f"{key}: unknown value {value!r}{did_you_mean(value, choices)}")
    return value


def boolean(value: Any, key: str) -> bool:
    """``value`` as a boolean, or a :class:`ConfigError`."""
    if not isinstance(value, bool):
        raise ConfigError(f"{key}: expected true or false, got {value!r}")
    return value


def table(value: Any, key: str) -> dict[str, Any]:
    """``value`` as a TOML table, or a :class:`ConfigError`."""
    if not isinstance(value, dict):
        raise ConfigError(f"{key}: expected a table, got {type_name(value)} ({value!r})")
    return value
