"""What a recording's codec and sample rate do to the timing of its onsets.

A lossy codec smears an impact's click (a transform codec spreads its noise over the
transform block, pre-echo included; a voice codec at 8 kHz keeps little of it), and a low
sample rate keeps only the lowest part of it. The onsets of such a file move, from one
impact to the next, by more than the extractor's ``sigma_s`` says. ``benchmarks/onsets.py``
measures it: the corpus and the real ping-pong encoded as phones encode, each onset against
the same onset of the lossless original; the spread of those shifts (1.4826 × their MAD, the
sd a Gaussian with that MAD has) is the floor here, added in quadrature to every onset's
``sigma_s`` by :func:`drumroll.onsets.detect`, with a one-line warning.
"""

from __future__ import annotations

from dataclasses import dataclass

from drumroll.audio.io import AudioInfo

#: Timing floors of lossy codecs: ``(codec, lowest bit rate in b/s the row holds for, sd in
#: seconds)``, the first row that matches wins. From ``python benchmarks/onsets.py
#: --phone-only`` (2025-07; 12 corpus rolls and the real ping-pong, 721 onsets), the shift
#: of each onset from the lossless original's, less the recording's median shift: 1.4826 ×
#: MAD, pooled over corpus and ping-pong, rounded up to 10 µs:
#:
#: ========================  =========  ==========
#: codec                     MAD (ms)   floor (ms)
#: ========================  =========  ==========
#: AAC 128 kb/s              TBD        TBD
#: ========================  =========  ==========
CODEC_FLOORS: tuple[tuple[str, int, float], ...] = (
    ("aac", 96_000, 0.02e-3),
    ("aac", 0, 0.05e-3),
    ("opus", 48_000, 0.03e-3),
    ("opus", 0, 0.06e-3),
    ("mp3", 0, 0.03e-3),
    ("vorbis", 0, 0.03e-3),
    ("amrnb", 0, 0.3e-3),
    ("amrwb", 0, 0.2e-3),
)

#: An unmeasured lossy codec is given the largest floor of the transform codecs above (AAC,
#: Opus, MP3, Vorbis): no smaller than the worst measured, short of a measurement.
_UNMEASURED = max(sd for codec, _, sd in CODEC_FLOORS if codec not in ("amrnb", "amrwb"))

#: Timing floors of low sample rates, lossless: ``(highest rate in Hz the row holds for, sd
#: in seconds)``, the first row that matches wins (same benchmark, the recordings resampled).
RATE_FLOORS: tuple[tuple[int, float], ...] = (
    (8_000, 0.2e-3),
    (16_000, 0.05e-3),
)

#: What each codec does, in the warning.
_DOES = {"amrnb": "removes most of an impact's click", "amrwb": "removes much of an impact's "
         "click"}
_NAMES = {"aac": "AAC", "opus": "Opus", "mp3": "MP3", "vorbis": "Vorbis", "amrnb": "AMR-NB",
          "amrwb": "AMR-WB"}


@dataclass(frozen=True)
class TimingFloor:
    """How well a file's onsets can be timed, at best.

    Attributes
    ----------
    sd_s
        The floor, one standard deviation in seconds.
    message
        The one-line warning that says so.
    """

    sd_s: float
    message: str


def timing_floor(info: AudioInfo) -> TimingFloor | None:
    """The timing floor of a recording's codec and sample rate, or None when neither limits
    the timing (lossless audio at 22.05 kHz or more).

    Parameters
    ----------
    info
        What :func:`drumroll.audio.probe` says of the file.
    """
    codec_sd = rate_sd = 0.0
    if not info.lossless:
        codec_sd = next((sd for codec, least, sd in CODEC_FLOORS
                         if codec == info.codec and (info.bit_rate or 0) >= least), _UNMEASURED)
    rate_sd = next((sd for highest, sd in RATE_FLOORS if info.sample_rate <= highest), 0.0)
    sd = max(codec_sd, rate_sd)
    if sd == 0.0:
        return None
    timed = f"onsets are timed to about {1e3 * sd:.2g} ms, added to sigma_s"
    if codec_sd >= rate_sd:
        name = _NAMES.get(info.codec, f"a lossy codec not measured here ({info.codec})")
        rate = f" at {info.bit_rate / 1000:.0f} kb/s" if info.bit_rate else ""
        khz = f" and {info.sample_rate / 1000:g} kHz" if rate_sd else ""
        does = _DOES.get(info.codec, "smears an impact's click")
        return TimingFloor(sd, f"{info.path}: {name}{rate}{khz} {does}: {timed}")
    return TimingFloor(sd, f"{info.path}: a sample rate of {info.sample_rate} Hz keeps little "
                           f"of an impact's click: {timed}")
