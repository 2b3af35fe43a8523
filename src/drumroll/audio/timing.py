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
#: seconds, share of onsets moved by more than 1 ms or lost)``; the first row that matches
#: wins. From ``python benchmarks/onsets.py --phone-only``: the 12 corpus rolls and the real
#: ping-pong (252 onsets), each encoded with :mod:`drumroll.audio.encode`, each onset's shift
#: from the lossless original's (paired within 3 ms) less its recording's median shift,
#: pooled; sd = 1.4826 × MAD, rounded up to 10 µs:
#:
#: ============================  ========  =======  ===================
#: condition                     MAD (ms)  sd (ms)  moved > 1 ms / lost
#: ============================  ========  =======  ===================
#: AAC 128 kb/s .m4a             0.068     0.101    0.079
#: AAC 64 kb/s .m4a              0.181     0.269    0.246
#: Opus 64 kb/s .webm            0.097     0.144    0.087
#: Opus 32 kb/s .webm            0.217     0.322    0.238
#: MP3 128 kb/s                  0.091     0.134    0.111
#: Vorbis q0.5 .ogg (110 kb/s)   0.135     0.201    0.111
#: AMR-NB 12.2 kb/s, 8 kHz .3gp  0.264     0.391    0.675
#: ============================  ========  =======  ===================
#:
#: MP3 and Vorbis below 96 kb/s were not measured: they get the low-rate rows of AAC and Opus,
#: the larger in each column; AMR-WB (no encoder in PyAV's wheels) gets AMR-NB's. The MAD
#: describes the bulk of the onsets; the last column is the tail, which a ``sigma_s`` cannot
#: describe (faint bounces in the ring of the ones before, whose first stage the codec's
#: noise hides, and loud impacts whose pre-echo is too long or too loud to be told from their
#: own sound; :func:`drumroll.onsets.refine.out_of_codec_noise` takes the rest of the
#: pre-echo out, the onset placed within an impact's rise,
#: :data:`~drumroll.onsets.refine.IMPACT_RISE_S`, of where its sound steps out of it): the
#: warning states it, and ``[likelihood] noise = "student-t"`` is made for it.
CODEC_FLOORS: tuple[tuple[str, int, float, float], ...] = (
    ("aac", 96_000, 0.11e-3, 0.08),
    ("aac", 0, 0.27e-3, 0.25),
    ("opus", 48_000, 0.15e-3, 0.09),
    ("opus", 0, 0.33e-3, 0.24),
    ("mp3", 96_000, 0.14e-3, 0.11),
    ("mp3", 0, 0.33e-3, 0.25),
    ("vorbis", 96_000, 0.21e-3, 0.11),
    ("vorbis", 0, 0.33e-3, 0.25),
    ("amrnb", 0, 0.40e-3, 0.68),
    ("amrwb", 0, 0.40e-3, 0.68),
)

#: An unmeasured lossy codec (AC-3, WMA, GSM, ...) is given the largest floor of the
#: transform codecs above: no smaller than the worst measured, short of a measurement.
_UNMEASURED = max((row for row in CODEC_FLOORS if row[0] not in ("amrnb", "amrwb")),
                  key=lambda row: row[2])[2:]

#: Timing floors of low sample rates, lossless: ``(highest rate in Hz the row holds for, sd
#: in seconds, share moved by more than 1 ms or lost)``, the first row that matches wins
#: (same benchmark, the recordings resampled and written as 16-bit WAV: at 16 kHz MAD
#: 0.092 ms, sd 0.136 ms, 0.103 moved; at 8 kHz MAD 0.151 ms, sd 0.224 ms, 0.194 moved).
RATE_FLOORS: tuple[tuple[int, float, float], ...] = (
    (8_000, 0.23e-3, 0.19),
    (16_000, 0.14e-3, 0.10),
)

#: How far ahead of an impact each lossy codec may spread the quantisation noise of the
#: transform block that holds it (pre-echo), in samples at the stream's rate: the support
#: of the codec's shortest window, which it switches to at a transient. AAC: 256-sample
#: short windows (ISO/IEC 14496-3); Vorbis: 256-sample short blocks (libvorbis's at 44.1
#: and 48 kHz); MP3: 384-sample short blocks (12 samples in each of 32 subbands); Opus
#: (CELT): 2.5 ms short MDCTs with 2.5 ms overlap, 240 samples at 48 kHz. AMR codes
#: 5 ms subframes (40 samples at 8 kHz) by prediction, not by transform blocks.
PRE_ECHO_SAMPLES = {"aac": 256, "vorbis": 256, "mp3": 384, "opus": 240, "amrnb": 40,
                    "amrwb": 80}

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
    codec = rate = (0.0, 0.0)
    if not info.lossless:
        codec = next((row[2:] for row in CODEC_FLOORS
                      if row[0] == info.codec and (info.bit_rate or 0) >= row[1]), _UNMEASURED)
    rate = next((row[1:] for row in RATE_FLOORS if info.sample_rate <= row[0]), rate)
    sd, moved = max(codec, rate)
    if sd == 0.0:
        return None
    timed = (f"onsets are timed to about {1e3 * sd:.2g} ms, added to sigma_s; "
             f"{moved:.0%} of them move by more than 1 ms or are lost")
    if codec >= rate:
        name = _NAMES.get(info.codec, f"a lossy codec not measured here ({info.codec})")
        bits = f" at {info.bit_rate / 1000:.0f} kb/s" if info.bit_rate else ""
        khz = f" and {info.sample_rate / 1000:g} kHz" if rate[0] else ""
        does = _DOES.get(info.codec, "smears an impact's click")
        return TimingFloor(sd, f"{info.path}: {name}{bits}{khz} {does}: {timed}")
    return TimingFloor(sd, f"{info.path}: a sample rate of {info.sample_rate} Hz keeps little "
                           f"of an impact's click: {timed}")


def pre_echo_s(info: AudioInfo) -> float:
    """The longest stretch (seconds) by which a recording's codec may spread its noise ahead
    of an impact (:data:`PRE_ECHO_SAMPLES`; the largest of them for a lossy codec not
    listed); 0 for lossless audio.

    Parameters
    ----------
    info
        What :func:`drumroll.audio.probe` says of the file.
    """
    if info.lossless:
        return 0.0
    samples = PRE_ECHO_SAMPLES.get(info.codec, max(PRE_ECHO_SAMPLES.values()))
    return samples / info.sample_rate
