"""What a recording holds (:class:`AudioInfo`): both readers, soundfile's and FFmpeg's, give
one, so it lives below both."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path


@dataclass(frozen=True)
class AudioInfo:
    """What a recording holds.

    Attributes
    ----------
    path
        The file.
    sample_rate
        Samples per second per channel.
    frames
        Samples per channel (as declared by a soundfile header, where a truncated file may
        hold fewer; exact for a file FFmpeg decodes, which is decoded whole).
    channels
        Number of channels (they are averaged to mono when read).
    format, subtype
        soundfile's names for the container and the sample encoding; for a file FFmpeg
        decodes, the container's short name and the decoder's sample format (``FLTP``,
        ``S16``, ``S32P``, ...).
    container, codec
        Short lower-case names: ``wav``/``pcm_16``, ``ogg``/``vorbis``, ``m4a``/``aac``,
        ``mp4``/``aac``, ``3gp``/``amrnb``, ``webm``/``opus``, ...
    stream
        Which audio stream of the file (0-based among its audio streams).
    bit_rate
        Bits per second of a lossy codec's stream (what was stored; from the file's size for
        soundfile's formats); None for lossless audio.
    lossless
        Whether the codec gives back exactly the samples it was given.
    decoder
        ``"soundfile"`` or ``"ffmpeg"``.
    damage
        What the reader found wrong with a file it still reads (a truncated file: its header
        promises more audio than it holds), in words; None for a whole file.
    """

    path: Path
    sample_rate: int
    frames: int
    channels: int
    format: str
    subtype: str
    container: str = ""
    codec: str = ""
    stream: int = 0
    bit_rate: int | None = None
    lossless: bool = True
    decoder: str = "soundfile"
    damage: str | None = None

    @property
    def duration_s(self) -> float:
        """Length in seconds."""
        return self.frames / self.sample_rate

    def holding(self, frames: int) -> AudioInfo:
        """This file as it turned out to hold ``frames`` samples per channel: fewer than its
        header declares when it was cut short, and then the bit rate taken from its size
        (what was stored) is over the audio it holds, not over the length its header
        declares (which would put an MP3 of 128 kb/s cut to two thirds at 85)."""
        if not 0 < frames < self.frames:
            return self
        bit_rate = (None if self.bit_rate is None
                    else round(self.bit_rate * self.frames / frames))
        return replace(self, frames=frames, bit_rate=bit_rate)
