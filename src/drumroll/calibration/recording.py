"""A simulated roll heard through a microphone: rendered as a recording by the renderer of
``drumroll simulate``, its onsets found by the extractor ``estimate`` uses, and each onset
matched with the impact it is.

The recording's sound is the config's ``[simulate]`` section's (synthetic drum or recorded
hits, room, background noise, hum, stray taps and knocks, sample rate and sample format; its
true set-up is not used, every draw brings its own), or ``drumroll simulate``'s defaults when
the config has none. The roll is the simulated one, impact for impact (its timing noise
included): the recording holds those impacts and nothing after them, so that the extractor's
errors are all that differs from fitting the onsets themselves.
"""

from __future__ import annotations

import contextlib
import io
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drumroll.calibration.roll import SimulatedRoll
from drumroll.config import Config
from drumroll.inference.results import Record
from drumroll.onsets import OnsetTable, detect
from drumroll.pipeline import choose_roll

#: Longest the extractor may take on one simulated recording (a few seconds of audio, found
#: in well under a second as a rule). Some rolls with a jitter of several ms keep its
#: window-by-window search going for tens of minutes; such a recording is drawn again
#: (:class:`TooSlow`), a selection on the data, and counted.
EXTRACTOR_SECONDS = 60.0


class TooSlow(Exception):
    """The extractor took longer than its time limit on a recording."""


@contextlib.contextmanager
def time_limit(seconds: float) -> Iterator[None]:
    """Raise :class:`TooSlow` in this block once ``seconds`` of wall time have passed.

    A real-time timer's signal interrupts the block: only in a process's main thread, where
    signal handlers can be set (the command's workers, a script); in another thread (a Dask
    worker's) the block runs without a limit.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum: int, frame: Any) -> None:
        raise TooSlow(f"the extractor took more than {seconds:g} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


@dataclass(frozen=True)
class Hearing(Record):
    """How the extractor heard one simulated roll.

    Attributes
    ----------
    n_impacts
        Impacts in the recording.
    n_heard
        Onsets of the roll ``estimate`` fits (the longest the extractor found).
    n_rolls
        Rolls the extractor found in the recording.
    first
        The true bounce number of the first onset fitted (0: the first impact was heard;
        negative: the roll's first onsets are no impacts, say a tap taken for a bounce).
    misnumbered
        Fitted onsets whose nearest impact is not the one their bounce number says (a
        missed first impact shifts every number; a stray sound taken for a bounce).
    median_error_ms, max_error_ms
        Median and largest |onset − impact| of the fitted onsets, at their numbers (ms).
    within_1ms
        Share of the fitted onsets within 1 ms of their impact.
    """

    n_impacts: int = 0
    n_heard: int = 0
    n_rolls: int = 0
    first: int = 0
    misnumbered: int = 0
    median_error_ms: float | None = None
    max_error_ms: float | None = None
    within_1ms: float | None = None


@dataclass(frozen=True)
class HeardRoll:
    """The extractor's onsets of a rendered roll, and what they should have been.

    Attributes
    ----------
    onsets
        Everything the extractor found (every roll).
    t0
        When, in the recording, the impact the first fitted onset belongs to would have
        happened without timing noise: the truth of the fit's T0.
    hearing
        The match of onsets and impacts.
    """

    onsets: OnsetTable
    t0: float
    hearing: Hearing


class Recorder:
    """Renders simulated rolls with a config's ``[simulate]`` sound and extracts their onsets.

    Parameters
    ----------
    config
        The config (its ``[simulate]`` section, if any; recorded hits and rooms it names are
        read relative to its file).

    Raises
    ------
    ConfigError
        The section is malformed, or a file it names cannot be read (one line).
    """

    def __init__(self, config: Config) -> None:
        # Importing the settings registers the [simulate] section's parser.
        from drumroll.simulation.settings import SimulateSettings, load_recorded

        settings = config.section("simulate")
        if settings is None:
            # drumroll simulate's sound; the set-up's values are placeholders, never used.
            settings = SimulateSettings(alpha=1.0, pivot=0.0, height=1.0)
        self.settings = settings
        base = Path(config.path).parent if config.path else Path.cwd()
        self.sources = load_recorded(settings, base)

    def record(self, roll: SimulatedRoll, rng: np.random.Generator) -> HeardRoll:
        """Render ``roll``, store it in the section's sample format, find its onsets, and
        match them with the impacts."""
        import soundfile as sf

        from drumroll.simulation.simulate import render_roll

        rendering = render_roll(self.settings, self.sources, roll.times - roll.t0, roll.speeds,
                                rng)
        # Through the sample format a file of `drumroll simulate` has (16-bit by default):
        # the extractor hears the quantised recording a user would give it.
        buffer = io.BytesIO()
        sf.write(buffer, rendering.samples, rendering.sample_rate, subtype=self.settings.subtype,
                 format="WAV")
        buffer.seek(0)
        samples, rate = sf.read(buffer, dtype="float64")
        with time_limit(EXTRACTOR_SECONDS):
            onsets = detect(samples, rate)
        impacts = rendering.impact_times_s  # the onsets as placed in the file (noise included)
        noise_free = rendering.lead_in_s + (roll.model_times - roll.t0)
        hearing, first = match(onsets, impacts)
        # The truth of the fit's T0 is the impact its first onset is; where that onset is
        # no impact at all, the roll's own first impact stands in (the fit is then wrong
        # about every number anyway, and Hearing.first < 0 says so).
        return HeardRoll(onsets=onsets, t0=float(noise_free[min(max(first, 0),
                                                                  noise_free.size - 1)]),
                         hearing=hearing)


def match(onsets: OnsetTable, impacts: NDArray) -> tuple[Hearing, int]:
    """Match the roll ``estimate`` would fit among ``onsets`` with the true ``impacts``
    through its bounce numbers: the offset j that puts the most onsets nearest to impact
    k + j (k their numbers from the roll's first onset), the closest on a tie; j < 0 when
    the first onsets are no impacts.

    Returns
    -------
    hearing, first
        The match's summary, and j (the first fitted onset's true bounce number).
    """
    n = int(np.size(impacts))
    if not len(onsets):
        return Hearing(n_impacts=n), 0
    fitted = choose_roll(onsets).onsets
    times, numbers = fitted.time_s, np.asarray(fitted.bounce, dtype=np.intp)
    nearest = np.abs(times[:, None] - impacts[None, :]).argmin(axis=1)
    best, best_key = 0, None
    # j < 0: the roll's first onsets are no impacts (a tap where the flights put one).
    for j in range(-int(numbers[-1]), n):
        at = numbers + j
        inside = (at >= 0) & (at < n)
        errors = np.abs(times[inside] - impacts[at[inside]])
        key = (-int(np.count_nonzero(nearest == at)),
               float(np.median(errors)) if errors.size else np.inf)
        if best_key is None or key < best_key:
            best, best_key = j, key
    at = numbers + best
    inside = (at >= 0) & (at < n)
    errors = np.abs(times[inside] - impacts[at[inside]]) * 1e3
    return Hearing(
        n_impacts=n, n_heard=int(times.size), n_rolls=len(onsets.roll_sizes()), first=best,
        misnumbered=int(np.count_nonzero(nearest != at)),
        median_error_ms=float(np.median(errors)) if errors.size else None,
        max_error_ms=float(errors.max()) if errors.size else None,
        within_1ms=float(np.mean(errors <= 1.0)) if errors.size else None), best
