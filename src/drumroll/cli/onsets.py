"""``drumroll onsets AUDIO``: extract impact times (and their uncertainties) from a recording."""

from __future__ import annotations

import argparse
import contextlib
import sys
import warnings
from pathlib import Path

from drumroll import fileio
from drumroll.cli.arguments import non_negative_int, positive_float
from drumroll.cli.progress import Progress
from drumroll.errors import DrumrollError, DrumrollWarning
from drumroll.onsets.formats import ONSET_FILE_SUFFIXES, read_onsets
from drumroll.onsets.table import COLUMNS


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``onsets`` subcommand."""
    p = subparsers.add_parser(
        "onsets", help="extract impact times from a recording",
        description="Find the impacts of every drumroll (or other freely bouncing object) in "
        "a recording, to the sample, each with its timing uncertainty and its bounce number "
        "(0 for a roll's first impact; an unheard bounce leaves a gap). Without -o the CSV "
        f"({','.join(COLUMNS)}) is printed.")
    p.add_argument("audio", metavar="AUDIO", help="recording (WAV, FLAC, OGG, MP3; a phone's "
                   ".m4a, .3gp, .webm; a camera's .mp4 or .mov; ...)")
    p.add_argument("-o", "--output", metavar="CSV", help="write the onset table here")
    p.add_argument("--labels", metavar="TXT", help="also write an Audacity label track")
    p.add_argument("--plot", metavar="PNG", help="also draw the waveform with the onsets")
    p.add_argument("--all-candidates", action="store_true",
                   help="list rejected candidates too, each with the reason")
    p.add_argument("--highpass", type=positive_float, default=None, metavar="HZ",
                   help="lowest frequency analysed (default 150 Hz)")
    p.add_argument("--threshold", type=positive_float, default=5.0, metavar="Z",
                   help="significance for a candidate, in robust standard deviations "
                   "(default 5)")
    p.add_argument("--stream", type=non_negative_int, metavar="N",
                   help="which audio stream of a video or other file with several (0, 1, 2, "
                   "…; default 0, the first)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress on stderr (no spinner on a terminal, no line saying what "
                   "was written)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``drumroll onsets``."""
    from drumroll.audio.io import AudioSource
    from drumroll.onsets import detect  # the detector: imported only when needed

    # Refuse to clobber before doing the work, not after it.
    outputs = [Path(p) for p in (args.output, args.labels, args.plot) if p]
    for path in outputs:
        fileio.check_writable(path, overwrite=args.force, inputs=[args.audio])
    if len({p.resolve() for p in outputs}) < len(outputs):
        raise DrumrollError("-o, --labels and --plot name the same file: give each its own")
    for option, path in (("-o", args.output), ("--labels", args.labels)):
        # What estimate reads as onsets, not as audio, is told by the suffix.
        if path and Path(path).suffix.lower() not in ONSET_FILE_SUFFIXES:
            raise DrumrollError(f"{option} {path}: onsets are written as text; give the file "
                                f"one of the suffixes {', '.join(ONSET_FILE_SUFFIXES)}, so that "
                                "estimate reads it back as onsets")
    if args.plot:
        fileio.check_figure_suffix(args.plot)
    _refuse_onset_file(args.audio)
    options = {} if args.highpass is None else {"highpass_hz": args.highpass}
    # The stream travels with the path, so that the figure reads the same stream.
    audio = args.audio if args.stream is None else AudioSource(args.audio, args.stream)
    progress = Progress(quiet=args.quiet)
    with progress.stage(f"finding the onsets of {Path(args.audio).name}") \
            if progress.interactive else contextlib.nullcontext():
        table = detect(audio, threshold=args.threshold, all_candidates=args.all_candidates,
                       **options)
    csv = table.to_csv(all_candidates=args.all_candidates)
    if not args.output:
        sys.stdout.write(csv)
    # The files are written together: all of them or, if one fails (a full disk), none.
    writers = {}
    if args.output:
        writers[args.output] = lambda tmp: tmp.write_text(csv, encoding="utf-8")
    if args.labels:
        labels = table.to_labels()
        writers[args.labels] = lambda tmp: tmp.write_text(labels, encoding="utf-8")
    with contextlib.ExitStack() as drawing:
        if args.plot:
            from drumroll.reporting.onset_plot import draw_onset_figure
            from drumroll.reporting.plot_style import missing_glyphs_said_once

            drawing.enter_context(missing_glyphs_said_once(Path(args.plot).name))
            figure = draw_onset_figure(audio, table)
            writers[args.plot] = lambda tmp: figure.savefig(tmp, dpi=110)
        fileio.write_together(writers, overwrite=args.force)
    if args.output:
        progress.say(f"drumroll: {table.describe()} written to {args.output}")
    return 0


def _refuse_onset_file(source: str) -> None:
    """Refuse an onset file given where a recording is wanted, saying what to run instead
    (audio's own error would call the file unreadable or damaged, which it is not)."""
    path = Path(source)
    if path.suffix.lower() not in ONSET_FILE_SUFFIXES or not path.is_file():
        return
    try:
        with warnings.catch_warnings():  # only asking what it is: its remarks are not ours
            warnings.simplefilter("ignore", DrumrollWarning)
            table = read_onsets(path)
    except DrumrollError:
        return  # not an onset file either: the audio reader says what it is
    raise DrumrollError(f"{source}: an onset file ({len(table.time_s)} onsets), not a "
                        "recording: `drumroll onsets` finds onsets in audio; "
                        f"`drumroll estimate {source} --prior CONFIG` fits these")
