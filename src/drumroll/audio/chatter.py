"""What a decoding library prints to the process's standard error itself, kept off the
terminal.

libmpg123 (libsndfile's MP3 decoder) writes its warnings and notes straight to file
descriptor 2, not through Python: on an MP3 cut short, ``Warning: Xing stream size off by
more than 1%, fuzzy seeking may be even more fuzzy than by design!`` at every opening; on
damaged frames, ``Note: Illegal Audio-MPEG-Header 0x… at offset …``, ``Note: Trying to
resync...``, ``[src/libmpg123/layer3.c:…] error: …`` by the dozen. :func:`quiet` points
descriptor 2 at a file while a decoder call runs, puts it back, and sorts what was written:
the seeking chatter is dropped (the truncation it hints at is said in drumroll's words by
:mod:`drumroll.audio.io`), damaged data becomes one warning naming the file, and anything
else is written through to standard error as it was (an error of the library is not lost).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
import threading
import warnings
from collections.abc import Iterator

from drumroll.errors import DrumrollWarning

#: Chatter with nothing in it for the user: libmpg123 doubting its seek table.
_DROPPED = re.compile(r"^Warning: Xing stream size off by more than 1%")
#: libmpg123's reports of damaged frames, skipped over as it resynchronises.
_DAMAGE = re.compile(r"^(Note: (Illegal Audio-MPEG-Header|Trying to resync|Skipped \d+ "
                     r"bytes)|\[[^\]]*libmpg123[^\]]*\] error: )")

#: One redirection at a time: descriptor 2 is the process's, shared by its threads (a
#: nested one, in the same thread, catches into the outer's file).
_lock = threading.RLock()


@contextlib.contextmanager
def quiet(path: os.PathLike[str] | str) -> Iterator[None]:
    """Run the block (a decoder's call on ``path``) with what C code writes to standard error
    caught and sorted (module docstring), whether the block succeeds or raises.

    Where descriptor 2 cannot be duplicated (it is closed) the block simply runs.
    """
    with _lock:
        try:
            saved = os.dup(2)
        except OSError:
            saved = None
        if saved is None:
            yield
            return
        text = ""
        try:
            with tempfile.TemporaryFile() as caught:
                sys.stderr.flush()
                os.dup2(caught.fileno(), 2)
                try:
                    yield
                finally:
                    sys.stderr.flush()
                    os.dup2(saved, 2)
                    caught.seek(0)
                    text = caught.read().decode("utf-8", "replace")
        finally:
            os.close(saved)
            _sort(path, text)


def _sort(path: os.PathLike[str] | str, text: str) -> None:
    """Drop, word or pass on what a decoder wrote (see the module docstring)."""
    damaged = False
    passed = []
    for line in text.splitlines(keepends=True):
        if _DROPPED.match(line):
            continue
        if _DAMAGE.match(line):
            damaged = True
            continue
        passed.append(line)
    if passed:
        sys.stderr.write("".join(passed))
        sys.stderr.flush()
    if damaged:
        # The same words at every call on the file: shown once.
        warnings.warn(f"{path}: the MP3 decoder met damaged data and skipped over it; an "
                      "impact there may be lost", DrumrollWarning, stacklevel=3)
