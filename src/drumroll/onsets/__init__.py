"""Impact times from a recording: every roll in it, every bounce numbered, each onset with a
timing uncertainty.

``detect(path_or_array, sr=None, **options) -> OnsetTable`` streams the recording through a
sub-millisecond high-frequency detection function (:mod:`.odf`), picks significant peaks
against robust noise statistics (:mod:`.peaks`) and refines each to the sample
(:mod:`.refine`, :mod:`.candidates`). The tracker scores whole candidate sequences as a
bouncer's (timing, unheard bounces, level) and finds every roll (:mod:`.tracking`); the
onsets are timed on the channel that hears them first (:mod:`.channels`). Then each roll, a
:class:`~.roll.Roll` with the audio around it (:class:`~.excerpt.Excerpt`), goes through the
stages :data:`.detector.STAGES` lists: from its first impact that stands out, back to an
impact before it where the flights continue (:mod:`.follow`), onsets later than the roll puts
them moved to an earlier stage of their sound (:mod:`.start`), onwards window by window where
the flights put the next bounce, numbering on past unheard ones (:mod:`.follow`,
:mod:`.prediction`), every onset timed again with the roll's law as its prior
(:mod:`.sequence`) and against its loudest impact's sound (:mod:`.envelope`), and the first
impact timed as if it had landed in the ring the next ones land in (:mod:`.start`).
:func:`read_onsets` reads onset files back, in any of :data:`ONSET_FORMATS` (:mod:`.formats`).
"""

from __future__ import annotations

from typing import Any

from drumroll.onsets.formats import ONSET_FILE_SUFFIXES, ONSET_FORMATS, read_onsets
from drumroll.onsets.table import COLUMNS, OnsetTable

__all__ = ["COLUMNS", "ONSET_FILE_SUFFIXES", "ONSET_FORMATS", "OnsetTable", "detect",
           "read_onsets"]


def __getattr__(name: str) -> Any:
    # The detector (its modules and the audio readers, a twentieth of a second to import,
    # no scipy) is loaded on first use, so that reading an onset table, or a command's
    # --help, does not wait for it.
    if name == "detect":
        from drumroll.onsets.detector import detect

        return detect
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
