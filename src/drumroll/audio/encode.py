"""Writing a recording as a phone, a camera or a messaging app would: AAC or ALAC in ``.m4a``,
AAC beside a video in ``.mp4``/``.mov``, Opus or Vorbis in ``.webm``/``.mkv``, AMR-NB in
``.3gp``, MP3, raw AAC.

The one encoder the tests, the benchmark (``benchmarks/onsets.py``) and the bundled
``data/pingpong.m4a`` (``examples/make_phone_recording.py``) share, so that what they measure
is one thing: FFmpeg's encoders through PyAV, imported only when this module is. A rate the
codec cannot take is converted first with :func:`scipy.signal.resample_poly` (a linear-phase
filter applied at the exact ratio: no delay, no drift), so that the timing measured is the
codec's own.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av
import numpy as np
from scipy import signal


@dataclass(frozen=True)
class Preset:
    """How one kind of file is made.

    Attributes
    ----------
    suffix
        The file's suffix (it picks the container).
    codec
        FFmpeg's encoder.
    bit_rate
        Bits per second (None: the codec's own choice, or lossless).
    sample_rate
        The rate the codec is given (None: the recording's, or the nearest the codec takes).
    video
        Also write a small video track first, as a camera does (the audio is stream 1 of the
        file and audio stream 0).
    channels
        The channels the codec takes, if it takes only one count (AMR one, FFmpeg's Vorbis
        encoder two): a recording is mixed down to mono, or its mono written on each.
    description
        What it is, in words.
    """

    suffix: str
    codec: str
    bit_rate: int | None = None
    sample_rate: int | None = None
    video: bool = False
    channels: int | None = None
    description: str = ""


#: The files people make, by name.
PRESETS: dict[str, Preset] = {
    "alac": Preset(".m4a", "alac", description="ALAC (lossless) in .m4a, a voice-memo app's "
                   "lossless setting"),
    "flac-mkv": Preset(".mkv", "flac", description="FLAC in Matroska"),
    "aac-128": Preset(".m4a", "aac", 128_000, description="AAC 128 kb/s in .m4a, a voice "
                      "memo"),
    "aac-64": Preset(".m4a", "aac", 64_000, description="AAC 64 kb/s in .m4a, a voice memo at "
                     "a low setting"),
    "aac-adts": Preset(".aac", "aac", 128_000, description="raw AAC 128 kb/s (ADTS), an "
                       "Android recorder's .aac"),
    "mp4-video": Preset(".mp4", "aac", 128_000, video=True, description="a camera's .mp4: "
                        "H.264 video and AAC 128 kb/s"),
    "mov-video": Preset(".mov", "aac", 128_000, video=True, description="a camera's .mov: "
                        "H.264 video and AAC 128 kb/s"),
    "opus-64": Preset(".webm", "libopus", 64_000, 48_000, description="Opus 64 kb/s in .webm, "
                      "a browser's or messaging app's recording"),
    "opus-32": Preset(".webm", "libopus", 32_000, 48_000, description="Opus 32 kb/s in .webm, "
                      "a voice message"),
    "opus-mkv": Preset(".mkv", "libopus", 64_000, 48_000, description="Opus 64 kb/s in "
                       "Matroska"),
    "vorbis-webm": Preset(".webm", "vorbis", 128_000, channels=2, description="Vorbis in "
                          ".webm (stereo: FFmpeg's Vorbis encoder takes two channels)"),
    "mp3-128": Preset(".mp3", "libmp3lame", 128_000, description="MP3 128 kb/s"),
    "amr-nb": Preset(".3gp", "libopencore_amrnb", 12_200, 8_000, channels=1,
                     description="AMR-NB 12.2 kb/s at 8 kHz in .3gp (mono), a phone's voice "
                     "recorder"),
}

#: Video written beside the audio: tiny black frames (what is measured is the audio).
_VIDEO_SIZE, _VIDEO_FPS = (64, 48), 25


def can_encode(preset: str | Preset) -> bool:
    """Whether the installed PyAV's FFmpeg has the encoder ``preset`` needs (its wheels'
    builds differ: 18.1.0 carries the AMR-NB encoder, libopencore_amrnb, 18.1.1 does not;
    both decode AMR, which is what reading a phone's file needs)."""
    chosen = PRESETS[preset] if isinstance(preset, str) else preset
    try:
        av.Codec(chosen.codec, "w")
    except av.codec.codec.UnknownCodecError:
        return False
    return True


def _rate_for(preset: Preset, codec: av.Codec, rate: int) -> int:
    if preset.sample_rate:
        return preset.sample_rate
    rates = codec.audio_rates
    if not rates or rate in rates:
        return rate
    higher = [r for r in rates if r >= rate]
    return min(higher) if higher else max(rates)


def _resample(x: np.ndarray, rate_in: int, rate_out: int) -> np.ndarray:
    if rate_in == rate_out:
        return x
    ratio = Fraction(rate_out, rate_in)
    return signal.resample_poly(x, ratio.numerator, ratio.denominator, axis=0)


def encode(samples: np.ndarray, sample_rate: int, path: str | os.PathLike[str],
           preset: str | Preset, *, extra_streams: Sequence[np.ndarray] = (),
           faststart: bool = False, gap_s: tuple[float, float] | None = None) -> Path:
    """Write ``samples`` to ``path`` as ``preset`` makes them.

    Parameters
    ----------
    samples
        ``(n,)`` or ``(n, channels)`` samples, full scale 1.
    sample_rate
        Their rate.
    path
        The file to write (its suffix should be the preset's).
    preset
        A name of :data:`PRESETS` or a :class:`Preset`.
    extra_streams
        More recordings at the same rate, written as further audio streams of the file (a
        camera with two microphones, a dubbed video).
    faststart
        Put an MP4's index (``moov``) before the audio instead of after it.
    gap_s
        ``(at, length)``: leave out ``length`` seconds of the audio at ``at`` seconds, with
        timestamps that say so (a recorder that dropped buffers).

    Returns
    -------
    Path
        ``path``.
    """
    chosen = PRESETS[preset] if isinstance(preset, str) else preset
    path = Path(path)
    try:
        codec = av.Codec(chosen.codec, "w")
    except av.codec.codec.UnknownCodecError:
        raise ValueError(f"{path.name}: PyAV {av.__version__} has no {chosen.codec} encoder "
                         "(see can_encode)") from None
    rate = _rate_for(chosen, codec, int(sample_rate))
    tracks = []
    for x in (samples, *extra_streams):
        x = np.asarray(x, dtype=np.float64)
        x = x[:, None] if x.ndim == 1 else x
        if chosen.channels is not None and x.shape[1] != chosen.channels:
            x = np.repeat(x.mean(axis=1, keepdims=True), chosen.channels, axis=1)
        tracks.append(_resample(x, int(sample_rate), rate).astype(np.float32))
    options = {"movflags": "+faststart"} if faststart else {}
    with av.open(str(path), "w", options=options) as out:
        video = None
        if chosen.video:
            name = "libx264" if "libx264" in av.codecs_available else "mpeg4"
            video = out.add_stream(name, rate=_VIDEO_FPS)
            video.width, video.height = _VIDEO_SIZE
            video.pix_fmt = "yuv420p"
        streams = []
        for x in tracks:
            layout = "mono" if x.shape[1] == 1 else "stereo"
            stream = out.add_stream(chosen.codec, rate=rate, layout=layout)
            if chosen.bit_rate:
                stream.bit_rate = chosen.bit_rate
            if chosen.codec == "vorbis":  # FFmpeg's own Vorbis encoder is "experimental"
                stream.codec_context.options = {"strict": "experimental"}
            streams.append(stream)
        for stream, x in zip(streams, tracks, strict=True):
            _encode_audio(out, stream, x, rate, gap_s)
        if video is not None:
            n_frames = int(np.ceil(tracks[0].shape[0] / rate * _VIDEO_FPS))
            black = np.zeros((_VIDEO_SIZE[1], _VIDEO_SIZE[0], 3), dtype=np.uint8)
            for k in range(n_frames):
                frame = av.VideoFrame.from_ndarray(black, format="rgb24")
                frame.pts = k
                out.mux(video.encode(frame))
            out.mux(video.encode(None))
    return path


def _encode_audio(out: av.container.OutputContainer, stream: av.AudioStream, x: np.ndarray,
                  rate: int, gap_s: tuple[float, float] | None) -> None:
    """Feed ``x`` to ``stream`` in blocks with sample timestamps (PyAV re-blocks them into
    the codec's frames and converts the sample format)."""
    layout = "mono" if x.shape[1] == 1 else "stereo"
    skip = (round(gap_s[0] * rate), round((gap_s[0] + gap_s[1]) * rate)) if gap_s else None
    block = 4096
    for i in range(0, x.shape[0], block):
        chunk = x[i: i + block]
        if skip is not None and i + chunk.shape[0] > skip[0] and i < skip[1]:
            continue  # left out: the blocks after it keep their timestamps
        frame = av.AudioFrame.from_ndarray(np.ascontiguousarray(chunk.T), format="fltp",
                                           layout=layout)
        frame.sample_rate = rate
        frame.pts = i
        frame.time_base = Fraction(1, rate)
        out.mux(stream.encode(frame))
    out.mux(stream.encode(None))
