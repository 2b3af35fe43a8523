"""A report as typed blocks, written once and rendered as Markdown or as one HTML page.

Every report of drumroll (``estimate``'s ``report.md`` / ``report.html``, ``table``'s table,
the notebook display of a result) is built as a :class:`Document`: a title and a sequence of
blocks, each block holding inline content. The builders decide *what* is said and in which
order (warnings before any number, then the headline, the tables, the figures); the
renderers decide only *how* it looks:

* :func:`drumroll.reporting.markdown.render_markdown` writes GitHub Markdown (figures linked
  relative to the report's folder);
* :func:`drumroll.reporting.html.render_html` writes one self-contained HTML page (figures
  embedded as PNG data, no scripts, a print style sheet), and
  :func:`~drumroll.reporting.html.render_fragment` the same blocks as a ``<div>`` for a
  notebook's rich display.

Blocks: :class:`Heading`, :class:`Paragraph`, :class:`Callout` (a note or a warning),
:class:`BulletList`, :class:`Table` (header, rows of cells, notes under it), :class:`Figure`
(a PNG file and/or its bytes, caption and what to look for), :class:`Details` (folded
away), :class:`CodeBlock`. Inline content (:data:`Content`) is text (``str``),
:class:`Strong`, :class:`Emphasis`, :class:`Code` and :class:`Number`.

A :class:`Number` keeps the raw value beside its formatted text, and where the value comes
from in the result's JSON (a JSON pointer such as ``/parameters/alpha/mean``, ``scale``
times the value there): the HTML page carries both, so that a reader (or a test) can check
every number against ``summary.json``.

Rendering another report (e.g. a new command's) is building its blocks and one call::

    from drumroll.reporting.document import Document, Heading, Table, number
    from drumroll.reporting.report_files import write_document

    document = Document("Calibration", (
        Heading(1, ("Calibration",)),
        Table(header=(("parameter",), ("coverage",)),
              rows=((("alpha",), (number(0.91, "0.91", "/coverage/alpha"),)),),
              align=(None, "right")),
    ))
    write_document("out/report.md", document)   # out/report.md and out/report.html

(:func:`~drumroll.reporting.report_files.document_writers` gives the two writers, to be
written together with other files; :func:`~drumroll.reporting.markdown.render_markdown` and
:func:`~drumroll.reporting.html.render_html` give the texts.)
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, Union

__all__ = ["Block", "BulletList", "Callout", "Code", "CodeBlock", "Content", "Details",
           "Document", "Emphasis", "Figure", "Heading", "Inline", "Number", "Paragraph",
           "Strong", "Table", "TableNote", "content", "iter_blocks", "number", "plain_text",
           "pointer"]


@dataclass(frozen=True)
class Strong:
    """Strong emphasis (Markdown ``**…**``, HTML ``<strong>``)."""

    content: Content


@dataclass(frozen=True)
class Emphasis:
    """Emphasis (Markdown ``*…*``, HTML ``<em>``)."""

    content: Content


@dataclass(frozen=True)
class Code:
    """A name as typed (a model, a key, a file): Markdown ``\\`…\\```, HTML ``<code>``."""

    text: str


@dataclass(frozen=True)
class Number:
    """A number as shown, with the value it shows.

    Attributes
    ----------
    text
        The formatted number as the report shows it (``0.880 ± 0.002``, ``1.0035``).
    value
        The raw value (None: not known; the text then says so, e.g. ``—``).
    source
        JSON pointer (RFC 6901) of ``value`` in the result's JSON, when it is there
        (``/parameters/alpha/mean``); None for a number computed for the report.
    error, error_source
        The raw uncertainty shown after ``±`` and its pointer, when the text has one.
    scale
        The shown value is ``scale`` times the value at ``source`` (1000 for seconds shown
        in milliseconds).
    """

    text: str
    value: float | None = None
    source: str | None = None
    error: float | None = None
    error_source: str | None = None
    scale: float = 1.0


#: One piece of inline content.
Inline = Union[str, Strong, Emphasis, Code, Number]  # noqa: UP007 (a runtime alias)
#: A run of inline content.
Content = tuple[Inline, ...]


def content(*parts: Inline | Content | None) -> Content:
    """Inline content from pieces (nested tuples flattened, None and "" left out)."""
    out: list[Inline] = []
    for part in parts:
        if part is None or part == "":
            continue
        if isinstance(part, tuple):
            out.extend(content(*part))
        else:
            out.append(part)
    return tuple(out)


def pointer(*parts: str | int) -> str:
    """A JSON pointer (RFC 6901) from its parts: ``pointer("models", "powerlaw/speed")`` is
    ``/models/powerlaw~1speed``."""
    return "".join("/" + str(p).replace("~", "~0").replace("/", "~1") for p in parts)


def number(value: float | None, text: str, source: str | None = None, *,
           error: float | None = None, error_source: str | None = None,
           scale: float = 1.0) -> Number:
    """A :class:`Number` (the raw value made a plain float; None stays None)."""
    return Number(text=text, value=None if value is None else float(value), source=source,
                  error=None if error is None else float(error), error_source=error_source,
                  scale=scale)


@dataclass(frozen=True)
class Heading:
    """A section heading, level 1 (the title) to 4."""

    level: int
    content: Content


@dataclass(frozen=True)
class Paragraph:
    """A paragraph of running text."""

    content: Content


@dataclass(frozen=True)
class Callout:
    """What the reader must see before the numbers: a note or a warning."""

    content: Content
    kind: Literal["note", "warning"] = "note"


@dataclass(frozen=True)
class BulletList:
    """An unordered list; ``kind`` ``"warning"`` marks a list of warnings."""

    items: tuple[Content, ...]
    kind: Literal["plain", "warning"] = "plain"


@dataclass(frozen=True)
class TableNote:
    """A line under a table (what a column means, a run's note or warning)."""

    content: Content
    warning: bool = False


@dataclass(frozen=True)
class Table:
    """A table of cells, each of inline content.

    Attributes
    ----------
    header
        The column headings.
    rows
        The rows, each a cell per column.
    align
        Per column ``"left"``, ``"right"`` (numbers) or None (the renderer's default).
    caption
        Shown above the table (a paper table's caption).
    notes
        Lines under the table.
    """

    header: tuple[Content, ...]
    rows: tuple[tuple[Content, ...], ...]
    align: tuple[Literal["left", "right"] | None, ...] = ()
    caption: Content = ()
    notes: tuple[TableNote, ...] = ()

    def __post_init__(self) -> None:
        width = len(self.header)
        for i, row in enumerate(self.rows):
            if len(row) != width:
                raise ValueError(f"table row {i} has {len(row)} cells for {width} columns")
        if self.align and len(self.align) != width:
            raise ValueError(f"{len(self.align)} alignments for {width} columns")


@dataclass(frozen=True)
class Figure:
    """A figure: a PNG, its caption and what to look for in it.

    Attributes
    ----------
    caption
        A few words (``Bounce series``).
    note
        What the figure shows and what to look for.
    path
        The PNG file beside the report: Markdown links it (relative to the report's
        folder); HTML embeds it.
    png
        The PNG's bytes, when the figure was drawn for this report only (no file): HTML
        embeds them; Markdown, which cannot embed an image, leaves such a figure out.
    """

    caption: str
    note: str = ""
    path: Path | None = None
    png: bytes | None = field(default=None, repr=False)

    def image_bytes(self) -> bytes | None:
        """The PNG's bytes (read from :attr:`path` when not given); None without either."""
        if self.png is not None:
            return self.png
        return None if self.path is None else Path(self.path).read_bytes()


@dataclass(frozen=True)
class CodeBlock:
    """Preformatted text (a configuration as JSON)."""

    text: str
    language: str = ""


@dataclass(frozen=True)
class Details:
    """Blocks folded away under a one-line summary (HTML ``<details>``)."""

    summary: str
    blocks: tuple[Block, ...]


#: One block of a document.
Block = Union[Heading, Paragraph, Callout, BulletList, Table, Figure, CodeBlock,  # noqa: UP007
              Details]


@dataclass(frozen=True)
class Document:
    """A report: its title (the HTML page's ``<title>``) and its blocks, in reading order."""

    title: str
    blocks: tuple[Block, ...]

    def extended(self, *blocks: Block) -> Document:
        """The document with ``blocks`` added at its end."""
        return Document(self.title, (*self.blocks, *blocks))


def iter_blocks(blocks: tuple[Block, ...]) -> Iterator[Block]:
    """Every block, those folded into :class:`Details` included, in reading order."""
    for block in blocks:
        yield block
        if isinstance(block, Details):
            yield from iter_blocks(block.blocks)


def plain_text(parts: Content) -> str:
    """The content as plain text (no markup)."""
    out = []
    for part in parts:
        if isinstance(part, str):
            out.append(part)
        elif isinstance(part, Strong | Emphasis):
            out.append(plain_text(part.content))
        elif isinstance(part, Code | Number):
            out.append(part.text)
    return "".join(out)
