"""Impact times from a recording, with a timing uncertainty for each.

``detect(path_or_array, sr=None, **options) -> OnsetTable`` streams the recording through a
sub-millisecond high-frequency detection function (:mod:`.odf`), picks significant peaks
against robust noise statistics (:mod:`.peaks`), refines each to the sample
(:mod:`.refine`), keeps the sequence whose intervals shrink like a bouncer's
(:mod:`.tracking`), and follows it into the noise window by window where physics predicts
the next impact (:mod:`.follow`). :func:`read_onsets` reads onset files back (:mod:`.table`).
"""

from __future__ import annotations

from drumroll.onsets.detector import detect
from drumroll.onsets.table import COLUMNS, OnsetTable, read_onsets

__all__ = ["COLUMNS", "OnsetTable", "detect", "read_onsets"]
