"""Ctrl-C and SIGTERM, handled alike: raised where the command is, and never lost.

Python raises a signal handler's exception wherever the main thread happens to be. When that
is inside a weakref callback or a ``__del__`` (a garbage collection in the middle of writing
the outputs), Python prints the exception as "ignored" and goes on: the command would finish
as if nothing had happened and exit 0. So the handler also records the signal, and the
commands check for it where it matters (:func:`raise_if_interrupted`: before outputs are moved
into place) and once more when they end.
"""

from __future__ import annotations

import signal
import threading

#: The signal received and not yet acted on (None: none).
_pending: int | None = None


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is, so that it ends as a Ctrl-C does: workers
    stopped, staged files removed, one line."""


def _interrupt(signum: int) -> KeyboardInterrupt:
    return Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _handler(signum, frame) -> None:
    global _pending
    _pending = signum
    raise _interrupt(signum)


def install() -> dict[int, object] | None:
    """Handle SIGINT and SIGTERM as above (in the main thread only: a signal handler can be
    set nowhere else); returns the handlers replaced, for :func:`restore`, or None."""
    global _pending
    if threading.current_thread() is not threading.main_thread():
        return None
    _pending = None
    return {s: signal.signal(s, _handler) for s in (signal.SIGINT, signal.SIGTERM)}


def restore(previous: dict[int, object] | None) -> None:
    """Put back the handlers :func:`install` replaced."""
    for signum, handler in (previous or {}).items():
        signal.signal(signum, handler)


def raise_if_interrupted() -> None:
    """Raise the interruption a signal asked for, if its own exception was swallowed."""
    global _pending
    if _pending is not None:
        signum, _pending = _pending, None
        raise _interrupt(signum)
