"""Writing outputs without ever losing a user's file.

Every output is written to a temporary file in the destination folder and renamed into place,
so an interrupted run leaves either the old file or the new one, never half of one. Existing
files are refused unless the caller allows overwriting.

A disk that fills up while an output is written (or a file size limit, ``ulimit -f``) is the
user's to fix, not a fault of ours: :func:`no_space` tells such an error and
:func:`no_space_error` words it as one line naming the output; the partial file is removed.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path

from drumroll.errors import DrumrollError
from drumroll.interruption import raise_if_interrupted

#: ``errno`` of a write that found no room: the device is full, the user's disk quota is
#: used up, or the file would exceed the process's (``ulimit -f``) or the file system's size
#: limit. What each means and what to do, in words.
NO_SPACE = {
    errno.ENOSPC: ("no space left on the device", "free some space, or write somewhere else"),
    errno.EDQUOT: ("the disk quota is used up", "free some space, or write somewhere else"),
    errno.EFBIG: ("the file would exceed the file size limit (ulimit -f, or the file "
                  "system's)", "raise the limit, or write somewhere else"),
}


def no_space(exc: BaseException) -> bool:
    """Whether ``exc`` is a write that found no room (see :data:`NO_SPACE`)."""
    return isinstance(exc, OSError) and exc.errno in NO_SPACE


class NoSpace(DrumrollError):
    """An output that could not be written for want of room (see :data:`NO_SPACE`).

    Parameters
    ----------
    path
        The output.
    code
        The error's ``errno``, a key of :data:`NO_SPACE`.
    """

    def __init__(self, path: str | os.PathLike[str], code: int) -> None:
        reason, advice = NO_SPACE[code]
        super().__init__(f"{path}: cannot write it: {reason}; nothing was written ({advice})")
        self.path, self.errno, self.reason = Path(path), code, reason

    def __reduce__(self):  # raised in worker processes: rebuilt from its own arguments
        return type(self), (self.path, self.errno)

    def moved(self, staging: Path, final: Path) -> NoSpace:
        """The same error about ``final / name`` when it concerned ``staging / name``."""
        if self.path.parent != staging:
            return self
        return NoSpace(final / self.path.name, self.errno)


def no_space_error(path: str | os.PathLike[str], exc: OSError) -> NoSpace:
    """The one-line error for ``exc`` (:func:`no_space` is true of it) writing ``path``."""
    return NoSpace(path, exc.errno)


def check_writable(path: str | os.PathLike[str], *, overwrite: bool = False,
                   inputs: Iterable[str | os.PathLike[str]] = ()) -> Path:
    """Refuse to replace an existing file unless ``overwrite`` is set, and never replace
    what is not a regular file or one of the command's ``inputs``.

    An output is written as a new file and renamed onto its name (:func:`atomic_paths`), so
    an existing device or pipe (``/dev/null``, a FIFO) would be replaced by a plain file, not
    written through: refused even with ``--force``, as is an output that is an input of the
    same command (a recording overwritten by its own onsets).

    Parameters
    ----------
    path
        Destination the caller is about to write.
    overwrite
        Allow replacing an existing file (the command line's ``--force``).
    inputs
        The files the command reads (those that do not exist are ignored).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.
    """
    path = Path(path)
    if path.is_dir():
        raise DrumrollError(f"{path}: is a directory, expected a file name to write")
    exists = path.exists()
    if exists and not path.is_file():
        raise DrumrollError(f"{path}: is not a regular file (a device, pipe or socket): "
                            "outputs are written as new files; give a file name")
    if exists and any(Path(source).exists() and os.path.samefile(path, source)
                      for source in inputs):
        raise DrumrollError(f"{path}: is an input of this command; give the output another "
                            "name")
    if exists and not overwrite:
        raise DrumrollError(f"{path}: already exists (use --force to overwrite it)")
    check_folder_writable(path.parent)
    return path


def check_folder_writable(folder: str | os.PathLike[str]) -> Path:
    """Refuse a folder that does not exist, is not a folder, or where a file cannot be made.

    The test is to make (and remove) a file there: permissions alone do not tell (root
    ignores them; a read-only mount or /proc refuses root too)."""
    folder = Path(folder)
    if not folder.exists():
        raise DrumrollError(f"{folder}: no such directory")
    if not folder.is_dir():
        raise DrumrollError(f"{folder}: is not a directory")
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".drumroll-probe-"):
            pass
    except OSError as exc:
        raise DrumrollError(f"{folder}: cannot write there ({exc.strerror or exc})") from None
    return folder


#: Figure files the commands write, by suffix (what matplotlib's Agg, PDF, SVG and PS
#: backends write without further packages).
FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff",
                   ".webp")


def check_figure_suffix(path: str | os.PathLike[str]) -> Path:
    """Refuse a figure file name whose suffix names no format a figure can be written in."""
    path = Path(path)
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise DrumrollError(f"{path}: a figure is written as {', '.join(FIGURE_SUFFIXES)}; "
                            f"{path.suffix or 'no suffix'} is none of them")
    return path


def _staging_file(path: Path) -> Path:
    """A new empty file beside ``path``, with ``path``'s suffix and the mode a plain
    ``open()`` would give it."""
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}",
                                    dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    # mkstemp creates the file private (0600); give it the mode a plain open() would.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return tmp


@contextlib.contextmanager
def atomic_paths(paths: list[str | os.PathLike[str]], *, overwrite: bool = False
                 ) -> Iterator[list[Path]]:
    """Yield a temporary path beside each of ``paths``; if the block succeeds, rename each
    onto its path, the outputs of one command together.

    The temporary files keep their path's suffix so that writers which choose a format by
    suffix (soundfile, matplotlib) still do the right thing. On any exception, Ctrl-C
    included, every temporary file is removed and no path is touched: a later output that
    fails (a full disk) leaves no earlier one behind. A full disk is one line naming the
    output (:func:`no_space_error`).
    """
    finals = [check_writable(path, overwrite=overwrite) for path in paths]
    temporaries: list[Path] = []

    def concerned(exc: OSError) -> Path:
        # The output the error is about: the one whose file it names, else the one being
        # staged (or the only one).
        named = [final for final, tmp in zip(finals, temporaries, strict=False)
                 if exc.filename in (str(tmp), str(final))]
        return named[0] if named else finals[min(len(temporaries), len(finals) - 1)]

    try:
        for final in finals:
            temporaries.append(_staging_file(final))
        yield temporaries
        for final in finals:
            if final.exists() and not overwrite:  # appeared while we were working
                raise DrumrollError(f"{final}: already exists (use --force to overwrite it)")
        # A Ctrl-C or SIGTERM whose exception was swallowed (raised in a garbage
        # collector's callback) must not let the outputs through.
        raise_if_interrupted()
        for final, tmp in zip(finals, temporaries, strict=True):
            os.replace(tmp, final)
    except OSError as exc:
        if not no_space(exc):
            raise
        raise no_space_error(concerned(exc), exc) from None
    finally:
        for tmp in temporaries:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds
    (see :func:`atomic_paths`).

    On any exception, Ctrl-C included, the temporary file is removed and ``path`` is
    untouched.
    """
    with atomic_paths([path], overwrite=overwrite) as (tmp,):
        yield tmp


def write_text(path: str | os.PathLike[str], text: str, *, overwrite: bool = False) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_path`)."""
    with atomic_path(path, overwrite=overwrite) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_with(path: str | os.PathLike[str], writer: Callable[[Path], object], *,
               overwrite: bool = False) -> Path:
    """Call ``writer(tmp_path)`` and move the result onto ``path`` atomically."""
    with atomic_path(path, overwrite=overwrite) as tmp:
        writer(tmp)
    return Path(path)


def write_together(writers: Mapping[str | os.PathLike[str], Callable[[Path], object]], *,
                   overwrite: bool = False) -> list[Path]:
    """Call each writer with a temporary path beside its output, then move them all into
    place: every output or none (see :func:`atomic_paths`).

    Parameters
    ----------
    writers
        Output path → ``writer(tmp_path)``, called in order.
    overwrite
        Allow replacing existing files.

    Returns
    -------
    list of Path
        The outputs written.
    """
    with atomic_paths(list(writers), overwrite=overwrite) as temporaries:
        for (path, writer), tmp in zip(writers.items(), temporaries, strict=True):
            try:
                writer(tmp)
            except NoSpace as exc:  # a writer that stages its own file: name the output
                raise NoSpace(path, exc.errno) from None
            except OSError as exc:
                if not no_space(exc):
                    raise
                raise no_space_error(path, exc) from None
    return [Path(path) for path in writers]
