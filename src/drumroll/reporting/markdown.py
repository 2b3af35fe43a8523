"""A :class:`~drumroll.reporting.document.Document` as GitHub Markdown.

Each block is followed by an empty line; table cells have their ``|`` escaped and their line
breaks joined; a figure is a level-3 heading with its caption, the image linked relative to
the report's folder (so the folder can be moved or zipped as a whole) and its note in
italics. A figure that has no file (drawn in memory for one report) is left out: Markdown
cannot embed an image.
"""

from __future__ import annotations

import os
from pathlib import Path

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

__all__ = ["inline", "render_blocks", "render_markdown"]


def inline(parts: Content) -> str:
    """Inline content as Markdown."""
    out = []
    for part in parts:
        if isinstance(part, str):
            out.append(part)
        elif isinstance(part, Strong):
            out.append(f"**{inline(part.content)}**")
        elif isinstance(part, Emphasis):
            out.append(f"*{inline(part.content)}*")
        elif isinstance(part, Code):
            out.append(f"`{part.text}`")
        elif isinstance(part, Number):
            out.append(part.text)
        else:
            raise TypeError(f"not inline content: {part!r}")
    return "".join(out)


def _cell(parts: Content) -> str:
    """Inline content safe inside a table cell."""
    return inline(parts).replace("|", "\\|").replace("\n", " ")


def _row(cells: tuple[Content, ...]) -> str:
    # An empty cell is "| |", not "|  |".
    return "|" + "".join(f" {text} |" if text else " |" for text in map(_cell, cells))


_RULE = {"right": "---:", "left": ":---", None: "---"}


def _table(table: Table) -> list[str]:
    lines = [f"**{inline(table.caption)}**", ""] if table.caption else []
    align = table.align or (None,) * len(table.header)
    lines += [_row(table.header), "|" + "".join(f"{_RULE[a]}|" for a in align)]
    lines += [_row(row) for row in table.rows]
    if table.notes:
        lines += ["", *(inline(note.content).replace("\n", " ") for note in table.notes)]
    return [*lines, ""]


def _figure(figure: Figure, base: Path) -> list[str]:
    if figure.path is None:
        return []
    link = Path(os.path.relpath(Path(figure.path).resolve(), base.resolve())).as_posix()
    lines = [f"### {figure.caption}", "", f"![{figure.caption}]({link})", ""]
    return [*lines, f"*{figure.note}*", ""] if figure.note else lines


def _block(block: Block, base: Path) -> list[str]:
    if isinstance(block, Heading):
        return [f"{'#' * block.level} {inline(block.content)}", ""]
    if isinstance(block, Paragraph):
        return [inline(block.content), ""]
    if isinstance(block, Callout):  # a line break would end the quote
        return [f"> {inline(block.content)}".replace("\n", " "), ""]
    if isinstance(block, BulletList):
        return [*(f"- {inline(item)}" for item in block.items), ""]
    if isinstance(block, Table):
        return _table(block)
    if isinstance(block, Figure):
        return _figure(block, base)
    if isinstance(block, CodeBlock):
        return [f"```{block.language}", block.text, "```", ""]
    if isinstance(block, Details):
        return [f"<details><summary>{block.summary}</summary>", "",
                *render_blocks(block.blocks, base), "</details>", ""]
    raise TypeError(f"not a block: {block!r}")


def render_blocks(blocks: tuple[Block, ...], base: Path) -> list[str]:
    """The Markdown lines of ``blocks`` (figures linked relative to ``base``)."""
    return [line for block in blocks for line in _block(block, base)]


def render_markdown(document: Document, base: str | os.PathLike[str] = ".") -> str:
    """``document`` as Markdown text, ending in one newline.

    Parameters
    ----------
    document
        What to render.
    base
        The folder the Markdown file is written to: figures are linked relative to it.
    """
    return "\n".join(render_blocks(document.blocks, Path(base))).rstrip() + "\n"
