"""Process pools that a Ctrl-C stops at once and quietly.

A terminal's Ctrl-C reaches every process of the command. The workers ignore it, so that the
main process alone sees the interrupt (and reports it in one line, removing whatever it had
staged) instead of racing their tracebacks; on any exception the main process then stops
the workers rather than waiting for their tasks to finish.

While a pool is open, the objects this process already holds are frozen out of the garbage
collector (:func:`gc.freeze`): the workers are forked with them, and their collections would
otherwise traverse the whole inherited heap (the imported libraries, the fits) again and again,
and write to every object's header, which copies page after page of memory the processes could
have shared.
"""

from __future__ import annotations

import contextlib
import gc
import signal
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor

#: Pools open now: the heap is frozen while any is (the estimate opens its figure workers'
#: pool while its samplers' is open, and closes it after).
_open_pools = 0


def _ignore_interrupt() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # The parent's SIGTERM handler (drumroll.cli.main) is inherited by a forked worker; a
    # worker must simply end on SIGTERM, which is how the parent stops it.
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


@contextlib.contextmanager
def process_pool(max_workers: int) -> Iterator[ProcessPoolExecutor]:
    """A :class:`ProcessPoolExecutor` (as a context manager) for the commands' parallel work.

    The objects that exist when it opens are frozen out of the garbage collector until it
    closes (module docstring): in the workers, forked with them, and in this process, whose
    own collections need not traverse them either while it waits. They are unfrozen once no
    pool is open, so that nothing of a long-lived process (a notebook's) stays out of reach
    of the collector. In the estimate this saved ~1 CPU-s of collections (four figure workers' and
    the main process's full collections, 0.1 s each).
    """
    global _open_pools
    gc.freeze()
    _open_pools += 1
    try:
        pool = ProcessPoolExecutor(max_workers=max_workers, initializer=_ignore_interrupt)
        try:
            yield pool
        except BaseException:
            # Cancel what has not started and end what has: the run is abandoned.
            # The workers, taken before shutdown() forgets them (it sets _processes to None).
            processes = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=False, cancel_futures=True)
            for process in processes:
                process.terminate()
            for process in processes:  # gone before the caller cleans up what they wrote
                process.join(timeout=5)
            raise
        pool.shutdown(wait=True)
    finally:
        _open_pools -= 1
        if not _open_pools:
            gc.unfreeze()
