"""Progress of long work, shown only where a person watches it.

Long work (the models of an estimate, the runs of a table, the recordings of a simulation)
reports to a :class:`Progress`: :meth:`Progress.say` for a line of news and
:meth:`Progress.bar` for a count of things done, with an estimate of the time left. What
is shown depends on where the work runs:

* on a terminal (standard error is a TTY), a `tqdm <https://tqdm.github.io>`_ bar that
  updates in place (the bar emcee draws), news lines written above it;
* in a Jupyter notebook, tqdm's notebook widget where ipywidgets is installed, otherwise
  its text bar, which a notebook's output updates in place as well;
* elsewhere (a pipe, a log file, a test), no bar: nothing, or the news lines where they are
  asked for (the command line prints them on standard error unless ``--quiet``).

:func:`as_progress` turns what a caller passes (``None``: bars where a person watches;
``False``: nothing; a callable such as ``print``: each news line to it) into a
:class:`Progress`. tqdm is imported only when a bar is shown.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable, Iterator
from typing import Any, Literal, TextIO

__all__ = ["Bar", "Bars", "Lines", "Progress", "ProgressLike", "as_progress", "watched"]

#: Where a bar is shown.
Place = Literal["terminal", "notebook"]


class Bar:
    """A count of things done; this one shows nothing (see :class:`Bars` for one that
    does)."""

    def advance(self, n: int = 1, note: str = "") -> None:
        """``n`` more things done; ``note`` names the last (shown beside the bar)."""


class Progress:
    """Where long work reports; this one shows nothing.

    Subclasses show the news (:meth:`say`), the bars (:meth:`bar`), or both.
    """

    def say(self, message: str) -> None:
        """A line of news (a stage begun or done)."""

    @contextlib.contextmanager
    def bar(self, total: int, description: str, unit: str, initial: int = 0
            ) -> Iterator[Bar]:
        """A bar for ``total`` things (``unit``: ``"run"``, ``"model"``) of which
        ``initial`` are already done; closed when the block ends."""
        yield Bar()


#: What a caller may pass for progress (see :func:`as_progress`).
ProgressLike = Progress | Callable[[str], Any] | bool | None


class Lines(Progress):
    """Each news line to a callable (``print``, a logger's method); no bar."""

    def __init__(self, write: Callable[[str], Any]) -> None:
        self.write = write

    def say(self, message: str) -> None:
        self.write(message)


def _in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (IPython imported and running a kernel)."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    try:
        shell = ipython.get_ipython()
    except AttributeError:
        return False
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


def watched(stream: TextIO | None = None) -> Place | None:
    """Where a person watches ``stream`` (default standard error): ``"notebook"`` in a
    Jupyter kernel, ``"terminal"`` when it is a TTY, None otherwise."""
    if _in_notebook():
        return "notebook"
    stream = sys.stderr if stream is None else stream
    try:
        return "terminal" if stream.isatty() else None
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return None


def _notebook_widgets() -> bool:
    """Whether tqdm's notebook widget can be drawn (ipywidgets is installed)."""
    try:
        import ipywidgets  # noqa: F401
    except ImportError:
        return False
    return True


def _columns(stream: TextIO) -> int:
    """The width of the terminal ``stream`` is (0: unknown)."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, OSError, ValueError):
        return 0


class _TqdmBar(Bar):
    def __init__(self, bar: Any) -> None:
        self._bar = bar

    def advance(self, n: int = 1, note: str = "") -> None:
        if note:
            self._bar.set_postfix_str(note, refresh=False)
        self._bar.update(n)


class Bars(Progress):
    """tqdm bars where a person watches (see :func:`watched`); news lines too when
    ``news`` (above an open bar, so that it is not broken).

    Parameters
    ----------
    place
        ``"terminal"`` or ``"notebook"``.
    news
        Also print the news lines.
    stream
        Where a terminal's bar and the news go (default standard error).
    """

    def __init__(self, place: Place, *, news: bool = False, stream: TextIO | None = None
                 ) -> None:
        self.place = place
        self.news = news
        self.stream = sys.stderr if stream is None else stream
        self._open: list[Any] = []

    @property
    def showing(self) -> bool:
        """Whether a bar is open."""
        return bool(self._open)

    def say(self, message: str) -> None:
        if not self.news:
            return
        if self._open:
            from tqdm import tqdm

            tqdm.write(message, file=self.stream)
        else:
            self.stream.write(message + "\n")
            self.stream.flush()

    def _tqdm(self) -> Any:
        if self.place == "notebook" and _notebook_widgets():
            from tqdm.notebook import tqdm
        else:
            from tqdm import tqdm
        return tqdm

    @contextlib.contextmanager
    def bar(self, total: int, description: str, unit: str, initial: int = 0
            ) -> Iterator[Bar]:
        tqdm = self._tqdm()
        options: dict[str, Any] = {"total": total, "initial": initial, "desc": description,
                                   "unit": unit, "dynamic_ncols": True,
                                   "smoothing": 0.1}
        if tqdm.__module__ != "tqdm.notebook":  # a text bar: to our stream, always drawn
            options.update(file=self.stream, disable=False, mininterval=0.2)
            if not _columns(self.stream):  # a terminal that gives no size (a bare pty)
                options.update(dynamic_ncols=False, ncols=80, nrows=24)
        bar = tqdm(**options)
        self._open.append(bar)
        try:
            yield _TqdmBar(bar)
        finally:
            self._open.remove(bar)
            bar.close()


def as_progress(value: ProgressLike = None, *, stream: TextIO | None = None) -> Progress:
    """The :class:`Progress` a caller asked for.

    Parameters
    ----------
    value
        A :class:`Progress` (used as it is); a callable (each news line to it, no bar);
        ``False`` (nothing); ``True`` (bars, even where nobody seems to watch); None (bars
        where a person watches: a terminal, a notebook; nothing elsewhere).
    stream
        The stream a terminal's bar goes to (default standard error).
    """
    if isinstance(value, Progress):
        return value
    if value is False:
        return Progress()
    if value is True:
        return Bars(watched(stream) or "terminal", stream=stream)
    if value is None:
        place = watched(stream)
        return Progress() if place is None else Bars(place, stream=stream)
    if callable(value):
        return Lines(value)
    raise TypeError(f"progress: expected a Progress, a callable, True, False or None, got "
                    f"{value!r}")
