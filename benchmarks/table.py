"""Benchmark of ``drumroll table``: a 6-run table with ``--workers 2`` against ``--workers 1``.

The six runs are the bundled recordings of the paper's Tables 1 and 2 (``data/``), each
estimated as configured (exact pendulum compared with the small-angle model and the power law,
evidences by nested sampling unless ``--no-evidence``). Each timing runs the command as a user
does (``drumroll table RUNS.toml --workers N``), with the cache in a fresh temporary folder,
so nothing is reused between the two. The goal is a ratio of at most 0.6.

Run: ``python benchmarks/table.py [--no-evidence] [--repeat 1]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SETUPS = ("table1_d110", "table1_d131", "table1_d152", "table2_h50", "table2_h80",
          "table2_h110")


def runs_file(folder: Path, evidence: bool) -> Path:
    """A RUNS.toml over the six bundled Table 1-2 recordings."""
    lines = ['vary = "height_mm"']
    if not evidence:
        lines.append("sampler = { evidence = false }")
    for name in SETUPS:
        lines += ["", "[[run]]", f'label = "{name}"', f'source = "{ROOT / "data" / name}.flac"',
                  f'config = "{ROOT / "data" / name}.toml"']
    path = folder / "runs.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def wall_time(runs: Path, workers: int) -> tuple[float, float]:
    """Wall and CPU seconds of ``drumroll table RUNS --workers N`` with a fresh cache folder.

    The CPU time (all child processes) over the wall time is the parallelism the command got:
    on a busy machine it falls below the number of workers, and so does the speed-up.
    """
    with tempfile.TemporaryDirectory() as cache:
        command = [sys.executable, "-m", "drumroll.cli.main", "table", str(runs), "-q",
                   "--workers", str(workers), "--cache-dir", cache]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - started
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        return wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-evidence", action="store_true", help="skip nested sampling")
    parser.add_argument("--repeat", type=int, default=1, help="timings per setting (best kept)")
    args = parser.parse_args()
    print(f"{len(SETUPS)} runs, evidence {'off' if args.no_evidence else 'on'}, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start")
    with tempfile.TemporaryDirectory() as tmp:
        runs = runs_file(Path(tmp), evidence=not args.no_evidence)
        times = {}
        for workers in (1, 2):
            wall, cpu = min(wall_time(runs, workers) for _ in range(args.repeat))
            times[workers] = wall
            print(f"--workers {workers}: {wall:7.1f} s wall, {cpu:7.1f} s CPU "
                  f"(parallelism {cpu / wall:.2f}), load average {os.getloadavg()[0]:.1f}")
    ratio = times[2] / times[1]
    print(f"ratio (2 workers / 1 worker): {ratio:.2f} (goal <= 0.6)")
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
