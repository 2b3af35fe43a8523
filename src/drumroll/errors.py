"""Errors a user can act on.

Every problem caused by the user's input (a config key, a file, an option) is raised as a
:class:`DrumrollError`. The command line prints its message on one line and exits with
:attr:`DrumrollError.exit_code` (2: usage or input error), never with a traceback.
"""

from __future__ import annotations


class DrumrollError(Exception):
    """A problem with the user's input, reported as one line.

    Parameters
    ----------
    message
        What is wrong and, where it helps, what to do; one line, no trailing period needed.
    exit_code
        Process exit status for the command line (2 for usage and input errors).
    """

    exit_code: int = 2

    def __init__(self, message: str, exit_code: int = 2) -> None:
        super().__init__(message)
        self.exit_code = exit_code


class ConfigError(DrumrollError):
    """An invalid configuration file or value; the message names the key."""


class UnknownKey(ConfigError):
    """A key that its table does not take: ``key`` in ``where`` (a dotted section path, ''
    for the top level), so that a caller can say where it belongs instead."""

    def __init__(self, message: str, where: str = "", key: str = "") -> None:
        super().__init__(message)
        self.where, self.key = where, key

    def __reduce__(self):  # raised in worker processes: rebuilt from its own arguments
        return type(self), (str(self), self.where, self.key)


class AudioError(DrumrollError):
    """An audio file that cannot be read or holds nothing usable."""


class OnsetsOutsidePriors(DrumrollError):
    """Onsets that no parameter value the priors allow can produce (every prior draw gives
    them zero probability): times in the wrong unit, or priors whose ranges miss the roll."""

    def __init__(self, model: str) -> None:
        super().__init__(
            f"{model}: no parameter value drawn from the priors gives these onsets a nonzero "
            "probability; check that the times are in seconds from the start of the "
            "recording, in order, and that the priors' ranges (t_b, alpha, jitter_ms, the "
            "geometry) include this roll")


class DrumrollWarning(UserWarning):
    """Something the user should know about that does not stop the work (clipping, say)."""
