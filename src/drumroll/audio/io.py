"""Reading recordings: WAV, FLAC, OGG, MP3 and what phones and cameras write, any length, in
bounded memory.

Two readers behind one interface. What soundfile (libsndfile) reads, it reads: WAV, FLAC,
AIFF, Ogg Vorbis and Opus, MP3. Everything else (AAC and ALAC in ``.m4a``/``.mp4``/``.mov``,
AMR in ``.3gp``, Opus and Vorbis in ``.webm``/``.mkv``, raw ``.aac``, the audio of a video) is
decoded by FFmpeg through PyAV (:mod:`drumroll.audio.decode`), which is imported only then:
reading a WAV never loads it. A file offers several audio streams only through FFmpeg; the
functions here take ``stream`` (0-based among the file's audio streams), and
:class:`AudioSource` carries one wherever a path goes.

Everything is read in blocks and mixed down to mono ``float64`` on the fly, so an hour-long
recording costs no more memory than a short one. Problems a user can fix are raised as
:class:`~drumroll.errors.AudioError` with one line that names the file; clipping is only a
:class:`~drumroll.errors.DrumrollWarning` because the impact *times* usually survive it.
"""

from __future__ import annotations

import os
import re
import threading
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import soundfile as sf

from drumroll.audio.chatter import quiet
from drumroll.audio.info import AudioInfo
from drumroll.errors import AudioError, DrumrollWarning

if TYPE_CHECKING:
    from drumroll.audio.decode import Decoded, RawReader

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


#: soundfile subtypes of lossy codecs, and their usual names (transform codecs smear a
#: click's sound ahead of it; the others quantise coarsely).
_SF_LOSSY = {"VORBIS": "vorbis", "OPUS": "opus", "MPEG_LAYER_I": "mp1",
             "MPEG_LAYER_II": "mp2", "MPEG_LAYER_III": "mp3", "GSM610": "gsm",
             "IMA_ADPCM": "adpcm_ima", "MS_ADPCM": "adpcm_ms", "VOX_ADPCM": "adpcm_vox",
             "G721_32": "g721", "G723_24": "g723", "G723_40": "g723",
             "NMS_ADPCM_16": "adpcm_nms", "NMS_ADPCM_24": "adpcm_nms",
             "NMS_ADPCM_32": "adpcm_nms"}


@dataclass(frozen=True)
class AudioSource:
    """One audio stream of a file, wherever a path goes.

    It is path-like (:func:`os.fspath` gives the file; ``name``, ``suffix`` and ``stem``
    are the file's), so code that takes a path and hands it to the functions of this module
    reads the stream it names without knowing that streams exist (the onset figure of a
    video's second audio stream, say). It pickles, so it crosses to worker processes.

    Attributes
    ----------
    path
        The file.
    stream
        Which of its audio streams, 0-based.
    """

    path: Path
    stream: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "path", Path(self.path))

    def __fspath__(self) -> str:
        return os.fspath(self.path)

    def __str__(self) -> str:
        return str(self.path)

    @property
    def name(self) -> str:
        """The file's name."""
        return self.path.name

    @property
    def suffix(self) -> str:
        """The file's suffix."""
        return self.path.suffix

    @property
    def stem(self) -> str:
        """The file's name without its suffix."""
        return self.path.stem


def _source(path: str | os.PathLike[str], stream: int | None) -> tuple[Path, int]:
    """The file and the stream to read: ``stream`` if given, else an :class:`AudioSource`'s,
    else the first."""
    if isinstance(path, AudioSource):
        file, chosen = path.path, path.stream if stream is None else stream
    else:
        file, chosen = Path(path), 0 if stream is None else stream
    if chosen < 0:
        raise AudioError(f"{file}: no audio stream {chosen}: streams are numbered from 0")
    return file, int(chosen)


def _check_file(path: Path) -> None:
    if not path.exists():
        raise AudioError(f"{path}: no such file")
    if path.is_dir():
        raise AudioError(f"{path}: is a directory, expected an audio file")
    if path.stat().st_size == 0:
        raise AudioError(f"{path}: empty file (zero-length audio)")


#: The last file FFmpeg decoded (one entry), keyed by its path, stream, size and mtime: the
#: detector reads a file several times (probe, the streaming pass, excerpts), the onset
#: figure again, and a compressed file is decoded once for all of them. An entry replaced
#: here is freed when its last reader lets go of it (its temporary file has no name: the
#: system frees it then, or when the process ends).
_DECODED: dict[tuple[str, int, int, int], Decoded] = {}
_DECODED_LOCK = threading.Lock()


def _decoded(path: Path, stream: int, soundfile_said: str) -> Decoded:
    # PyAV (FFmpeg) is imported here, for the first file that needs it.
    from drumroll.audio import decode

    st = path.stat()
    key = (str(path.resolve()), stream, st.st_size, st.st_mtime_ns)
    with _DECODED_LOCK:
        hit = _DECODED.get(key)
    if hit is not None:
        return hit
    try:
        decoded = decode.decode(path, stream)
    except decode.NotMedia as exc:
        raise AudioError(f"{path}: not a readable audio file, or its header is damaged "
                         f"({soundfile_said}; FFmpeg: {exc.detail})") from None
    decode.warn(decoded)
    with _DECODED_LOCK:
        _DECODED.clear()
        _DECODED[key] = decoded
    return decoded


def forget_decoded() -> None:
    """Let go of the decoded copy of the last compressed file read (kept so that reading
    the file again costs no second decoding; see :mod:`drumroll.audio.decode`)."""
    with _DECODED_LOCK:
        _DECODED.clear()


def _soundfile_info(f: sf.SoundFile, path: Path) -> AudioInfo:
    subtype = str(f.subtype)
    lossy = subtype in _SF_LOSSY
    bit_rate = None
    if lossy and f.frames > 0 and f.samplerate > 0:
        # soundfile does not say; the file's size over its length is what was stored.
        bit_rate = round(8 * path.stat().st_size / (f.frames / f.samplerate))
    return AudioInfo(path, int(f.samplerate), int(f.frames), int(f.channels), str(f.format),
                     subtype, container=str(f.format).lower(),
                     codec=_SF_LOSSY.get(subtype, subtype.lower()), stream=0,
                     bit_rate=bit_rate, lossless=not lossy, decoder="soundfile",
                     damage=_damage(f.extra_info))


#: What libsndfile's log says of a file cut short: a chunk whose declared size the file does
#: not hold (WAV, AIFF: ``data : 444868 (should be 222412)``), or an Ogg stream that stops
#: without its end-of-stream page.
_SHORT_CHUNK = re.compile(r"^\s*(data|SSND)\s*:\s*(\d+)\s*\(should be (\d+)\)", re.MULTILINE)
_NO_OGG_END = "lacks an end-of-stream"


def _damage(log: str) -> str | None:
    """A truncation that libsndfile's log of the file reports, in words (None: whole)."""
    short = _SHORT_CHUNK.search(log)
    if short:
        declared, held = int(short.group(2)), int(short.group(3))
        return (f"the file is cut short: its header declares {declared} bytes of audio and "
                f"it holds {held} ({held / declared:.0%}); what is there is analysed")
    if _NO_OGG_END in log:
        return ("the file is cut short: its last Ogg page lacks the end-of-stream mark; what "
                "is there is analysed")
    return None


def _open(path: Path, stream: int) -> tuple[sf.SoundFile | RawReader, AudioInfo]:
    """A reader of ``path``'s audio stream ``stream`` (soundfile's, or one over FFmpeg's
    decoding) and what it holds."""
    _check_file(path)
    try:
        with quiet(path):  # libmpg123's chatter on a damaged MP3
            f = sf.SoundFile(path)
    except (sf.LibsndfileError, RuntimeError, TypeError) as exc:
        said = " ".join(str(exc).split())  # libsndfile messages may span lines
        decoded = _decoded(path, stream, said)
        return decoded.reader(), decoded.info
    except OSError as exc:
        raise AudioError(f"{path}: cannot open ({exc.strerror or exc})") from None
    if stream != 0:
        f.close()
        raise AudioError(f"{path}: no audio stream {stream}: it holds 1 audio stream, numbered "
                         f"from 0 (container {str(f.format).lower()})")
    info = _soundfile_info(f, path)
    return (_QuietReader(f, path) if f.format == "MP3" else f), info


class _QuietReader:
    """A :class:`soundfile.SoundFile` of an MP3 whose seeks and reads run inside
    :func:`~drumroll.audio.chatter.quiet` (libmpg123 reports damaged frames as it reads)."""

    def __init__(self, file: sf.SoundFile, path: Path) -> None:
        self._file, self._path = file, path

    def __getattr__(self, name: str):
        return getattr(self._file, name)

    def __enter__(self) -> _QuietReader:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._file.close()

    def seek(self, frames: int, *args, **kwargs) -> int:
        with quiet(self._path):
            return self._file.seek(frames, *args, **kwargs)

    def read(self, *args, **kwargs) -> np.ndarray:
        with quiet(self._path):
            return self._file.read(*args, **kwargs)


def probe(path: str | os.PathLike[str], *, stream: int | None = None) -> AudioInfo:
    """Check that ``path`` is a readable, non-empty recording and say what it holds.

    A file soundfile cannot read is decoded by FFmpeg here (once: later reads reuse it).

    Parameters
    ----------
    path
        The recording (or an :class:`AudioSource`).
    stream
        Which audio stream (0-based; default the first, or the :class:`AudioSource`'s).

    Raises
    ------
    AudioError
        Missing file, a directory, not audio, a damaged header, no such audio stream, a codec
        FFmpeg cannot decode, a truncated file, zero-length audio or a sample rate too low to
        time impacts.
    """
    file, stream = _source(path, stream)
    reader, info = _open(file, stream)
    with reader:
        pass
    if info.frames <= 0:
        raise AudioError(f"{file}: holds no audio (zero-length)")
    if info.sample_rate < MIN_SAMPLE_RATE:
        raise AudioError(f"{file}: sample rate {info.sample_rate} Hz is too low to time "
                         f"impacts (need at least {MIN_SAMPLE_RATE} Hz)")
    if info.damage:
        # stacklevel 1: one place, so that the probes of one file (detection, the figure)
        # give one line
        warnings.warn(f"{file}: {info.damage}", DrumrollWarning, stacklevel=1)
    return info


def _clip_level(subtype: str) -> float:
    # Integer encodings saturate one step below +1; soundfile scales them to [-1, 1). FFmpeg
    # decodes 24-bit ALAC and FLAC into 32-bit words: the 24-bit level catches both.
    bits = {"PCM_S8": 8, "PCM_U8": 8, "PCM_16": 16, "PCM_24": 24, "PCM_32": 32, "U8": 8,
            "U8P": 8, "S16": 16, "S16P": 16, "S32": 24, "S32P": 24}.get(subtype)
    if bits is None:
        return 1.0 - 1e-6
    return 1.0 - 2.0 ** (1 - bits) * 1.5


def iter_blocks(path: str | os.PathLike[str], block_frames: int = DEFAULT_BLOCK_FRAMES, *,
                start: int = 0, stop: int | None = None, check: bool = True,
                stream: int | None = None) -> Iterator[np.ndarray]:
    """Yield the recording as consecutive mono ``float64`` blocks.

    Parameters
    ----------
    path
        Any recording soundfile or FFmpeg reads (or an :class:`AudioSource`).
    block_frames
    block_frames
        Samples per yielded block (the last one may be shorter).
    start, stop
        Frame range to read (``stop=None``: to the end).
    check
        Validate the samples: NaN/inf raise :class:`AudioError`, clipping warns, and a
        recording that turns out to be silent raises :class:`AudioError` once it is exhausted.
    stream
        Which audio stream (0-based; default the first, or the :class:`AudioSource`'s).

    Yields
    ------
    numpy.ndarray
        1-D mono blocks; multichannel audio is averaged across channels.
    """
    file, stream = _source(path, stream)
    info = probe(file, stream=stream)
    level = _clip_level(info.subtype)
    run = 0
    clipped = 0
    peak = 0.0
    total = 0
    reader, _ = _open(file, stream)
    with reader as f:
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
    if stop is None and info.damage is None and start + total < 0.99 * info.frames:
        # The header promised more than the file holds (an MP3's Xing header of the whole
        # file, cut short; libsndfile's log says nothing of it)
        warnings.warn(f"{info.path}: the file is cut short: its header declares "
                      f"{info.duration_s:.2f} s of audio and it holds "
                      f"{(start + total) / info.sample_rate:.2f} s; what is there is analysed",
                      DrumrollWarning, stacklevel=1)


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


def read_audio(path: str | os.PathLike[str], *, start: int = 0, stop: int | None = None,
               stream: int | None = None, check: bool = True) -> tuple[np.ndarray, int]:
    """Read (part of) a recording into memory as mono ``float64``.

    Meant for short recordings and for excerpts of long ones; the onset detector itself
    streams with :func:`iter_blocks`.

    Parameters
    ----------
    path
        Any recording soundfile or FFmpeg reads (or an :class:`AudioSource`).
    start, stop
        Frame range to read (``stop=None``: to the end).
    stream
        Which audio stream (0-based; default the first, or the :class:`AudioSource`'s).
    check
        Validate the samples as :func:`iter_blocks` does.

    Returns
    -------
    samples, sample_rate
    """
    file, stream = _source(path, stream)
    info = probe(file, stream=stream)
    blocks = list(iter_blocks(file, start=start, stop=stop, stream=stream, check=check))
    return (np.concatenate(blocks) if blocks else np.zeros(0)), info.sample_rate


def read_excerpt(path: str | os.PathLike[str], start: int, stop: int,
                 channel: int | None = None, *, stream: int | None = None) -> np.ndarray:
    """Read frames ``[start, stop)`` as mono ``float64`` without validating them again:
    the mean of the channels, or only ``channel`` (0-based), of audio stream ``stream``
    (default the first, or the :class:`AudioSource`'s).

    Frames outside the file are returned as zeros, so callers can ask for windows that hang
    over either end. For a file FFmpeg decodes these are the very samples
    :func:`iter_blocks` yields (both read its one decoding).
    """
    lo = max(start, 0)
    out = np.zeros(max(stop - start, 0))
    if stop <= lo:
        return out
    file, stream = _source(path, stream)
    reader, _ = _open(file, stream)
    with reader as f:
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
