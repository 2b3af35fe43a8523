"""A :class:`~drumroll.reporting.document.Document` written to disk as its two files:
``NAME.md`` (Markdown, figures linked) and ``NAME.html`` beside it (one page, figures
embedded), both or neither.

    from drumroll.reporting.report_files import write_document

    write_document("out/report.md", document, overwrite=True)   # report.md, report.html
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from drumroll import fileio
from drumroll.reporting.document import Document
from drumroll.reporting.html import render_html
from drumroll.reporting.markdown import render_markdown

__all__ = ["document_writers", "html_path", "write_document"]


def html_path(markdown_path: str | os.PathLike[str]) -> Path:
    """Where the HTML page of a Markdown report goes: beside it, suffix ``.html``."""
    return Path(markdown_path).with_suffix(".html")


def document_writers(markdown_path: str | os.PathLike[str], document: Document
                     ) -> dict[Path, Callable[[Path], object]]:
    """Output path → writer (of a temporary path beside it) of ``document``'s two files, to
    be written with others by :func:`drumroll.fileio.write_together`. The texts are
    rendered here, before any file is touched."""
    markdown_path = Path(markdown_path)
    markdown = render_markdown(document, markdown_path.parent)
    page = render_html(document)
    return {markdown_path: lambda tmp: tmp.write_text(markdown, encoding="utf-8"),
            html_path(markdown_path): lambda tmp: tmp.write_text(page, encoding="utf-8")}


def write_document(markdown_path: str | os.PathLike[str], document: Document, *,
                   overwrite: bool = False) -> tuple[Path, Path]:
    """Write ``document`` as ``markdown_path`` and its HTML page beside it, atomically and
    together.

    Returns
    -------
    tuple of Path
        The Markdown file and the HTML page.

    Raises
    ------
    drumroll.errors.DrumrollError
        If either file exists and ``overwrite`` is false, or the folder does not exist; then
        neither is written.
    """
    markdown, page = fileio.write_together(document_writers(markdown_path, document),
                                           overwrite=overwrite)
    return markdown, page
