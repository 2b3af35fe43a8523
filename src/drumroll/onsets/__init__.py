"""Impact times from a recording, with a timing uncertainty for each.

``detect(path_or_array, sr=None, **options) -> OnsetTable`` streams the recording through a
sub-millisecond high-frequency detection function (:mod:`.odf`), picks significant peaks
against robust noise statistics (:mod:`.peaks`), refines each to the sample
(:mod:`.refine`), keeps the sequence whose intervals shrink like a bouncer's
(:mod:`.tracking`), follows it into the noise window by window where physics predicts
the next impact (:mod:`.follow`), and times each onset again with the roll's help: its law
as a prior (:mod:`.sequence`), and its loudest impact's sound envelope as a template for the
faint ones whose first milliseconds are lost in what they land in (:mod:`.envelope`).
:func:`read_onsets` reads onset files back (:mod:`.table`).
"""

from __future__ import annotations

from drumroll.onsets.detector import detect
from drumroll.onsets.table import COLUMNS, OnsetTable, read_onsets

__all__ = ["COLUMNS", "OnsetTable", "detect", "read_onsets"]
