"""One document, two renderers: each block as Markdown and as HTML, numbers with their
places, figures embedded, the page self-contained; the progress where nobody watches."""

from __future__ import annotations

import base64
import io
import re
from pathlib import Path

import matplotlib
import pytest

from drumroll.errors import DrumrollError
from drumroll.progress import Bars, Lines, Progress, as_progress, watched
from drumroll.reporting.document import (
    BulletList,
    Callout,
    Code,
    CodeBlock,
    Details,
    Document,
    Emphasis,
    Figure,
    Heading,
    Paragraph,
    Strong,
    Table,
    TableNote,
    number,
    plain_text,
    pointer,
)
from drumroll.reporting.html import png_dpi, png_size, render_fragment, render_html
from drumroll.reporting.markdown import render_markdown
from drumroll.reporting.plot_style import new_figure, png_bytes
from drumroll.reporting.report_files import write_document

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def png() -> bytes:
    fig = new_figure((2, 1.5))
    fig.subplots().plot([0, 1], [1, 0])
    return png_bytes(fig)


def _document(png: bytes, path: Path | None = None) -> Document:
    alpha = number(0.880123, "0.880 ± 0.002", "/parameters/alpha/mean", error=0.00213,
                   error_source="/parameters/alpha/sd")
    return Document("A <test> report", (
        Heading(1, ("Report of ", Code("roll.flac"))),
        Callout((Strong(("Note:",)), " a <b> & c."), "note"),
        Callout((Strong(("⚠ Misfit.",)), " line\nbreak"), "warning"),
        BulletList((("⚠ one",), ("⚠ two | three",)), kind="warning"),
        Paragraph((Strong(("Result:",)), " α = ", alpha, ", ", Emphasis(("nice",)), ".")),
        Table(header=(("name",), ("value",), ("note",)),
              rows=((("α",), (alpha,), ("a | b",)), (("—",), ("—",), ())),
              align=(None, "right", "left"), caption=("Caption",),
              notes=(TableNote(("first",)), TableNote(("careful",), warning=True))),
        Figure("A figure", "What to see.", path=path, png=png),
        Details("Folded", (CodeBlock('{"a": 1}', "json"),)),
    ))


def test_markdown_of_every_block(png, tmp_path):
    path = tmp_path / "fig" / "a.png"
    text = render_markdown(_document(png, path), tmp_path)
    assert text == (
        "# Report of `roll.flac`\n\n"
        "> **Note:** a <b> & c.\n\n"
        "> **⚠ Misfit.** line break\n\n"
        "- ⚠ one\n- ⚠ two | three\n\n"
        "**Result:** α = 0.880 ± 0.002, *nice*.\n\n"
        "**Caption**\n\n"
        "| name | value | note |\n|---|---:|:---|\n"
        "| α | 0.880 ± 0.002 | a \\| b |\n| — | — | |\n\n"
        "first\ncareful\n\n"
        "### A figure\n\n![A figure](fig/a.png)\n\n*What to see.*\n\n"
        "<details><summary>Folded</summary>\n\n```json\n{\"a\": 1}\n```\n\n</details>\n")


def test_markdown_leaves_out_a_figure_with_no_file(png):
    text = render_markdown(_document(png, None))
    assert "A figure" not in text and "![" not in text


def test_html_page_is_self_contained_escaped_and_carries_each_number(png, tmp_path):
    page = render_html(_document(png))
    assert page.startswith("<!DOCTYPE html>") and "<script" not in page
    assert "<title>A &lt;test&gt; report</title>" in page
    assert "a &lt;b&gt; &amp; c." in page  # text is text
    assert '<data value="0.880123" data-source="/parameters/alpha/mean" data-error="0.00213" ' \
        'data-error-source="/parameters/alpha/sd">0.880 ± 0.002</data>' in page
    assert '<div class="callout warning" role="alert">' in page
    assert '<ul class="warnings">' in page and "<caption>Caption</caption>" in page
    assert '<p class="warning">careful</p>' in page
    assert "@media print" in page and "http" not in page.replace("http-equiv", "")
    source = re.search(r'src="data:image/png;base64,([^"]+)"', page).group(1)
    assert base64.b64decode(source) == png
    width, _ = png_size(png)
    assert f'width="{round(width * 96 / 150)}"' in page  # drawn at 150 dpi, shown in inches
    assert png_dpi(png) == 150


def test_html_fragment_is_one_scoped_div(png):
    fragment = render_fragment(_document(png))
    assert fragment.startswith('<div class="drumroll">') and fragment.endswith("</div>")
    rules = re.findall(r"^([^@\s}][^{]*)\{", fragment.split("<style>")[1].split("</style>")[0],
                       flags=re.MULTILINE)
    assert rules and all(rule.strip().startswith(".drumroll") for rule in rules)


def test_a_figure_needs_an_image():
    with pytest.raises(ValueError, match="neither a file nor its bytes"):
        render_html(Document("x", (Figure("nothing"),)))


def test_a_table_row_must_fill_the_columns():
    with pytest.raises(ValueError, match="row 0 has 1 cells for 2 columns"):
        Table(header=(("a",), ("b",)), rows=((("x",),),))


def test_pointers_and_plain_text():
    assert pointer("models", "powerlaw/speed", "a~b", 0) == "/models/powerlaw~1speed/a~0b/0"
    assert plain_text((Strong(("a ", Code("b"))), " ", number(1.0, "1.0"))) == "a b 1.0"


def test_write_document_writes_both_files_or_neither(png, tmp_path):
    markdown, page = write_document(tmp_path / "r.md", _document(png, None))
    assert markdown.read_text(encoding="utf-8").startswith("# Report")
    assert page == tmp_path / "r.html" and page.read_text(encoding="utf-8").startswith("<!DOC")
    (tmp_path / "s.html").write_text("keep")
    with pytest.raises(DrumrollError, match="already exists"):
        write_document(tmp_path / "s.md", _document(png, None))
    assert not (tmp_path / "s.md").exists() and (tmp_path / "s.html").read_text() == "keep"


# -- progress where nobody watches ------------------------------------------------------------
def test_progress_as_asked():
    said = []
    lines = as_progress(said.append)
    assert isinstance(lines, Lines)
    lines.say("news")
    with lines.bar(3, "x", "run") as bar:
        bar.advance(note="a")
    assert said == ["news"]
    assert type(as_progress(False)) is Progress
    assert type(as_progress(None, stream=io.StringIO())) is Progress  # nobody watches
    assert watched(io.StringIO()) is None
    with pytest.raises(TypeError, match="expected a Progress"):
        as_progress(3)


def test_a_bar_drawn_where_asked_counts_and_says_above_itself():
    stream = io.StringIO()
    bars = Bars("terminal", news=True, stream=stream)
    with bars.bar(2, "table", "run", initial=1) as bar:
        bars.say("run 'b': done")
        bar.advance(note="b")
    shown = stream.getvalue()
    assert "table:" in shown and "1/2" in shown and "2/2" in shown and ", b]" in shown
    assert "run 'b': done\n" in shown
