"""Writing outputs without ever losing a user's file.

Every output is written to a temporary file in the destination folder and renamed into place,
so an interrupted run leaves either the old file or the new one, never half of one. Existing
files are refused unless the caller allows overwriting.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from drumroll.errors import DrumrollError


def check_writable(path: str | os.PathLike[str], *, overwrite: bool = False) -> Path:
    """Refuse to replace an existing file unless ``overwrite`` is set.

    Parameters
    ----------
    path
        Destination the caller is about to write.
    overwrite
        Allow replacing an existing file (the command line's ``--force``).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.
    """
    path = Path(path)
    if path.is_dir():
        raise DrumrollError(f"{path}: is a directory, expected a file name to write")
    if path.exists() and not overwrite:
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


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    The temporary file keeps ``path``'s suffix so that writers which choose a format by suffix
    (soundfile, matplotlib) still do the right thing. On any exception, Ctrl-C included, the
    temporary file is removed and ``path`` is untouched.
    """
    path = check_writable(path, overwrite=overwrite)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}",
                                    dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    # mkstemp creates the file private (0600); give it the mode a plain open() would.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    try:
        yield tmp
        if path.exists() and not overwrite:  # appeared while we were working
            raise DrumrollError(f"{path}: already exists (use --force to overwrite it)")
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


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
