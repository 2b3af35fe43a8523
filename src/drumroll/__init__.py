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

From Python, each command is a function (imported on first use)::

    import drumroll

    onsets = drumroll.detect("roll.wav")                    # drumroll onsets
    result = drumroll.estimate("roll.wav", "roll.toml")     # drumroll estimate
    fits = drumroll.load_posteriors("out/posterior.nc")     # its posterior.nc, by model
    predictions = drumroll.predict("roll.toml")             # drumroll predict
    recording = drumroll.simulate("roll.toml", seed=1)      # drumroll simulate
    table = drumroll.run_table(drumroll.load_runs("runs.toml"))  # drumroll table
    calibration = drumroll.calibrate("roll.toml", n=200)     # drumroll calibrate
"""

from __future__ import annotations

from drumroll._version import __version__

#: The public functions, as the commands they mirror: name → (module, attribute). Each is
#: imported on first use, so ``import drumroll`` stays instant and ``drumroll.predict`` does not
#: wait for the samplers, nor ``drumroll.read_onsets`` for the detector.
_API = {
    "detect": ("drumroll.onsets.detector", "detect"),                # drumroll onsets
    "read_onsets": ("drumroll.onsets.formats", "read_onsets"),
    "estimate": ("drumroll.pipeline", "estimate"),                    # drumroll estimate
    "load_posteriors": ("drumroll.reporting.posterior_file", "load_posteriors"),
    "predict": ("drumroll.inference.prior_predictive", "predict"),    # drumroll predict
    "simulate": ("drumroll.simulation.simulate", "simulate"),         # drumroll simulate
    "load_runs": ("drumroll.table.runs", "load_runs"),                # drumroll table
    "run_table": ("drumroll.table.execute", "run_table"),
    "load_config": ("drumroll.config.loader", "load_config"),
    "calibrate": ("drumroll.calibration.run", "calibrate"),           # drumroll calibrate
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        import importlib

        module, attribute = _API[name]
        return getattr(importlib.import_module(module), attribute)
    raise AttributeError(f"module 'drumroll' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_API})
