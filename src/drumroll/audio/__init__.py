"""Reading recordings (see :mod:`drumroll.audio.io`)."""

from __future__ import annotations

from drumroll.audio.io import AudioInfo, iter_blocks, probe, read_audio, read_excerpt

__all__ = ["AudioInfo", "iter_blocks", "probe", "read_audio", "read_excerpt"]
