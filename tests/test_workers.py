"""The commands' process pools: workers ignore Ctrl-C, and an interrupt stops them at once."""

from __future__ import annotations

import os
import signal
import time

import pytest

from drumroll.workers import process_pool


def _interrupt_myself() -> str:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.2)  # a SIGINT that were not ignored would have ended this process by now
    return "still here"


def test_workers_ignore_ctrl_c():
    with process_pool(1) as pool:
        assert pool.submit(_interrupt_myself).result(timeout=30) == "still here"


def test_an_interrupt_stops_running_workers_without_waiting_for_them():
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt), process_pool(2) as pool:
        for _ in range(3):
            pool.submit(time.sleep, 60)
        time.sleep(0.5)
        raise KeyboardInterrupt
    assert time.perf_counter() - started < 15
