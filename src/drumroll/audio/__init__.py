"""Reading recordings (see :mod:`drumroll.audio.io`; FFmpeg's decoding in
:mod:`drumroll.audio.decode`, imported only for a file that needs it)."""

from __future__ import annotations

from drumroll.audio.io import (
    AudioInfo,
    AudioSource,
    iter_blocks,
    probe,
    read_audio,
    read_excerpt,
)

__all__ = ["AudioInfo", "AudioSource", "iter_blocks", "probe", "read_audio", "read_excerpt"]
