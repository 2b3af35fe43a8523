"""Ctrl-C, SIGTERM and SIGHUP, handled alike: raised where the command is, and never lost.

SIGHUP is what a closed terminal or a dropped SSH session sends: left to its default, it
would kill the command at once, leaving its staged files and its workers behind.

Python raises a signal handler's exception wherever the main thread happens to be. When that
is inside a weakref callback or a ``__del__`` (a garbage collection in the middle of writing
the outputs), Python prints the exception as "ignored" and goes on: the command would finish
as if nothing had happened and exit 0. So the handler also records the signal, and the
commands check for it where it matters (:func:`raise_if_interrupted`: before outputs are moved
into place) and once more when they end. Inside a C extension's import the exception comes
out as another one ("ImportError: initialization failed", seen in CI when SIGTERM met the
sampling's first import of a module): whatever ends a command after a signal came is the
signal's doing (:func:`pending`), not a fault to report.
"""

from __future__ import annotations

import signal
import threading

#: The signal received and not yet acted on (None: none).
_pending: int | None = None


#: The signals handled: a terminal's Ctrl-C, a kill, a hang-up (where the system has one).
SIGNALS = tuple(s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None))
                if s is not None)


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP (``signum``), raised where the command is, so that it ends as a
    Ctrl-C does: workers stopped, staged files removed, one line; the exit status is
    128 + ``signum``, as a shell reports a command the signal ended."""

    def __init__(self, signum: int = signal.SIGTERM) -> None:
        super().__init__(signum)
        self.signum = int(signum)

    @property
    def how(self) -> str:
        """The word for it: "terminated" or "hung up"."""
        return "hung up" if self.signum == getattr(signal, "SIGHUP", None) else "terminated"


def _interrupt(signum: int) -> KeyboardInterrupt:
    return KeyboardInterrupt() if signum == signal.SIGINT else Terminated(signum)


def _handler(signum, frame) -> None:
    global _pending
    _pending = signum
    raise _interrupt(signum)


def install() -> dict[int, object] | None:
    """Handle :data:`SIGNALS` as above (in the main thread only: a signal handler can be
    set nowhere else); returns the handlers replaced, for :func:`restore`, or None."""
    global _pending
    if threading.current_thread() is not threading.main_thread():
        return None
    _pending = None
    return {s: signal.signal(s, _handler) for s in SIGNALS}


def restore(previous: dict[int, object] | None) -> None:
    """Put back the handlers :func:`install` replaced."""
    for signum, handler in (previous or {}).items():
        signal.signal(signum, handler)


def pending() -> KeyboardInterrupt | None:
    """The interruption a signal asked for, if one came since :func:`install` (None
    otherwise), whatever became of its own exception."""
    return None if _pending is None else _interrupt(_pending)


def raise_if_interrupted() -> None:
    """Raise the interruption a signal asked for, if its own exception was swallowed."""
    global _pending
    if _pending is not None:
        signum, _pending = _pending, None
        raise _interrupt(signum)
