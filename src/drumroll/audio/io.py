"""Reading recordings: any container soundfile reads, any length, in bounded memory.

Everything is read through :class:`soundfile.SoundFile` in blocks and mixed down to mono
``float64`` on the fly, so an hour-long recording costs no more memory than a short one.
Problems a user can fix are raised as :class:`~drumroll.errors.AudioError` with one line that
names the file; clipping is only a :class:`~drumroll.errors.DrumrollWarning` because the
impact *times* usually survive it.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import soundfile as sf

from drumroll.errors import AudioError, DrumrollWarning

#: Frames per block when streaming (about 1.5 s at 44.1 kHz: big enough to amortise the
#: per-call overhead of the filters, small enough that memory does not matter).
DEFAULT_BLOCK_FRAMES = 1 << 16

#: Lowest sample rate accepted: below this an impact's click is gone from the recording.
MIN_SAMPLE_RATE = 4000

#: A run of this many consecutive full-scale samples is taken as clipping (a single
#: full-scale sample is legitimate, a flat top of several is not).
_CLIP_RUN = 3

#: A recording whose peak is below this (about -140 dBFS) holds no sound at all.
_SILENCE_PEAK = 1e-7


@dataclass(frozen=True)
class AudioInfo:
    """What the header of a recording says.

    Attributes
    ----------
    path
        The file.
    sample_rate
        Samples per second per channel.
    frames
        Samples per channel (as declared; a truncated file may hold fewer).
    channels
        Number of channels (they are averaged to mono when read).
    format, subtype
        soundfile's names for the container and the sample encoding.
    """

    path: Path
    sample_rate: int
    frames: int
    channels: int
    format: str
    subtype: str

    @property
    def duration_s(self) -> float:
        """Declared length in seconds."""
        return self.frames / self.sample_rate


def _open(path: Path) -> sf.SoundFile:
    if not path.exists():
        raise AudioError(f"{path}: no such file")
    if path.is_dir():
        raise AudioError(f"{path}: is a directory, expected an audio file")
    if path.stat().st_size == 0:
        raise AudioError(f"{path}: empty file (zero-length audio)")
    try:
        return sf.SoundFile(path)
    except (sf.LibsndfileError, RuntimeError, TypeError) as exc:
        detail = " ".join(str(exc).split())  # libsndfile messages may span lines
        raise AudioError(f"{path}: not a readable audio file, or its header is damaged "
                         f"({detail})") from None
    except OSError as exc:
        raise AudioError(f"{path}: cannot open ({exc.strerror or exc})") from None


def probe(path: str | os.PathLike[str]) -> AudioInfo:
    """Check that ``path`` is a readable, non-empty recording and return its header.

    Raises
    ------
    AudioError
        Missing file, a directory, not audio, a damaged header, zero-length audio or a sample
        rate too low to time impacts.
    """
    path = Path(path)
    with _open(path) as f:
        info = AudioInfo(path, int(f.samplerate), int(f.frames), int(f.channels),
                         str(f.format), str(f.subtype))
    if info.frames <= 0:
        raise AudioError(f"{path}: holds no audio (zero-length)")
    if info.sample_rate < MIN_SAMPLE_RATE:
        raise AudioError(f"{path}: sample rate {info.sample_rate} Hz is too low to time "
                         f"impacts (need at least {MIN_SAMPLE_RATE} Hz)")
    return info


def _clip_level(subtype: str) -> float:
    # Integer encodings saturate one step below +1; soundfile scales them to [-1, 1).
    bits = {"PCM_S8": 8, "PCM_U8": 8, "PCM_16": 16, "PCM_24": 24, "PCM_32": 32}.get(subtype)
    if bits is None:
        return 1.0 - 1e-6
    return 1.0 - 2.0 ** (1 - bits) * 1.5


def iter_blocks(path: str | os.PathLike[str], block_frames: int = DEFAULT_BLOCK_FRAMES, *,
                start: int = 0, stop: int | None = None,
                check: bool = True) -> Iterator[np.ndarray]:
    """Yield the recording as consecutive mono ``float64`` blocks.

    Parameters
    ----------
    path
        Any file soundfile reads.
    block_frames
        Samples per yielded block (the last one may be shorter).
    start, stop
        Frame range to read (``stop=None``: to the end).
    check
        Validate the samples: NaN/inf raise :class:`AudioError`, clipping warns, and a
        recording that turns out to be silent raises :class:`AudioError` once it is exhausted.

    Yields
    ------
    numpy.ndarray
        1-D mono blocks; multichannel audio is averaged across channels.
    """
    info = probe(path)
    level = _clip_level(info.subtype)
    run = 0
    clipped = 0
    peak = 0.0
    total = 0
    with _open(info.path) as f:
        if start:
            f.seek(start)
        remaining = (stop - start) if stop is not None else None
        while remaining is None or remaining > 0:
            n = block_frames if remaining is None else min(block_frames, remaining)
            try:
                block = f.read(n, dtype="float64", always_2d=True)
            except (sf.LibsndfileError, RuntimeError) as exc:
                raise AudioError(f"{info.path}: audio data damaged after {total} samples "
                                 f"({' '.join(str(exc).split())})") from None
            if block.shape[0] == 0:
                break
            if remaining is not None:
                remaining -= block.shape[0]
            if check:
                if not np.isfinite(block).all():
                    bad = int(np.argmin(np.isfinite(block).all(axis=1)))
                    raise AudioError(f"{info.path}: NaN or infinite sample at "
                                     f"{(start + total + bad) / info.sample_rate:.6f} s")
                full = (np.abs(block) >= level).any(axis=1)
                if full.any():
                    run, n_clipped = _count_clip_runs(full, run)
                    clipped += n_clipped
                else:
                    run = 0
                peak = max(peak, float(np.abs(block).max()))
            total += block.shape[0]
            yield block.mean(axis=1) if block.shape[1] > 1 else block[:, 0]
    if not check:
        return
    if total == 0:
        raise AudioError(f"{info.path}: holds no audio (zero-length or truncated)")
    if peak < _SILENCE_PEAK and start == 0 and stop is None:
        raise AudioError(f"{info.path}: the recording is silent")
    if clipped:
        warnings.warn(f"{info.path}: clipped in {clipped} place(s); impact times are kept but "
                      "amplitudes near full scale are unreliable", DrumrollWarning, stacklevel=2)


def _count_clip_runs(full: np.ndarray, run: int) -> tuple[int, int]:
    """Count runs of at least ``_CLIP_RUN`` full-scale samples; carry the open run across
    blocks. Returns the run length at the block's end and the number of runs that reached
    the limit inside this block."""
    # Run lengths of True values, the first one continuing ``run`` from the previous block.
    padded = np.concatenate(([False], full, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2]
    lengths = ends - starts
    if starts.size and starts[0] == 0:
        lengths = lengths.copy()
        lengths[0] += run
        if run >= _CLIP_RUN:  # already counted in the previous block
            lengths[0] = 0
    n = int(np.count_nonzero(lengths >= _CLIP_RUN))
    tail = int(lengths[-1]) if ends.size and ends[-1] == full.size else 0
    return tail, n


def read_audio(path: str | os.PathLike[str], *, start: int = 0,
               stop: int | None = None) -> tuple[np.ndarray, int]:
    """Read (part of) a recording into memory as mono ``float64``.

    Meant for short recordings and for excerpts of long ones; the onset detector itself
    streams with :func:`iter_blocks`.

    Returns
    -------
    samples, sample_rate
    """
    info = probe(path)
    blocks = list(iter_blocks(path, start=start, stop=stop))
    return (np.concatenate(blocks) if blocks else np.zeros(0)), info.sample_rate


def read_excerpt(path: str | os.PathLike[str], start: int, stop: int,
                 channel: int | None = None) -> np.ndarray:
    """Read frames ``[start, stop)`` as mono ``float64`` without validating them again:
    the mean of the channels, or only ``channel`` (0-based).

    Frames outside the file are returned as zeros, so callers can ask for windows that hang
    over either end.
    """
    lo = max(start, 0)
    out = np.zeros(max(stop - start, 0))
    if stop <= lo:
        return out
    with _open(Path(path)) as f:
        if lo >= f.frames > 0:
            return out
        f.seek(lo)
        block = f.read(stop - lo, dtype="float64", always_2d=True)
    if channel is not None:
        mono = block[:, channel]
    else:
        mono = block.mean(axis=1) if block.shape[1] > 1 else block[:, 0]
    out[lo - start: lo - start + mono.size] = mono
    return out
