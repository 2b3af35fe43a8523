"""Entry point of the ``drumroll`` command.

Each subcommand lives in its own module exposing ``register(subparsers)``, which adds its
parser and sets ``func`` to a ``run(args) -> int`` callable. Errors the user can fix are
:class:`~drumroll.errors.DrumrollError`: printed as one line, exit status 2, no traceback.
"""

from __future__ import annotations

import argparse
import atexit
import importlib
import logging
import os
import re
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Sequence
from typing import NoReturn

from drumroll import fileio, interruption
from drumroll._version import __version__
from drumroll.errors import DrumrollError, DrumrollWarning

#: Subcommand modules, in the order ``drumroll --help`` lists them.
SUBCOMMANDS = ("predict", "onsets", "simulate", "estimate", "table", "calibrate")


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


#: numpy's floating-point warnings (scipy's too, in numpy's words): an overflow, an invalid
#: value or a division by zero met somewhere in an array. They name no quantity and no input,
#: and what the commands print is checked and said in their own words (a config error, a
#: prediction that overflows), so they are not shown (``--debug`` shows them).
_FLOATING_POINT = re.compile(r"(overflow|underflow|invalid value|divide by zero) encountered")


def _warning_printer(debug: bool):
    """The command's :func:`warnings.showwarning`: each warning one plain line, not the
    source line that raised it, and a message shown once (a warning of every run, every
    block or every figure is one line); numpy's floating-point warnings only with
    ``--debug``, which also says where a warning came from."""
    shown: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        text = " ".join(str(message).split())
        if debug:
            text += f" ({category.__name__}, {filename}:{lineno})"
        elif issubclass(category, RuntimeWarning) and _FLOATING_POINT.search(text):
            return
        if text not in shown:
            shown.add(text)
            print(f"drumroll: warning: {text}", file=sys.stderr)

    return show


def _without_numba() -> None:
    """Keep ArviZ from importing numba in this process.

    ArviZ imports numba whenever it is installed (librosa brings it) and compiles a few
    kernels as it is imported, ~0.6 s in every process that imports ArviZ; on chains of a
    few thousand draws plain numpy is as fast, and nothing of ours uses numba. A command owns
    its process, so it may decline it; the library (a notebook's process) does not.
    """
    sys.modules.setdefault("numba", None)  # type: ignore[arg-type]  # import numba: ImportError


def _one_blas_thread() -> None:
    """One BLAS thread per process, unless the user set otherwise (before numpy loads BLAS).

    The commands parallelise across processes themselves (one model, one figure per core).
    BLAS threads on top of that oversubscribe the cores: our matrix products are small and
    gain nothing from threads, and OpenBLAS's threads spin while they wait, taking the cores
    the other processes need (an estimate ran 6.3 s with one thread, up to 8.7 s without).
    """
    if "numpy" in sys.modules:
        return  # too late: BLAS has read its settings
    for variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(variable, "1")


def _file_size_limit_as_error() -> object | None:
    """Let a file that would exceed the size limit (``ulimit -f``) fail as an error (EFBIG:
    one line, nothing half-written) rather than kill the process (SIGXFSZ's default, with a
    core dump); the figure workers inherit it. In the main thread only (a signal handler can
    be set nowhere else); returns the handler replaced, or None."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal,
                                                                                "SIGXFSZ"):
        return None
    return signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


class _LibraryLog(logging.Handler):
    """The command's handler of the libraries' log records (emcee's, ArviZ's, …), on the
    root logger while it runs: they report on the sampler and the files in their own terms,
    where drumroll says what matters in its own (convergence, damaged files). Without
    ``--debug`` an error is one warning line, its first line only, and anything less is
    dropped; with ``--debug`` every record of level WARNING and up is shown that way."""

    def __init__(self, debug: bool) -> None:
        super().__init__(logging.WARNING if debug else logging.ERROR)

    def emit(self, record: logging.LogRecord) -> None:
        lines = record.getMessage().strip().splitlines() or [""]
        warnings.warn(f"{record.name}: {lines[0]}", DrumrollWarning, stacklevel=1)


def _unraisable_hook(debug: bool):
    """A :data:`sys.unraisablehook` for a command: an exception Python cannot raise (one in a
    weak reference's callback or a destructor) printed as one line, not a traceback; a stop
    (Ctrl-C, SIGTERM) there not at all, as it is recorded and acted on
    (:mod:`drumroll.interruption`). ``--debug`` keeps Python's report."""
    default = sys.__unraisablehook__

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            return
        if debug:
            default(unraisable)
            return
        what = " ".join(f"{unraisable.exc_type.__name__}: {unraisable.exc_value}".split())
        print(f"drumroll: warning: an error while cleaning up was ignored ({what[:200]})",
              file=sys.stderr)

    return hook


#: The option that shows an internal error's traceback instead of one line.
DEBUG_OPTION = "--debug"


def run_cli(make_parser: Callable[[], argparse.ArgumentParser], argv: Sequence[str] | None
            ) -> int:
    """Parse ``argv`` with the parser ``make_parser`` builds and run the chosen command,
    turning errors into lines.

    The process is set up first (one BLAS thread), since building a parser loads numpy.
    """
    _one_blas_thread()
    parser = make_parser()
    parser.add_argument(DEBUG_OPTION, action="store_true",
                        help="show the traceback of an internal error (anywhere on the line)")
    arguments = list(sys.argv[1:] if argv is None else argv)
    debug = DEBUG_OPTION in arguments  # understood after a subcommand too
    args = parser.parse_args([a for a in arguments if a != DEBUG_OPTION])
    _without_numba()
    previous = interruption.install()
    size_limit = _file_size_limit_as_error()
    show_warning, warnings.showwarning = warnings.showwarning, _warning_printer(debug)
    library_log = _LibraryLog(debug)
    logging.root.addHandler(library_log)  # before ArviZ is imported: it adds none of its own
    unraisable_hook, sys.unraisablehook = sys.unraisablehook, _unraisable_hook(debug)
    try:
        status = int(args.func(args) or 0)
        interruption.raise_if_interrupted()  # a signal whose exception Python swallowed
        return status
    except KeyboardInterrupt as exc:
        return _stopped(parser.prog, exc)
    except Exception as exc:
        # After a signal, whatever ended the command is the signal's doing: its exception may
        # have come out as another (an import it broke off) or caused one on its way out.
        stopped = interruption.pending()
        if stopped is not None:
            return _stopped(parser.prog, stopped)
        return _failed(parser.prog, exc, debug)
    finally:
        warnings.showwarning, sys.unraisablehook = show_warning, unraisable_hook
        logging.root.removeHandler(library_log)
        interruption.restore(previous)
        if size_limit is not None:
            signal.signal(signal.SIGXFSZ, size_limit)


def _stopped(prog: str, exc: KeyboardInterrupt) -> int:
    """Report a stop (Ctrl-C, SIGTERM, SIGHUP) in one line; the exit status 128 + signal."""
    ended = exc if isinstance(exc, interruption.Terminated) else None
    how = "interrupted" if ended is None else ended.how
    print(f"{prog}: {how}; no partial output was kept", file=sys.stderr)
    return 130 if ended is None else 128 + ended.signum


def _failed(prog: str, exc: Exception, debug: bool) -> int:
    """Report an exception that ended a command: the input's fault (one line, exit 2), a full
    disk, a closed pipe, or a fault of ours (one line, exit 1; ``debug`` re-raises it)."""
    if isinstance(exc, DrumrollError):
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    if isinstance(exc, BrokenPipeError):  # e.g. `drumroll predict cfg.toml | head`
        return 0
    if debug:
        raise exc
    if isinstance(exc, OSError) and fileio.no_space(exc):
        # A full disk met where no output is named (a library's own file): the user's.
        reason, advice = fileio.NO_SPACE[exc.errno]
        error = (fileio.no_space_error(exc.filename, exc) if exc.filename else
                 DrumrollError(f"cannot write: {reason} ({advice})"))
        print(f"{prog}: error: {error}", file=sys.stderr)
        return error.exit_code
    return _internal_error(prog, exc)  # a fault of ours, not of the input


def _internal_error(prog: str, exc: Exception) -> int:
    """Report ``exc``, a fault of ours, in one line; the exit status 1."""
    what = " ".join(f"{type(exc).__name__}: {exc}".split())
    print(f"{prog}: internal error (a bug in drumroll; please report it with the command "
          f"and its input): {what[:300]}; {DEBUG_OPTION} shows the traceback",
          file=sys.stderr)
    return 1


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``drumroll`` with ``argv`` (default: ``sys.argv[1:]``) and return the exit status."""
    return run_cli(build_parser, argv)


def estimate_main(argv: Sequence[str] | None = None) -> int:
    """``estimate SOURCE --prior CONFIG.toml``: the top-level alias of ``drumroll estimate``."""
    def make_parser() -> argparse.ArgumentParser:
        from drumroll.cli.estimate import add_arguments

        parser = argparse.ArgumentParser(
            prog="estimate", description="Estimate α, t_C, t_B, the effective pivot, the "
            "release speed and the onset jitter from a drumroll recording (same as "
            "`drumroll estimate`).")
        add_arguments(parser)
        return parser

    return run_cli(make_parser, argv)


def end_process(status: int) -> NoReturn:
    """End this process with ``status`` once a command is done, without Python's teardown.

    Every output is written and closed by then; what is left of an interpreter's shutdown is
    freeing the heap object by object and clearing every module: 0.15-0.2 s after the
    estimate's last line, on the command's critical path. The exit handlers the libraries
    registered run (logging, multiprocessing, h5py, PIL, matplotlib: well under a
    millisecond), the standard streams are flushed, and the process ends. For the console
    scripts and ``python -m drumroll`` only: in-process callers (tests, notebooks) call
    :func:`main`, which returns.
    """
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can reach it
            pass
    os._exit(status)


def console_main() -> NoReturn:
    """The ``drumroll`` console script: :func:`main`, then :func:`end_process`."""
    end_process(main())


def console_estimate() -> NoReturn:
    """The ``estimate`` console script: :func:`estimate_main`, then :func:`end_process`."""
    end_process(estimate_main())


if __name__ == "__main__":
    console_main()
