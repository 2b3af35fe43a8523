"""The commands' progress on stderr: on a terminal, a tqdm bar with an ETA for a count of
things (a table's runs, an estimate's fits, a simulation's recordings), a spinner with the
elapsed time for a stage that cannot be counted, and news lines above them; elsewhere (a
pipe, a log file) the news lines alone, plain; with ``--quiet``, nothing.

It is a :class:`drumroll.progress.Progress`, so the library's long work (``estimate``,
``run_table``) reports to it directly.
"""

from __future__ import annotations

import contextlib
import itertools
import sys
import threading
import time
from collections.abc import Iterator
from types import TracebackType
from typing import TextIO

from drumroll import progress as library


class Progress(library.Progress):
    """Report the stages of a long command on stderr (silent when ``quiet``).

    Use :meth:`say` for a line of news, ``with progress.stage("sampling"):`` around a long
    stage (on a terminal a spinner shows the elapsed time until the stage ends), and ``with
    progress.bar(total, "runs", "run") as bar:`` for a count (on a terminal a bar with the
    time left; the spinner of an enclosing stage pauses meanwhile).
    """

    def __init__(self, quiet: bool = False, stream: TextIO | None = None) -> None:
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.interactive = library.watched(self.stream) == "terminal"
        self._lock = threading.Lock()
        self._bars = library.Bars("terminal", stream=self.stream)

    @property
    def showing_bar(self) -> bool:
        """Whether a bar is on the screen (the spinner then waits)."""
        return self._bars.showing

    def say(self, message: str) -> None:
        """Print one line of progress."""
        if self.quiet:
            return
        with self._lock:
            if self._bars.showing:
                from tqdm import tqdm

                tqdm.write(message, file=self.stream)
                return
            self.stream.write(("\r\033[K" if self.interactive else "") + message + "\n")
            self.stream.flush()

    @contextlib.contextmanager
    def bar(self, total: int, description: str, unit: str, initial: int = 0
            ) -> Iterator[library.Bar]:
        """A bar on a terminal; nothing elsewhere (the news lines say what is done)."""
        if self.quiet or not self.interactive:
            yield library.Bar()
            return
        with self._lock:
            self.stream.write("\r\033[K")  # the spinner's line, if one was drawn
        with self._bars.bar(total, description, unit, initial) as bar:
            yield bar

    def stage(self, name: str) -> _Stage:
        """A context manager showing ``name`` with a spinner and the elapsed time."""
        return _Stage(self, name)


class _Stage:
    def __init__(self, progress: Progress, name: str) -> None:
        self.progress, self.name = progress, name
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.started = 0.0

    def __enter__(self) -> _Stage:
        self.started = time.perf_counter()
        p = self.progress
        if p.quiet:
            return self
        if not p.interactive:
            p.say(f"{self.name} …")
            return self
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        return self

    def _spin(self) -> None:
        for frame in itertools.cycle("⠋⠙⠹⠸⠼⠴⠦⠧⠇⠏"):
            if self._stop.wait(0.2):
                return
            with self.progress._lock:
                if self.progress.showing_bar:
                    continue
                elapsed = time.perf_counter() - self.started
                self.progress.stream.write(f"\r\033[K{frame} {self.name} {elapsed:5.1f} s")
                self.progress.stream.flush()

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if kind is None:
            self.progress.say(f"{self.name}: done in {time.perf_counter() - self.started:.1f} s")
        elif self.progress.interactive and not self.progress.quiet:
            self.progress.stream.write("\r\033[K")
