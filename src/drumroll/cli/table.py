"""``drumroll table RUNS.toml``: Tables 1–2 and Figure 5 of the paper from a folder of runs."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from concurrent.futures import Executor
from pathlib import Path

from drumroll.cli.arguments import positive_int
from drumroll.cli.progress import Progress
from drumroll.errors import DrumrollError
from drumroll.fileio import check_folder_writable, check_writable, write_together


class _TableFormats:
    """The table formats' names as argparse ``choices``, read from their registry only when
    asked (the registry imports the table's machinery, which ``--help`` should not wait
    for)."""

    def _names(self) -> list[str]:
        from drumroll.table.formatting import FORMATS

        return list(FORMATS)

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __iter__(self):
        return iter(self._names())


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``table`` subcommand."""
    parser = subparsers.add_parser(
        "table", help="a paper-style table (and Figure 5) from several recordings",
        description="Estimate every run of a RUNS.toml file (in parallel, cached by content) "
        "and print the paper's Tables 1-2: the varied quantity, computed t_B (prior "
        "propagation), fitted t_B and alpha, the preferred model. `share = [\"alpha\"]` fits "
        "the listed parameters jointly across the runs.")
    parser.add_argument("runs", metavar="RUNS.toml", help="runs file (see drumroll.table.runs)")
    parser.add_argument("-o", "--output", type=Path, metavar="FILE",
                        help="write the table here (default: print it); a Markdown table "
                        "gets its HTML page beside it (FILE.html, Figure 5 embedded)")
    # An explicit metavar: without one, add_argument formats the choices at once (to check
    # them), importing the table's machinery (scipy.special among it) for every command.
    parser.add_argument("--format", choices=_TableFormats(), metavar="FORMAT",
                        help="table format: %(choices)s (default: from the -o suffix, else "
                        "markdown)")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="write Figure 5 here")
    parser.add_argument("--workers", type=positive_int, metavar="N",
                        help="runs estimated side by side (default: the cores)")
    parser.add_argument("--dask", metavar="ADDRESS",
                        help="run on a Dask cluster, e.g. tcp://scheduler:8786 (needs the "
                        "'dask' extra)")
    parser.add_argument("--cache-dir", type=Path, metavar="DIR",
                        help="cache folder (default: .drumroll-cache/ beside RUNS.toml)")
    parser.add_argument("--no-cache", action="store_true",
                        help="neither read nor write cached runs")
    parser.add_argument("--force", action="store_true", help="overwrite existing outputs")
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress on stderr (no bar on a terminal, no news lines)")
    parser.set_defaults(func=run)


@contextlib.contextmanager
def dask_executor(address: str) -> Iterator[Executor]:
    """A :class:`concurrent.futures.Executor` on the Dask cluster at ``address``."""
    try:
        from distributed import Client
    except ImportError:
        raise DrumrollError("--dask needs Dask: pip install 'drumroll[dask]' (or "
                            "'dask[distributed]')") from None
    try:
        client = Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise DrumrollError(f"--dask {address}: cannot connect ({exc})") from None
    try:
        yield client.get_executor()
    finally:
        client.close()


def run(args: argparse.Namespace) -> int:
    """Run ``table``: validate everything, then estimate, then write."""
    from drumroll.table import format_table, load_runs, run_table
    from drumroll.table.formatting import FORMATS, format_for, format_named_by

    suffix = args.output.suffix if args.output else ""
    named = format_named_by(suffix)
    if args.format and named and named != args.format:
        # A CSV written to table.md (or Markdown to table.csv) is a file its suffix lies about.
        raise DrumrollError(f"{args.output}: --format {args.format} writes "
                            f"{FORMATS[args.format].suffixes[0]} files, and {suffix} is "
                            f"{named}'s; name the file *{FORMATS[args.format].suffixes[0]} "
                            "or leave --format out")
    runs = load_runs(args.runs)
    fmt = args.format or format_for(suffix)
    # A Markdown table written to a file gets its HTML page beside it (Figure 5 embedded).
    page = None
    if args.output is not None and fmt == "markdown":
        from drumroll.reporting.report_files import html_path

        page = html_path(args.output)
    for path in (args.output, page, args.plot):
        if path is not None:
            check_writable(path, overwrite=args.force, inputs=[args.runs])
    if args.plot is not None and args.plot.suffix.lower() != ".png":
        raise DrumrollError(f"{args.plot}: the figure is written as PNG; name it *.png")
    if not args.no_cache:
        _check_cache_folder(args.cache_dir or runs.cache_dir)
    progress = Progress(quiet=args.quiet)
    options = {"workers": args.workers, "cache_dir": args.cache_dir,
               "use_cache": not args.no_cache, "progress": progress}
    if args.dask:
        with dask_executor(args.dask) as executor:
            result = run_table(runs, executor=executor, **options)
    else:
        result = run_table(runs, **options)
    if runs.share:
        from drumroll.table.joint import joint_table

        with progress.stage(f"joint fit of {', '.join(runs.share)} across {len(runs.runs)} "
                            "runs"):
            result.joint = joint_table(runs, result, cache_dir=args.cache_dir,
                                       use_cache=not args.no_cache)
    text = format_table(result, fmt)
    if args.output is None:
        sys.stdout.write(text)
    # The table, its page and the figure are written together: all or, if one fails (a
    # full disk), none.
    writers = {}
    with contextlib.ExitStack() as drawing:
        figure = None
        if args.plot is not None or page is not None:
            from drumroll.reporting.plot_style import missing_glyphs_said_once
            from drumroll.table.plot import table_png

            drawing.enter_context(missing_glyphs_said_once((args.plot or page).name))
            figure = table_png(result)  # drawn once: the PNG file and the page's figure
        if page is not None:
            from drumroll.reporting.document import Figure
            from drumroll.reporting.report_files import document_writers
            from drumroll.table.formatting import FIGURE_CAPTION, FIGURE_NOTE, table_document

            document = table_document(result, Figure(FIGURE_CAPTION, FIGURE_NOTE,
                                                     path=args.plot, png=figure))
            writers.update(document_writers(args.output, document))
        elif args.output is not None:
            writers[args.output] = lambda tmp: tmp.write_text(text, encoding="utf-8")
        if args.plot is not None:
            writers[args.plot] = lambda tmp: tmp.write_bytes(figure)
        write_together(writers, overwrite=args.force)
    if args.output is not None:
        progress.say(f"table written to {args.output}"
                     + (f" (and {page})" if page is not None else ""))
    if args.plot is not None:
        progress.say(f"figure written to {args.plot}")
    return 0


def _check_cache_folder(folder: Path) -> None:
    """Refuse, before any work, a cache folder that is a file or under one, or where no file
    can be made (it is made, with its parents, when the first run is cached)."""
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise DrumrollError(f"{existing}: is not a directory; the cache needs a folder "
                            "(--cache-dir DIR, or --no-cache)")
    try:
        check_folder_writable(existing)
    except DrumrollError as exc:
        raise DrumrollError(f"{exc} (the cache of the runs' fits goes into {folder}: "
                            "--cache-dir DIR for another folder, or --no-cache)") from None


def main(argv: list[str] | None = None) -> int:
    """``python -m drumroll.cli.table RUNS.toml …``: the same command without loading the
    other subcommands (``drumroll`` imports them all, ArviZ included, ~1–2 s of start-up)."""
    from drumroll.cli.main import run_cli

    def make_parser() -> argparse.ArgumentParser:
        parser = argparse.ArgumentParser(prog="drumroll table")
        register(parser.add_subparsers(dest="command", required=True))
        return parser

    return run_cli(make_parser, ["table", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
