"""Shared test configuration."""

import os

# One BLAS thread per test process: the files run side by side, a process per core
# (pytest-xdist), and BLAS's own threads on top of them only contend for the same cores
# (set before numpy is loaded; a value the user set is kept).
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

from hypothesis import settings  # noqa: E402

# Deterministic property tests: the same examples on every run and every machine.
settings.register_profile("drumroll", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("drumroll-explore", max_examples=2000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "drumroll"))
