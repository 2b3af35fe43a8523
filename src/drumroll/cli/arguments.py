"""Argument types shared by the subcommands."""

from __future__ import annotations

import argparse


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


def non_negative_int(text: str) -> int:
    """An ``argparse`` type: a whole number of at least 0 (a usage error otherwise)."""
    return _whole_number(text, 0)
