"""Entry point of the ``drumroll`` command.

Each subcommand lives in its own module exposing ``register(subparsers)``, which adds its
parser and sets ``func`` to a ``run(args) -> int`` callable. Errors the user can fix are
:class:`~drumroll.errors.DrumrollError`: printed as one line, exit status 2, no traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings
from collections.abc import Sequence

from drumroll import __version__
from drumroll.errors import DrumrollError

#: Subcommand modules, in the order ``drumroll --help`` lists them.
SUBCOMMANDS = ("predict", "onsets", "simulate", "estimate", "table")


def build_parser() -> argparse.ArgumentParser:
    """The ``drumroll`` argument parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="drumroll",
        description="Turn the sound of a bouncing drumstick (or any bouncing object) into "
        "physics with honest error bars.",
    )
    parser.add_argument("--version", action="version", version=f"drumroll {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in SUBCOMMANDS:
        importlib.import_module(f"drumroll.cli.{name}").register(subparsers)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    # Users see one plain line per warning, not the source line that raised it.
    print(f"drumroll: warning: {message}", file=sys.stderr)


def run_cli(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> int:
    """Parse ``argv`` with ``parser`` and run the chosen command, turning errors into lines."""
    args = parser.parse_args(argv)
    warnings.showwarning = _show_warning
    try:
        return int(args.func(args) or 0)
    except DrumrollError as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"{parser.prog}: interrupted; no partial output was kept", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `drumroll predict cfg.toml | head`
        return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``drumroll`` with ``argv`` (default: ``sys.argv[1:]``) and return the exit status."""
    return run_cli(build_parser(), argv)


def estimate_main(argv: Sequence[str] | None = None) -> int:
    """``estimate SOURCE --prior CONFIG.toml``: the top-level alias of ``drumroll estimate``."""
    from drumroll.cli.estimate import add_arguments

    parser = argparse.ArgumentParser(
        prog="estimate", description="Estimate α, t_C, t_B, the effective pivot, the release "
        "speed and the onset jitter from a drumroll recording (same as `drumroll estimate`).")
    add_arguments(parser)
    return run_cli(parser, argv)


if __name__ == "__main__":
    raise SystemExit(main())
