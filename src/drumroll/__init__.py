"""drumroll: the sound of a bouncing drumstick turned into physics with honest error bars.

The data's path through the package:

``audio`` / ``onsets``
    read recordings and extract impact times with their timing uncertainty;
``physics``
    stick geometry and the forward models (power law, small-angle and exact pendulum);
``inference``
    priors, likelihood, sampling and model comparison;
``reporting``
    tables and figures;
``cli``
    the ``drumroll`` command.
"""

from __future__ import annotations

from drumroll._version import __version__

__all__ = ["__version__", "estimate"]


def __getattr__(name: str):
    # ``drumroll.estimate`` is imported on first use: it pulls in emcee, dynesty and ArviZ,
    # which commands such as ``drumroll predict`` do not need.
    if name == "estimate":
        from drumroll.pipeline import estimate

        return estimate
    raise AttributeError(f"module 'drumroll' has no attribute {name!r}")
