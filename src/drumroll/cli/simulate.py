"""``drumroll simulate CONFIG.toml -o roll.wav``: a realistic recording with known truth.

The config's ``[simulate]`` section (see :mod:`drumroll.simulation.settings`) gives the true
set-up and the recording; the ``[stick]`` section and ``gravity_m_s2`` are shared with the
fit. The truth (impact times as placed in the file, speeds, per-impact local SNR, spurious
events, every parameter, the seed, the sample rate, the drumroll version) goes to a JSON
file beside the recording, or to ``--truth``.

With ``hits`` in the section the impacts are recorded hits
(:func:`~drumroll.simulation.render_hits`; the truth adds the files, each impact's velocity
layer and level), and ``room = "file"`` is a measured room; their file names are relative to
the config file's folder.

With ``--count N`` it makes N recordings of the same set-up, each with its own seed (the
seed, the seed + 1, …): ``roll.wav`` becomes ``roll-000.wav`` … with its truth beside each,
and a terminal shows a bar of the recordings made, with the time left.
"""

from __future__ import annotations

import argparse
import io
import json
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import soundfile as sf

from drumroll.cli.arguments import non_negative_int, positive_int
from drumroll.cli.progress import Progress
from drumroll.errors import DrumrollError, DrumrollWarning
from drumroll.fileio import check_writable, write_together

if TYPE_CHECKING:
    from drumroll.simulation.settings import SimulateSettings

#: Container by file suffix.
CONTAINERS = {".wav": "WAV", ".flac": "FLAC", ".ogg": "OGG"}


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` subcommand."""
    parser = subparsers.add_parser(
        "simulate", help="make a realistic drumroll recording with known truth",
        description="Render the roll that the config's [simulate] section describes (true "
        "alpha, pivot, height, release; drum, room, noise) through the exact physics into an "
        "audio file, and write the truth (impact times, speeds, local SNRs, spurious events, "
        "all parameters) as JSON.")
    parser.add_argument("config", help="TOML config file with a [simulate] section")
    parser.add_argument("-o", "--output", required=True, metavar="AUDIO",
                        help="recording to write: .wav, .flac or .ogg")
    parser.add_argument("--truth", metavar="JSON",
                        help="truth file (default: AUDIO with the suffix .truth.json)")
    parser.add_argument("--seed", type=non_negative_int, default=None,
                        help="random seed (default: the config's simulate.seed, else 0)")
    parser.add_argument("--count", type=positive_int, default=1, metavar="N",
                        help="make N recordings, seeds SEED, SEED + 1, …: AUDIO's name "
                        "numbered (roll-000.wav, …), each truth beside its recording")
    parser.add_argument("--force", action="store_true", help="overwrite existing files")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress on stderr (with --count: no bar, no news lines)")
    parser.set_defaults(func=run)


def numbered(path: Path, index: int, count: int) -> Path:
    """The ``index``-th of ``count`` recordings named after ``path`` (``roll-007.wav``; the
    path itself when there is one)."""
    if count == 1:
        return path
    return path.with_name(f"{path.stem}-{index:0{max(3, len(str(count - 1)))}d}{path.suffix}")


def run(args: argparse.Namespace) -> int:
    """Run ``simulate``."""
    # The simulator and the config's priors (scipy): imported only when it runs (the
    # simulator first: it registers the config's [simulate] section).
    from drumroll.config import load_config
    from drumroll.simulation.simulate import simulate  # noqa: F401

    output = Path(args.output)
    container = CONTAINERS.get(output.suffix.lower())
    if container is None:
        raise DrumrollError(f"{output}: unknown audio container {output.suffix!r} "
                            f"(expected one of: {', '.join(CONTAINERS)})")
    if args.truth and args.count > 1:
        raise DrumrollError("--truth names one file; with --count each truth is written "
                            "beside its recording (roll-000.truth.json, …)")
    truth_path = Path(args.truth) if args.truth else output.with_suffix(".truth.json")
    if truth_path.resolve() == output.resolve():
        raise DrumrollError(f"{truth_path}: the truth file cannot be the recording itself")
    config = load_config(args.config)
    settings: SimulateSettings | None = config.section("simulate")
    subtype = None
    if settings is not None:  # simulate() says what is missing otherwise
        subtype = _subtype(container, settings, output)
    if args.seed is not None and args.seed < 0:
        raise DrumrollError(f"--seed: must not be negative, got {args.seed}")
    targets = [(numbered(output, i, args.count),
                numbered(output, i, args.count).with_suffix(".truth.json")
                if args.count > 1 else truth_path) for i in range(args.count)]
    for recording, truth in targets:  # fail before the work, not after it
        check_writable(recording, overwrite=args.force, inputs=[args.config])
        check_writable(truth, overwrite=args.force, inputs=[args.config])
    if args.count == 1:
        print(_simulate_one(config, args, output, truth_path, args.seed, container, subtype))
        return 0
    first = args.seed if args.seed is not None else \
        (settings.seed if settings is not None and settings.seed is not None else 0)
    progress = Progress(quiet=args.quiet)
    with progress.bar(args.count, "simulate", "recording") as bar:
        for i, (recording, truth) in enumerate(targets):
            progress.say(_simulate_one(config, args, recording, truth, first + i, container,
                                       subtype))
            bar.advance(note=recording.name)
    print(f"{targets[0][0]} … {targets[-1][0]}: {args.count} recordings (seeds {first}–"
          f"{first + args.count - 1}), each truth beside its recording")
    return 0


def _simulate_one(config, args: argparse.Namespace, output: Path, truth_path: Path,
                  seed: int | None, container: str, subtype: str | None) -> str:
    """Make one recording and its truth (both or neither); the line saying what was made."""
    from drumroll.simulation.simulate import simulate

    simulated = simulate(config, seed=seed)
    settings, rendering = simulated.settings, simulated.rendering
    rest = dict(simulated.truth)
    truth = {**{key: rest.pop(key) for key in ("drumroll_version", "seed")},
             "config": str(args.config),
             "recording": {"file": output.name, "container": container, "subtype": subtype},
             **rest}
    # Encoded in memory, then written by Python: libsndfile reports a full disk only as
    # "System error". The recording and its truth are written together, both or neither.
    recording = io.BytesIO()
    sf.write(recording, simulated.samples, simulated.sample_rate, subtype=subtype,
             format=container)
    write_together({output: lambda tmp: tmp.write_bytes(recording.getbuffer()),
                    truth_path: lambda tmp: tmp.write_text(json.dumps(truth, indent=1) + "\n",
                                                           encoding="utf-8")},
                   overwrite=args.force)
    audible = int(np.sum(rendering.local_snr_db > 0))
    return (f"{output}: {len(rendering.impact_times_s)} impacts ({audible} with local SNR > 0 "
            f"dB), {rendering.duration_s:.2f} s, {settings.sample_rate} Hz, "
            f"{settings.channels} ch, {subtype}; truth in {truth_path}")


def _subtype(container: str, settings: SimulateSettings, output: Path) -> str:
    """The soundfile subtype for ``container``, or a one-line error if it cannot hold it."""
    if container == "OGG":
        if "subtype" in settings.raw:
            warnings.warn(f"{output}: .ogg is lossy Vorbis; simulate.subtype = "
                          f"{settings.subtype!r} does not apply (use .wav or .flac for exact "
                          "samples)", DrumrollWarning, stacklevel=1)
        return "VORBIS"
    if container == "FLAC" and settings.subtype == "FLOAT":
        raise DrumrollError(f"{output}: FLAC cannot hold FLOAT samples; use simulate.subtype "
                            "= \"PCM_16\" or \"PCM_24\", or a .wav file")
    return settings.subtype
