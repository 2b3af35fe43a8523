"""Shared test configuration."""

import os

from hypothesis import settings

# Deterministic property tests: the same examples on every run and every machine.
settings.register_profile("drumroll", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("drumroll-explore", max_examples=2000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "drumroll"))
