"""The commands' process pools: workers ignore Ctrl-C, and an interrupt stops them at once."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
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
    """The workers are ended, and gone, when the pool's block is left: nothing of theirs
    (a figure being saved) lands after the caller has cleaned up."""
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt), process_pool(2) as pool:
        for _ in range(3):
            pool.submit(time.sleep, 60)
        time.sleep(0.5)
        workers = list(pool._processes.values())
        raise KeyboardInterrupt
    assert time.perf_counter() - started < 15
    assert len(workers) == 2 and all(_gone(w) for w in workers)


def _gone(process) -> bool:
    """Whether a worker has ended. is_alive() can say it runs when the pool's own thread
    reaped it first (its waitpid then finds no child), so the process table decides."""
    if process.exitcode is not None:
        return True
    try:
        os.kill(process.pid, 0)
    except ProcessLookupError:
        return True  # ended and reaped
    try:  # ended but not yet reaped (a zombie), on systems that show it
        with open(f"/proc/{process.pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[-1].split()[0] == "Z"
    except OSError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux's")
def test_workers_end_when_the_command_is_killed_outright():
    """A main process killed by SIGKILL runs no clean-up: its workers are ended by the
    kernel (they asked for SIGTERM on their parent's death), not left sampling, orphaned."""
    script = (
        "import os, signal, time\n"
        "from drumroll.workers import process_pool\n"
        "with process_pool(2) as pool:\n"
        "    pool.submit(time.sleep, 60); pool.submit(time.sleep, 60)\n"
        "    time.sleep(0.5)\n"
        "    print(*[p.pid for p in pool._processes.values()], flush=True)\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=60, check=False)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    pids = [int(p) for p in proc.stdout.split()]
    assert len(pids) == 2
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and not all(_pid_gone(p) for p in pids):
        time.sleep(0.1)
    assert all(_pid_gone(p) for p in pids), "workers outlived their killed parent"


def _pid_gone(pid: int) -> bool:
    """Whether the process ``pid`` has ended (gone, or a zombie nobody reaped yet)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[-1].split()[0] == "Z"
    except OSError:
        return True


def test_pools_nest_and_the_heap_stays_frozen_while_any_is_open():
    import gc

    with process_pool(1):
        inner = process_pool(1)
        inner.__enter__()
    assert gc.get_freeze_count() > 0  # the outer pool closed first, the inner is open
    inner.__exit__(None, None, None)
    assert gc.get_freeze_count() == 0


SPY = """
import os, sys
for variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.pop(variable, None)
import drumroll.cli.main as cli
import drumroll.cli.table as table_cli
set_up = cli._one_blas_thread
def spy():
    print("numpy loaded" if "numpy" in sys.modules else "numpy not loaded")
    set_up()
cli._one_blas_thread = spy
entry = {"drumroll": cli.main, "estimate": cli.estimate_main, "table": table_cli.main}
try:
    entry[sys.argv[1]](["--help"])
except SystemExit:
    pass
print("threads", os.environ.get("OPENBLAS_NUM_THREADS"))
"""


@pytest.mark.parametrize("entry", ["drumroll", "estimate", "table"])
def test_every_command_runs_blas_on_one_thread_per_process(entry):
    # The commands parallelise over processes; BLAS threads on top spin and take the cores
    # the other workers need (a 6-run table: 24 CPU-s with one thread, 28 without). The
    # setting only counts if made before numpy loads BLAS, and building a parser loads numpy.
    proc = subprocess.run([sys.executable, "-c", SPY, entry], capture_output=True, text=True,
                          check=True)
    lines = [line for line in proc.stdout.splitlines() if not line.startswith(("usage", " "))]
    assert "numpy not loaded" in lines
    assert "numpy loaded" not in lines
    assert "threads 1" in lines

