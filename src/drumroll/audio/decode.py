"""Decoding what soundfile cannot read: phone and camera recordings, through FFmpeg (PyAV).

A voice-memo app writes AAC or ALAC in an ``.m4a``, a camera AAC in an ``.mp4``/``.mov``
beside its video, a messaging app Opus or Vorbis in ``.webm``/``.mkv``, or AMR in a
``.3gp``. PyAV's wheels carry FFmpeg's libraries and codecs, so reading them needs no system
program; this module is imported only when a file needs it (``import av`` costs about 60 ms
and its libraries some 100 MB on disk, see the README).

**Design.** The chosen audio stream is decoded once, front to back, into an unnamed
temporary file of 32-bit float frames (every channel), and every read afterwards (the
detector's streaming pass, its excerpts, the onset figure) is served from that file by
:class:`RawReader`. Decoding a compressed stream is sequential; seeking in it lands on a
packet boundary and restarts the decoder without its history (the first samples after a seek
differ from a straight decode), so excerpts read from a seek would not be the samples that
streaming yielded. The temporary file makes both the same bytes, sample-exact, in bounded
memory (a few decoded frames at a time; an hour of 44.1 kHz mono is 635 MB on disk, none of
it in memory). It is created with :func:`tempfile.TemporaryFile` in the system's temporary
folder (``TMPDIR``), never beside the user's file, and has no name: the system frees it when
it is closed or the process ends, whatever the ending (an exception, Ctrl-C, a kill).

**Time zero is the recording's.** Encoders prepend priming samples (AAC 1024–2112, Opus's
pre-skip, MP3's encoder delay) and containers record how many to drop: an MP4/MOV edit list
or ``iTunSMPB``, Matroska's ``CodecDelay``, Ogg Opus's pre-skip, the LAME header. FFmpeg's
demuxers turn these into "skip samples" that its decoders honour, which the tests check by
cross-correlation (ALAC to the sample; AAC and Opus with no offset above 0.05 ms). A raw AAC
stream (``.aac``, ADTS) records nothing: the 1024 samples of FFmpeg's encoder are taken off,
with a warning. The encoder's padding at the end is cut where the container says the
recording ends. A gap in the packets' timestamps (a recorder that dropped buffers) is filled
with silence, so that the sounds after it keep their times.

Problems are one-line :class:`~drumroll.errors.AudioError` messages that name the container
and codec found: no audio stream, a codec FFmpeg cannot decode, a truncated or damaged file.
"""

from __future__ import annotations

import contextlib
import tempfile
import threading
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import av
import av.logging
import numpy as np

from drumroll.audio.info import AudioInfo
from drumroll.errors import AudioError, DrumrollWarning

#: FFmpeg decoder names → the codec's usual name (the one the timing table and messages use).
_CODEC_NAMES = {"mp3float": "mp3", "mp2float": "mp2", "aac_fixed": "aac", "libopus": "opus",
                "libvorbis": "vorbis", "libopencore_amrnb": "amrnb",
                "libopencore_amrwb": "amrwb", "ac3_fixed": "ac3"}

#: Codecs that give back exactly the samples they were given.
LOSSLESS_CODECS = frozenset({"alac", "flac", "wavpack", "tta", "ape", "mlp", "truehd",
                             "mp4als", "shorten", "tak"})

#: Priming of FFmpeg's AAC-LC encoder (one frame: the MDCT's overlap), taken off a raw AAC
#: stream, which has no container to record it. Other encoders prime more (Apple's 2112).
ADTS_PRIMING = 1024

#: Frames (per channel) buffered before a write to the temporary file.
_WRITE_FRAMES = 1 << 16

#: A timestamp gap shorter than this is rounding (Matroska stores milliseconds), not a gap.
_GAP_S = 0.002

#: Frames the decoded length may fall short of the container's declared length before the
#: file is called truncated (a codec's last frame, rounding of the declared duration).
_SHORT_FRAMES = 4096


def codec_name(decoder: str) -> str:
    """The usual name of the codec an FFmpeg decoder decodes (``mp3float`` → ``mp3``)."""
    return _CODEC_NAMES.get(decoder, decoder)


#: Extensions of a demuxer family that its name does not list.
_ALSO = {"matroska": ("mkv", "mka", "mk3d"), "mov": ("m4v", "m4b", "m4r", "qt"),
         "aac": ("adts",), "ogg": ("oga", "opus")}


def container_name(format_name: str, path: Path) -> str:
    """A short name for FFmpeg's demuxer: its family name (``mov,mp4,m4a,3gp,3g2,mj2``) as
    the file's extension spells it when the family includes it, else the family's first."""
    names = format_name.split(",")
    ext = path.suffix.lower().lstrip(".")
    also = {e for n in names for e in _ALSO.get(n, ())}
    return ext if ext in names or ext in also else names[0]


def is_lossless(codec: str) -> bool:
    """Whether ``codec`` (a usual name) gives back exactly the samples it was given."""
    return codec in LOSSLESS_CODECS or (codec.startswith("pcm_")
                                        and codec not in ("pcm_alaw", "pcm_mulaw"))


class NotMedia(AudioError):
    """FFmpeg does not recognise the file at all (:mod:`drumroll.audio.io` then says that
    neither reader does, quoting both)."""

    def __init__(self, path: Path, detail: str) -> None:
        super().__init__(f"{path}: not a readable audio file, or its header is damaged "
                         f"(FFmpeg: {detail})")
        self.detail = detail


@contextlib.contextmanager
def _ffmpeg_log() -> Iterator[list[tuple[int, str, str]]]:
    """FFmpeg's error messages while decoding, captured (so that the one-line errors can
    quote them) instead of printed; PyAV's logging is off again afterwards."""
    before = av.logging.get_level()
    av.logging.set_level(av.logging.ERROR)
    try:
        with av.logging.Capture() as logs:
            yield logs
    finally:
        av.logging.set_level(before)


def _ffmpeg_says(exc: Exception, logs: list[tuple[int, str, str]]) -> str:
    """FFmpeg's own words on a failure: its last logged error, else the exception's text."""
    if logs:
        return " ".join(logs[-1][2].split())
    return " ".join(str(getattr(exc, "strerror", None) or exc).split())


class Decoded:
    """One audio stream of a file, decoded into an unnamed temporary file of float32 frames.

    Attributes
    ----------
    info
        The recording as decoded (exact length, rate, channels; container and codec).
    warnings
        What the decoding found that the user should know (raw AAC priming, gaps), one line
        each; :func:`drumroll.audio.io.probe` issues them once per decoding.
    """

    def __init__(self, info: AudioInfo, file: IO[bytes], notes: list[str]) -> None:
        self.info = info
        self.warnings = notes
        self._file = file
        self._lock = threading.Lock()

    def read(self, start: int, n: int) -> np.ndarray:
        """Frames ``[start, start + n)`` (clipped to the recording) as ``(n, channels)``
        float32."""
        ch = self.info.channels
        start = min(max(start, 0), self.info.frames)
        n = max(min(n, self.info.frames - start), 0)
        with self._lock:  # readers share one file position
            self._file.seek(start * ch * 4)
            data = self._file.read(n * ch * 4)
        return np.frombuffer(data, dtype="<f4").reshape(-1, ch)

    def reader(self) -> RawReader:
        """A reader with its own position (what :class:`soundfile.SoundFile` offers)."""
        return RawReader(self)

    def close(self) -> None:
        """Free the temporary file (also done when the object is garbage-collected)."""
        self._file.close()


class RawReader:
    """The part of :class:`soundfile.SoundFile`'s interface that :mod:`drumroll.audio.io`
    uses (``samplerate``, ``channels``, ``frames``, ``seek``, ``read``, ``with``), over a
    :class:`Decoded` stream."""

    def __init__(self, decoded: Decoded) -> None:
        self._decoded = decoded
        self._pos = 0
        self.samplerate = decoded.info.sample_rate
        self.channels = decoded.info.channels
        self.frames = decoded.info.frames

    def seek(self, frame: int) -> int:
        self._pos = min(max(int(frame), 0), self.frames)
        return self._pos

    def read(self, frames: int, dtype: str = "float64", always_2d: bool = True) -> np.ndarray:
        block = self._decoded.read(self._pos, frames).astype(dtype)
        self._pos += block.shape[0]
        return block if always_2d else (block[:, 0] if self.channels == 1 else block)

    def __enter__(self) -> RawReader:
        return self

    def __exit__(self, *exc: object) -> None:
        return None


def _describe_streams(container: Any) -> str:
    """``video h264, audio aac``: what a container holds, for messages."""
    parts = []
    for s in container.streams:
        cc = s.codec_context
        parts.append(f"{s.type} {codec_name(cc.name) if cc is not None else 'unknown'}")
    return ", ".join(parts) if parts else "none"


def _open_container(path: Path, logs: list) -> Any:
    try:
        return av.open(str(path), metadata_errors="ignore")
    except av.FFmpegError as exc:
        said = _ffmpeg_says(exc, logs)
        if _is_mp4_family(path):
            raise AudioError(f"{path}: truncated or damaged: an MP4-family file (container "
                             f"{path.suffix.lstrip('.').lower() or 'mp4'}, codec unknown) "
                             f"whose index FFmpeg cannot read ({said}); a recording app that "
                             "was stopped before it finished writes no index") from None
        raise NotMedia(path, said) from None


def _is_mp4_family(path: Path) -> bool:
    """Whether the file starts like an MP4/MOV/3GP (an ``ftyp`` box, or a ``moov``/``mdat``/
    ``wide``/``free`` one for old QuickTime files)."""
    try:
        with open(path, "rb") as f:
            head = f.read(12)
    except OSError:
        return False
    return len(head) >= 8 and head[4:8] in (b"ftyp", b"moov", b"mdat", b"wide", b"free")


def _convert(frame: Any, channels: int) -> np.ndarray:
    """A decoded frame as ``(samples, channels)`` float32 in [-1, 1] full scale."""
    a = frame.to_ndarray()
    a = a.T if frame.format.is_planar else a.reshape(-1, channels)
    if a.dtype == np.int16:
        return a.astype(np.float32) / np.float32(32768.0)
    if a.dtype == np.int32:
        return (a.astype(np.float64) / 2147483648.0).astype(np.float32)
    if a.dtype == np.uint8:
        return (a.astype(np.float32) - 128.0) / np.float32(128.0)
    return a.astype(np.float32, copy=False)


def _declared_frames(stream: Any, container: Any, rate: int) -> int | None:
    """The stream's length as its container declares it (None if it does not): the
    edit-listed duration of an MP4/MOV/3GP stream; a Matroska stream's ``DURATION`` tag, or
    the segment's duration when the file holds this stream alone. (An MP3's or a raw AAC's
    length is only estimated from its bit rate: not a declaration.)"""
    family = container.format.name
    if family.startswith("mov") and stream.duration and stream.time_base is not None:
        return round(float(stream.duration * stream.time_base) * rate)
    if family.startswith("matroska"):
        tag = stream.metadata.get("DURATION") or stream.metadata.get("duration")
        if tag:
            with contextlib.suppress(ValueError):
                h, m, s = tag.split(":")
                return round((3600 * int(h) + 60 * int(m) + float(s)) * rate)
        if container.duration and len(container.streams) == 1:
            return round(container.duration / av.time_base * rate)
    return None


def decode(path: Path, stream: int = 0) -> Decoded:
    """Decode audio stream ``stream`` (0-based among the file's audio streams) of ``path``.

    Raises
    ------
    AudioError
        One line naming the file, the container and the codec: not a media file, no audio
        stream (or not that many), a codec FFmpeg cannot decode, a truncated or damaged
        file, no space for the decoded samples.
    """
    file = tempfile.TemporaryFile(prefix="drumroll-", suffix=".f32")
    try:
        with _ffmpeg_log() as logs:
            container = _open_container(path, logs)
            with container:
                info, notes = _decode_into(file, container, path, stream, logs)
        file.flush()
        return Decoded(info, file, notes)
    except OSError as exc:
        file.close()
        raise AudioError(f"{path}: no room to decode it in the temporary folder "
                         f"{tempfile.gettempdir()} ({exc.strerror or exc}); set TMPDIR to a "
                         "folder with space") from None
    except BaseException:  # an error, Ctrl-C: the temporary file goes with it
        file.close()
        raise


def _decode_into(file: IO[bytes], container: Any, path: Path, index: int, logs: list
                 ) -> tuple[AudioInfo, list[str]]:
    name = container_name(container.format.name, path)
    audio = list(container.streams.audio)
    if not audio:
        raise AudioError(f"{path}: holds no audio stream (container {name}, streams: "
                         f"{_describe_streams(container)})")
    if index >= len(audio):
        count = f"{len(audio)} audio stream{'s' if len(audio) > 1 else ''}"
        raise AudioError(f"{path}: no audio stream {index}: it holds {count}, numbered from 0 "
                         f"(container {name}, streams: {_describe_streams(container)})")
    stream = audio[index]
    cc = stream.codec_context
    if cc is None:
        version = getattr(av, "ffmpeg_version_info", "")
        raise AudioError(f"{path}: audio stream {index} is in a codec FFmpeg cannot decode "
                         f"(container {name}, codec unknown: FFmpeg {version} has no decoder "
                         "for it); convert it to WAV or FLAC with the app that made it")
    codec = codec_name(cc.name)
    where = f"container {name}, codec {codec}"
    for other in container.streams:  # demux only the chosen stream's packets
        if other is not stream:
            with contextlib.suppress(AttributeError, ValueError, TypeError):
                other.discard = av.stream.Discard.all

    rate = channels = 0
    written = 0          # frames written to the temporary file
    origin = None        # the first frame's timestamp, in frames of the recording
    # A raw AAC stream has no container to record its priming (see the module docstring);
    # HE-AAC's differs and is left in.
    adts = container.format.name == "aac" and codec == "aac"
    skip = ADTS_PRIMING if adts and cc.profile in ("LC", None) else 0
    gaps: list[tuple[float, float]] = []
    pending: list[np.ndarray] = []
    n_pending = 0
    packet_bytes = 0
    sample_format = ""

    def flush() -> None:
        nonlocal pending, n_pending
        if pending:
            file.write(np.concatenate(pending).astype("<f4", copy=False).tobytes())
        pending, n_pending = [], 0

    try:
        for packet in container.demux(stream):
            packet_bytes += packet.size
            for frame in packet.decode():
                if not rate:
                    rate, channels = int(frame.sample_rate), int(frame.layout.nb_channels)
                    sample_format = frame.format.name
                elif frame.sample_rate != rate or frame.layout.nb_channels != channels:
                    raise AudioError(
                        f"{path}: the audio changes from {rate} Hz, {channels} channel(s) to "
                        f"{frame.sample_rate} Hz, {frame.layout.nb_channels} channel(s) at "
                        f"{written / rate:.3f} s ({where}); not one recording")
                x = _convert(frame, channels)
                position = written + n_pending
                if frame.pts is not None and frame.time_base is not None:
                    # Where the frame's timestamp puts it, less where the first frame's put
                    # that one: a gap the recorder left is filled, rounding is not.
                    at = round(float(frame.pts * frame.time_base) * rate)
                    if origin is None:
                        origin = at - position
                    gap = at - origin - position
                    if gap > max(_GAP_S * rate, 2 * float(frame.time_base) * rate):
                        gaps.append((position / rate, gap / rate))
                        pending.append(np.zeros((gap, channels), dtype=np.float32))
                        n_pending += gap
                if skip:
                    drop = min(skip, x.shape[0])
                    x, skip = x[drop:], skip - drop
                    if origin is not None:
                        origin += drop  # the samples after the priming start the recording
                pending.append(x)
                n_pending += x.shape[0]
                if n_pending >= _WRITE_FRAMES:
                    written += n_pending
                    flush()
    except av.FFmpegError as exc:
        said = _ffmpeg_says(exc, logs)
        if written + n_pending == 0:  # not audio at all (FFmpeg also guesses by extension)
            raise NotMedia(path, f"{said} ({where})") from None
        raise AudioError(f"{path}: truncated or damaged: the audio stops at "
                         f"{(written + n_pending) / rate:.3f} s ({where}; FFmpeg: {said})"
                         ) from None
    written += n_pending
    flush()
    if written == 0:
        raise NotMedia(path, f"no audio decoded ({where}): zero-length, truncated or not audio")

    declared = _declared_frames(stream, container, rate)
    if declared is not None:
        if written < declared - max(_SHORT_FRAMES, round(0.01 * declared)):
            raise AudioError(f"{path}: truncated: the audio stops at {written / rate:.3f} s of "
                             f"the {declared / rate:.3f} s its container declares ({where})")
        if written > declared > 0:  # the encoder's padding after the last sample
            written = declared
            file.truncate(written * channels * 4)

    duration = written / rate
    bit_rate = round(8 * packet_bytes / duration) if duration > 0 else None
    info = AudioInfo(path, rate, written, channels, name, sample_format.upper(),
                     container=name, codec=codec, stream=index,
                     bit_rate=None if is_lossless(codec) else bit_rate,
                     lossless=is_lossless(codec), decoder="ffmpeg")
    notes = []
    if adts:
        notes.append(f"{path}: a raw AAC stream keeps no record of its encoder's delay: "
                     f"{ADTS_PRIMING} samples ({1e3 * ADTS_PRIMING / rate:.0f} ms) are taken off "
                     "as FFmpeg's encoder adds; another encoder's may leave every onset up to "
                     "25 ms late, which moves no flight (an .m4a records it)")
    if gaps:
        total = sum(g for _, g in gaps)
        first = gaps[0][0]
        notes.append(f"{path}: {len(gaps)} gap(s) in the recording ({1e3 * total:.1f} ms in all, "
                     f"the first at {first:.3f} s), filled with silence so that the sounds after "
                     "them keep their times")
    return info, notes


def warn(decoded: Decoded) -> None:
    """Issue a decoding's warnings (each one line)."""
    for note in decoded.warnings:
        warnings.warn(note, DrumrollWarning, stacklevel=3)
