"""Process pools that a Ctrl-C stops at once and quietly, and that never outlive the command.

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
import ctypes
import gc
import os
import signal
import sys
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor

#: prctl's option that sets the signal a process gets when its parent ends (linux/prctl.h).
_PR_SET_PDEATHSIG = 1
#: Pools open now: the heap is frozen while any is (the estimate opens its figure workers'
#: pool while its samplers' is open, and closes it after).
_open_pools = 0


def _end_with(parent: int) -> None:
    """Have the kernel send this worker SIGTERM when the process that forked it ends
    (Linux's PR_SET_PDEATHSIG): a main process killed outright (SIGKILL, the OOM killer)
    runs no clean-up, and its workers would otherwise sample on, orphaned. Elsewhere, or
    where prctl is not to be had, nothing is done."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # it ended before the request was made
        os._exit(1)


def _ignore_interrupt(parent: int) -> None:
    # A terminal's Ctrl-C and hang-up reach every process of the command: the main process
    # alone acts on them (drumroll.interruption) and stops the workers.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "SIGHUP"):
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
    # The parent's SIGTERM handler (drumroll.cli.main) is inherited by a forked worker; a
    # worker must simply end on SIGTERM, which is how the parent stops it.
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _end_with(parent)


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
        pool = ProcessPoolExecutor(max_workers=max_workers, initializer=_ignore_interrupt,
                                   initargs=(os.getpid(),))
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
