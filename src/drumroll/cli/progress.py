"""Progress on stderr: a spinner with elapsed time on a terminal, plain lines elsewhere."""

from __future__ import annotations

import itertools
import sys
import threading
import time
from types import TracebackType


class Progress:
    """Report stages of a long command on stderr (silent when ``quiet``).

    Use :meth:`say` for a line of news and ``with progress.stage("sampling"):`` around a long
    stage: on a terminal a spinner shows the elapsed time until the stage ends.
    """

    def __init__(self, quiet: bool = False, stream=None) -> None:
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.interactive = hasattr(self.stream, "isatty") and self.stream.isatty()
        self._lock = threading.Lock()

    def say(self, message: str) -> None:
        """Print one line of progress."""
        if self.quiet:
            return
        with self._lock:
            self.stream.write(("\r\033[K" if self.interactive else "") + message + "\n")
            self.stream.flush()

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
