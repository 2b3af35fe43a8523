"""Several searches of one vectorised function, their calls evaluated together.

A search that calls a vectorised function with a few points at a time (L-BFGS-B's
finite-difference gradient: 2 ndim + 1 points) pays the function's fixed cost per call, the
Python of the posterior's layers, more than its arithmetic. :func:`lockstep` runs several such
searches side by side, each in its own thread, and whenever every search still running is
waiting for its next call, evaluates all their points in one call of the function: the same
numbers, row for row, as separate calls (each row is computed on its own), for one fixed cost
instead of one per search. The threads only take turns: one of them evaluates while the others
wait, so nothing runs concurrently and the result does not depend on their timing.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

Result = TypeVar("Result")


class _Abandoned(Exception):
    """Raised in a search whose siblings failed: it stops at its next call."""


class _Batch:
    """The calls the searches are waiting on, evaluated once all of them wait."""

    def __init__(self, function: Callable[[NDArray], NDArray], searches: int) -> None:
        self.function = function
        self.condition = threading.Condition()
        self.waiting: dict[int, NDArray] = {}
        self.results: dict[int, NDArray] = {}
        self.running = searches
        self.failed = False

    def call(self, index: int, points: NDArray) -> NDArray:
        with self.condition:
            if self.failed:
                raise _Abandoned
            self.waiting[index] = np.atleast_2d(np.asarray(points, float))
            self._evaluate_if_all_wait()
            while index not in self.results:
                if self.failed:
                    raise _Abandoned
                self.condition.wait()
            return self.results.pop(index)

    def leave(self, failed: bool) -> None:
        with self.condition:
            self.running -= 1
            if failed:
                self.failed = True
                self.condition.notify_all()
            elif not self.failed:
                self._evaluate_if_all_wait()

    def _evaluate_if_all_wait(self) -> None:
        if not self.waiting or len(self.waiting) < self.running:
            return
        order = sorted(self.waiting)
        blocks = [self.waiting[i] for i in order]
        self.waiting.clear()
        try:
            values = self.function(np.concatenate(blocks))
        except BaseException:
            self.failed = True
            self.condition.notify_all()
            raise
        ends = np.cumsum([len(b) for b in blocks])
        for i, part in zip(order, np.split(values, ends[:-1]), strict=True):
            self.results[i] = part
        self.condition.notify_all()


class _Caller:
    """One search's view of the batched function: callable on its points, with the
    function's other attributes (a sampler target's ``coordinates``) passed through."""

    def __init__(self, batch: _Batch, index: int) -> None:
        self._batch, self._index = batch, index

    def __call__(self, points: NDArray) -> NDArray:
        return self._batch.call(self._index, points)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._batch.function, name)


def lockstep(function: Callable[[NDArray], NDArray],
             searches: Sequence[Callable[[Callable[[NDArray], NDArray]], Result]]
             ) -> list[Result]:
    """Run each of ``searches`` (called with the function it is to use in place of
    ``function``) with their calls of ``function`` batched together (module docstring).

    The first search runs in this thread, the others in threads of their own. Returns their
    results in order; the first exception raised in any of them is raised here, once all
    have stopped.
    """
    if len(searches) < 2:
        return [search(function) for search in searches]
    batch = _Batch(function, len(searches))
    results: list[Any] = [None] * len(searches)
    errors: list[BaseException | None] = [None] * len(searches)

    def run(index: int) -> None:
        try:
            results[index] = searches[index](_Caller(batch, index))
        except _Abandoned:
            batch.leave(failed=True)
        except BaseException as exc:  # raised in this thread once all have stopped
            errors[index] = exc
            batch.leave(failed=True)
        else:
            batch.leave(failed=False)

    threads = [threading.Thread(target=run, args=(i,), daemon=True)
               for i in range(1, len(searches))]
    for thread in threads:
        thread.start()
    run(0)
    try:
        for thread in threads:
            thread.join()
    except BaseException:  # an interrupt while waiting: the others stop at their next call
        with batch.condition:
            batch.failed = True
            batch.condition.notify_all()
        raise
    for error in errors:
        if error is not None:
            raise error
    return results
