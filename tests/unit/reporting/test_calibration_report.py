"""The audio calibration report's split of the rolls numbered right by their true jitter."""

from __future__ import annotations

import numpy as np

from drumroll.calibration.recording import Hearing
from drumroll.calibration.results import DrawRecord, FitRecord
from drumroll.reporting.calibration_report import _by_jitter
from drumroll.reporting.document import Strong, Table


def _draw(jitter_ms: float, heard_covers: bool) -> DrawRecord:
    return DrawRecord(truth={"alpha": 0.9, "jitter_ms": jitter_ms},
                      onsets=FitRecord(covered_90={"alpha": True}),
                      audio=FitRecord(covered_90={"alpha": heard_covers}),
                      hearing=Hearing(n_impacts=16, n_heard=10))


def test_the_rolls_are_split_in_thirds_by_jitter_and_a_failing_third_is_marked():
    # 30 rolls, jitter 0.01 to 10 ms (given out of order); the heard fits of the 10 noisiest
    # miss the truth, their onsets' fits never do.
    jitter = np.geomspace(0.01, 10.0, 30)
    draws = [_draw(float(j), j < jitter[20]) for j in jitter[::-1]]
    blocks = _by_jitter(("alpha",), draws)
    table = next(b for b in blocks if isinstance(b, Table))
    assert [h[0] for h in table.header[1:]] == [
        f"σ {jitter[0]:.2g} to {jitter[9]:.2g} ms (10 rolls)",
        f"σ {jitter[10]:.2g} to {jitter[19]:.2g} ms (10 rolls)",
        f"σ {jitter[20]:.2g} to {jitter[29]:.2g} ms (10 rolls)"]
    (row,) = table.rows
    assert row[1] == ("1.00 (1.00)",) and row[2] == ("1.00 (1.00)",)
    assert row[3] == (Strong(("0.00 (1.00)",)), " ⚠")  # outside the band for 10 rolls


def test_too_few_rolls_or_a_fixed_jitter_give_no_split():
    assert _by_jitter(("alpha",), [_draw(float(j), True) for j in np.geomspace(0.01, 1, 29)]) == ()
    assert _by_jitter(("alpha",), [_draw(0.1, True) for _ in range(40)]) == ()
