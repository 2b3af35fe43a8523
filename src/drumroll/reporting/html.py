"""A :class:`~drumroll.reporting.document.Document` as one self-contained HTML page.

The page opens offline in any browser and needs no script: every figure is embedded as PNG
data (a ``data:`` URI), the style sheet is inline, and nothing is fetched. Its print style
sheet (``@media print``) sets the page in black on white at a printed size, keeps a table
or a figure on one page where it fits, and does not break a page after a heading: a teacher
prints it as it is.

Every :class:`~drumroll.reporting.document.Number` is an HTML ``<data>`` element whose
``value`` is the raw number and whose ``data-source`` is the JSON pointer of that number in
the result's JSON (``data-error``, ``data-error-source`` and ``data-scale`` likewise), so
the page's numbers can be checked against ``summary.json`` by a machine.

:func:`render_fragment` renders the same blocks as one ``<div>`` with its style sheet
scoped to it, for a notebook's rich display.
"""

from __future__ import annotations

import base64
import html
import os
import struct
from pathlib import Path

from drumroll import fileio
from drumroll._version import __version__
from drumroll.reporting.document import (
    Block,
    BulletList,
    Callout,
    Code,
    CodeBlock,
    Content,
    Details,
    Document,
    Emphasis,
    Figure,
    Heading,
    Number,
    Paragraph,
    Strong,
    Table,
)

__all__ = ["STYLE", "inline", "png_size", "render_fragment", "render_html", "write_html"]

#: The style sheet, every rule scoped to ``.drumroll`` (the page's ``<main>``, or the
#: notebook display's ``<div>``), so that it styles nothing around a notebook's output.
STYLE = """\
.drumroll { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue",
  Arial, "Noto Sans", "DejaVu Sans", sans-serif; font-size: 16px; line-height: 1.5;
  color: #1a1a1a; background: #fff; max-width: 66rem; margin: 0 auto; padding: 1.5rem; }
.drumroll h1 { font-size: 1.6rem; margin: 0 0 .75rem; line-height: 1.25; }
.drumroll h2 { font-size: 1.25rem; margin: 2rem 0 .5rem; padding-bottom: .2rem;
  border-bottom: 1px solid #d0d0d0; }
.drumroll h3 { font-size: 1.05rem; margin: 1.25rem 0 .4rem; }
.drumroll p { margin: .5rem 0; }
.drumroll code { font-family: ui-monospace, "SFMono-Regular", Menlo, Consolas,
  "DejaVu Sans Mono", monospace; font-size: .9em; background: #f3f3f3; padding: 0 .2em;
  border-radius: 3px; }
.drumroll pre { background: #f6f6f6; border: 1px solid #e0e0e0; padding: .75rem;
  overflow-x: auto; font-size: .85rem; line-height: 1.35; }
.drumroll pre code { background: none; padding: 0; }
.drumroll .callout { margin: .75rem 0; padding: .5rem .8rem; border-left: 4px solid #0072B2;
  background: #eef6fb; }
.drumroll .callout.warning, .drumroll ul.warnings { border-left-color: #D55E00;
  background: #fdf1e8; }
.drumroll ul.warnings { margin: .75rem 0; padding: .5rem .8rem .5rem 2rem;
  border-left: 4px solid #D55E00; }
.drumroll table { border-collapse: collapse; margin: .75rem 0; font-size: .92rem;
  font-variant-numeric: tabular-nums; }
.drumroll caption { caption-side: top; text-align: left; font-weight: 600;
  padding-bottom: .4rem; }
.drumroll th, .drumroll td { border-bottom: 1px solid #dcdcdc; padding: .3rem .6rem;
  vertical-align: top; text-align: left; }
.drumroll th { border-bottom: 2px solid #999; font-weight: 600; }
.drumroll .num { text-align: right; }
.drumroll .nowrap, .drumroll td code { white-space: nowrap; }
.drumroll .table-wrap { overflow-x: auto; }
.drumroll .table-notes { font-size: .88rem; color: #333; margin: .25rem 0 1rem; }
.drumroll .table-notes p { margin: .2rem 0; }
.drumroll .table-notes p.warning { color: #8a3500; }
.drumroll figure { margin: 1.25rem 0; }
.drumroll figure img { max-width: 100%; height: auto; display: block;
  border: 1px solid #eee; }
.drumroll figcaption { font-size: .9rem; color: #333; margin-top: .35rem; }
.drumroll details { margin: .75rem 0; }
.drumroll summary { cursor: pointer; font-weight: 600; }
.drumroll footer { margin-top: 2.5rem; font-size: .8rem; color: #666; }
@media print {
  @page { margin: 14mm 12mm; }
  .drumroll { max-width: none; padding: 0; font-size: 10.5pt; line-height: 1.4; }
  .drumroll h1 { font-size: 16pt; }
  .drumroll h2 { font-size: 13pt; margin-top: 1.2rem; break-after: avoid; }
  .drumroll h3 { font-size: 11pt; break-after: avoid; }
  .drumroll table { font-size: 9pt; }
  .drumroll .table-wrap { overflow: visible; }
  .drumroll table, .drumroll figure, .drumroll .callout, .drumroll ul.warnings {
    break-inside: avoid; }
  .drumroll tr { break-inside: avoid; }
  .drumroll figure img { max-height: 22cm; width: auto; margin: 0 auto; border: none; }
  .drumroll .callout, .drumroll ul.warnings { background: none; }
  .drumroll pre { white-space: pre-wrap; background: none; }
  .drumroll summary { cursor: auto; }
}
"""


#: Pixels per inch of a CSS pixel: a figure is shown at the size it was drawn in inches.
CSS_DPI = 96


def png_size(data: bytes) -> tuple[int, int] | None:
    """Width and height of a PNG from its header (None: not a PNG)."""
    if len(data) < 24 or data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR":
        return None
    return struct.unpack(">II", data[16:24])


def png_dpi(data: bytes, default: float = 150.0) -> float:
    """The resolution a PNG was drawn at (its ``pHYs`` chunk, which matplotlib writes;
    ``default`` without one)."""
    at = data.find(b"pHYs", 0, 4096)  # among the first chunks, before the image data
    if at < 0 or len(data) < at + 13:
        return default
    per_unit, _, unit = struct.unpack(">IIB", data[at + 4:at + 13])
    # pixels per metre, a whole number: 5906 is 150.01 dpi, which is 150
    return round(per_unit * 0.0254, 1) if unit == 1 and per_unit > 0 else default


def _escape(text: str) -> str:
    return html.escape(text, quote=True)


def _number(part: Number) -> str:
    attributes = []
    if part.value is not None:
        attributes.append(f'value="{part.value!r}"')
    if part.source is not None:
        attributes.append(f'data-source="{_escape(part.source)}"')
    if part.error is not None:
        attributes.append(f'data-error="{part.error!r}"')
    if part.error_source is not None:
        attributes.append(f'data-error-source="{_escape(part.error_source)}"')
    if part.scale != 1.0:
        attributes.append(f'data-scale="{part.scale!r}"')
    return f"<data {' '.join(attributes)}>{_escape(part.text)}</data>"


def inline(parts: Content) -> str:
    """Inline content as HTML (text escaped)."""
    out = []
    for part in parts:
        if isinstance(part, str):
            out.append(_escape(part))
        elif isinstance(part, Strong):
            out.append(f"<strong>{inline(part.content)}</strong>")
        elif isinstance(part, Emphasis):
            out.append(f"<em>{inline(part.content)}</em>")
        elif isinstance(part, Code):
            out.append(f"<code>{_escape(part.text)}</code>")
        elif isinstance(part, Number):
            out.append(_number(part))
        else:
            raise TypeError(f"not inline content: {part!r}")
    return "".join(out)


def _has_number(parts: Content) -> bool:
    return any(isinstance(p, Number) or (isinstance(p, Strong | Emphasis)
                                         and _has_number(p.content)) for p in parts)


def _cell(tag: str, parts: Content, align: str | None) -> str:
    # A number is not broken across lines ("0.880 ± 0.002" stays whole).
    classes = [name for name, on in (("num", align == "right"),
                                     ("nowrap", _has_number(parts)))
               if on]
    css = f' class="{" ".join(classes)}"' if classes else ""
    return f"<{tag}{css}>{inline(parts)}</{tag}>"


def _table(table: Table) -> str:
    align = table.align or (None,) * len(table.header)
    lines = ['<div class="table-wrap"><table>']
    if table.caption:
        lines.append(f"<caption>{inline(table.caption)}</caption>")
    lines.append("<thead><tr>" + "".join(_cell("th", h, a) for h, a in
                                         zip(table.header, align, strict=True)) + "</tr></thead>")
    lines.append("<tbody>")
    lines += ["<tr>" + "".join(_cell("td", c, a) for c, a in zip(row, align, strict=True))
              + "</tr>" for row in table.rows]
    lines.append("</tbody></table></div>")
    if table.notes:
        lines.append('<div class="table-notes">')
        lines += [("<p class=\"warning\">" if note.warning else "<p>")
                  + f"{inline(note.content)}</p>" for note in table.notes]
        lines.append("</div>")
    return "\n".join(lines)


def _figure(figure: Figure) -> str:
    data = figure.image_bytes()
    if data is None:
        raise ValueError(f"figure {figure.caption!r} has neither a file nor its bytes")
    size = png_size(data)
    if size is None:
        raise ValueError(f"figure {figure.caption!r}: not a PNG")
    # Shown at the size it was drawn, in inches (the style sheets shrink it to the page).
    scale = CSS_DPI / png_dpi(data)
    width, height = (round(v * scale) for v in size)
    uri = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
    caption = f"<strong>{_escape(figure.caption)}.</strong>"
    if figure.note:
        caption += f" {_escape(figure.note)}"
    return (f'<figure><img src="{uri}" alt="{_escape(figure.caption)}" width="{width}" '
            f'height="{height}"><figcaption>{caption}</figcaption></figure>')


def _block(block: Block) -> str:
    if isinstance(block, Heading):
        level = min(max(block.level, 1), 6)
        return f"<h{level}>{inline(block.content)}</h{level}>"
    if isinstance(block, Paragraph):
        return f"<p>{inline(block.content)}</p>"
    if isinstance(block, Callout):
        role = ' role="alert"' if block.kind == "warning" else ""
        return f'<div class="callout {block.kind}"{role}><p>{inline(block.content)}</p></div>'
    if isinstance(block, BulletList):
        css = ' class="warnings"' if block.kind == "warning" else ""
        return f"<ul{css}>" + "".join(f"<li>{inline(item)}</li>" for item in block.items) \
            + "</ul>"
    if isinstance(block, Table):
        return _table(block)
    if isinstance(block, Figure):
        return _figure(block)
    if isinstance(block, CodeBlock):
        language = f' class="language-{_escape(block.language)}"' if block.language else ""
        return f"<pre><code{language}>{_escape(block.text)}</code></pre>"
    if isinstance(block, Details):
        return (f"<details><summary>{_escape(block.summary)}</summary>\n"
                + _blocks(block.blocks) + "\n</details>")
    raise TypeError(f"not a block: {block!r}")


def _blocks(blocks: tuple[Block, ...]) -> str:
    return "\n".join(_block(block) for block in blocks)


def render_html(document: Document) -> str:
    """``document`` as a complete HTML page (UTF-8, figures embedded, no scripts)."""
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f'<meta name="generator" content="drumroll {_escape(__version__)}">\n'
        f"<title>{_escape(document.title)}</title>\n"
        f"<style>\n{STYLE}body {{ margin: 0; background: #fff; }}\n</style>\n"
        "</head>\n<body>\n"
        f'<main class="drumroll">\n{_blocks(document.blocks)}\n'
        f"<footer>Made by drumroll {_escape(__version__)}.</footer>\n</main>\n"
        "</body>\n</html>\n")


def render_fragment(document: Document) -> str:
    """``document``'s blocks as one ``<div class="drumroll">`` with the style sheet (scoped
    to it), for a notebook's rich display (``_repr_html_``)."""
    return (f'<div class="drumroll">\n<style>\n{STYLE}</style>\n'
            f"{_blocks(document.blocks)}\n</div>")


def write_html(path: str | os.PathLike[str], document: Document, *,
               overwrite: bool = False) -> Path:
    """Write ``document`` as an HTML page to ``path``, atomically.

    Raises
    ------
    drumroll.errors.DrumrollError
        If ``path`` exists and ``overwrite`` is false, or its folder does not exist.
    """
    return fileio.write_text(path, render_html(document), overwrite=overwrite)
