"""Argument types shared by the subcommands."""

from __future__ import annotations

import argparse
import math


def _whole_number(text: str, least: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < least:
        raise argparse.ArgumentTypeError(f"must be at least {least}, got {value}")
    return value


def positive_int(text: str) -> int:
    """An ``argparse`` type: a whole number of at least 1 (a usage error otherwise)."""
    return _whole_number(text, 1)


def at_least(least: int):
    """An ``argparse`` type: a whole number of at least ``least`` (a usage error otherwise)."""
    def parse(text: str) -> int:
        return _whole_number(text, least)

    return parse


def non_negative_int(text: str) -> int:
    """An ``argparse`` type: a whole number of at least 0 (a usage error otherwise)."""
    return _whole_number(text, 0)


def positive_float(text: str) -> float:
    """An ``argparse`` type: a finite number above 0 (a usage error otherwise)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number above 0, got {text}")
    return value
