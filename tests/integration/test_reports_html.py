"""What people look at, end to end on the bundled data (no mocks): the HTML reports the
examples produce, the notebook example and its rich displays, and the progress bars.

The bundled runs file ``examples/tension.toml`` (two recordings) is run once through the
command line under a pseudo-terminal (its bar) into a cache that the piped and quiet runs
and the notebook example then read; the notebook example (``examples/notebook.py``) runs in
this process, as a notebook's kernel would, and writes the estimate's ``report.html``.
Each HTML page is parsed (every image embedded and decoded, every number of its tables the
JSON's, every warning before the first number) and rendered by headless Chromium, whose
screenshot must be neither blank nor cut.
"""

from __future__ import annotations

import base64
import fcntl
import io
import json
import math
import os
import pty
import re
import runpy
import select
import shutil
import struct
import subprocess
import sys
import termios
import time
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from configs import BALL_CONFIG
from paths import ROOT

EXAMPLES = ROOT / "examples"
RUNS = EXAMPLES / "tension.toml"
DRUMROLL = [sys.executable, "-m", "drumroll"]


# -- running a command on a terminal ---------------------------------------------------------
def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    env["MPLBACKEND"] = "Agg"
    env.pop("DRUMROLL_NOTEBOOK_OUT", None)
    return env


def run_on_terminal(args: list[str], timeout: float = 300.0) -> tuple[int, str]:
    """Run ``args`` with standard input, output and error on a pseudo-terminal of 100 × 30
    characters, as a person's terminal; return the exit status and everything it showed."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    process = subprocess.Popen(args, stdin=slave, stdout=slave, stderr=slave,
                               env=_environment(), close_fds=True, start_new_session=True)
    os.close(slave)
    shown = bytearray()
    deadline = time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            ready, _, _ = select.select([master], [], [], 1.0)
            if not ready:
                if process.poll() is not None:
                    break
                continue
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO: the last writer closed the terminal
                break
            if not chunk:
                break
            shown += chunk
        status = process.wait(timeout=max(1.0, deadline - time.monotonic()))
    finally:
        os.close(master)
        if process.poll() is None:
            process.kill()
            process.wait()
    return status, shown.decode("utf-8", errors="replace")


#: A tqdm bar of the table's runs with its time left: "table: 50%|███  | 1/2 [00:09<00:09".
TABLE_BAR = re.compile(r"table:\s+\d+%\|.*\| [0-2]/2 \[\d\d:\d\d<\d\d:\d\d")


@pytest.fixture(scope="module")
def table_run(tmp_path_factory) -> dict[str, Path]:
    """``drumroll table examples/tension.toml -o tension.md`` on a terminal, into a new
    cache: both recordings are estimated while the bar counts them."""
    folder = tmp_path_factory.mktemp("table")
    cache = folder / "cache"
    status, shown = run_on_terminal([*DRUMROLL, "table", str(RUNS), "--cache-dir", str(cache),
                                     "-o", str(folder / "tension.md")])
    assert status == 0, shown
    status, _ = run_on_terminal([*DRUMROLL, "table", str(RUNS), "--cache-dir", str(cache),
                                 "--format", "json", "-o", str(folder / "tension.json"), "-q"])
    assert status == 0
    return {"folder": folder, "cache": cache, "shown": shown}


def test_table_shows_a_bar_with_the_time_left_on_a_terminal(table_run):
    shown = table_run["shown"]
    assert TABLE_BAR.search(shown), shown
    assert "2/2" in shown and "100%" in shown
    # the news lines are written above the bar, not through it
    assert "run 'soft': done in" in shown and "run 'hard': done in" in shown
    assert "table written to" in shown


def test_table_shows_no_bar_when_piped(table_run, tmp_path):
    out = subprocess.run([*DRUMROLL, "table", str(RUNS), "--cache-dir", str(table_run["cache"]),
                          "-o", str(tmp_path / "tension.md")], env=_environment(),
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "2 of 2 runs from the cache" in out.stderr  # the news lines stay, plain
    for mark in ("\r", "\x1b", "%|", "run/s", "s/run"):
        assert mark not in out.stderr + out.stdout
    assert (tmp_path / "tension.html").exists()


def test_quiet_shows_nothing_on_a_terminal(table_run, tmp_path):
    status, shown = run_on_terminal([*DRUMROLL, "table", str(RUNS), "--cache-dir",
                                     str(table_run["cache"]), "-o", str(tmp_path / "t.md"),
                                     "-q"])
    assert status == 0
    assert shown.strip() == ""


def test_estimate_counts_its_models_on_a_terminal(tmp_path):
    times = 0.3 + np.concatenate([[0.0], np.cumsum(0.5 * 0.75 ** np.arange(1, 10))])
    (tmp_path / "ball.txt").write_text("\n".join(f"{t:.6f}" for t in times) + "\n")
    (tmp_path / "ball.toml").write_text(BALL_CONFIG.replace("evidence = false",
                                                           "evidence = false\nmax_steps = 2000"))
    status, shown = run_on_terminal([*DRUMROLL, "estimate", str(tmp_path / "ball.txt"),
                                     "--prior", str(tmp_path / "ball.toml"), "-o",
                                     str(tmp_path / "out")])
    assert status == 0, shown
    assert re.search(r"sampling:\s+100%\|.*\| 1/1 \[", shown), shown
    assert (tmp_path / "out" / "report.html").exists()


def test_simulate_of_many_recordings_counts_them_on_a_terminal(tmp_path):
    config = tmp_path / "ball.toml"
    config.write_text((ROOT / "data" / "table2_h80.toml").read_text(encoding="utf-8")
                      .replace("sample_rate = 44100", "sample_rate = 16000"))
    status, shown = run_on_terminal([*DRUMROLL, "simulate", str(config), "--count", "3", "-o",
                                     str(tmp_path / "roll.flac")])
    assert status == 0, shown
    assert re.search(r"simulate:\s+100%\|.*\| 3/3 \[", shown), shown
    assert len(list(tmp_path.glob("roll-*.flac"))) == 3


def test_onsets_quiet_says_nothing(tmp_path):
    args = [*DRUMROLL, "onsets", str(ROOT / "data" / "table2_h80.flac"), "-o"]
    loud = subprocess.run([*args, str(tmp_path / "a.csv")], env=_environment(),
                          capture_output=True, text=True, timeout=120)
    quiet = subprocess.run([*args, str(tmp_path / "b.csv"), "--quiet"], env=_environment(),
                           capture_output=True, text=True, timeout=120)
    assert loud.returncode == quiet.returncode == 0
    assert ("14 impacts from 1.0897 s to 2.9440 s, bounces 13, 14 unheard written to"
            in loud.stderr)
    assert quiet.stderr == "" and quiet.stdout == ""
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


# -- the notebook example ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def notebook(table_run, tmp_path_factory) -> dict:
    """``examples/notebook.py`` run top to bottom in this process, as a kernel runs it (the
    table from the terminal run's cache); its namespace."""
    out = tmp_path_factory.mktemp("notebook")
    saved = {k: os.environ.get(k) for k in ("DRUMROLL_NOTEBOOK_OUT", "DRUMROLL_NOTEBOOK_CACHE",
                                             "MPLBACKEND")}
    os.environ.update(DRUMROLL_NOTEBOOK_OUT=str(out / "estimate"),
                      DRUMROLL_NOTEBOOK_CACHE=str(table_run["cache"]), MPLBACKEND="Agg")
    try:
        namespace = runpy.run_path(str(EXAMPLES / "notebook.py"), run_name="__main__")
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    namespace["OUT"] = out / "estimate"
    return namespace


def test_the_notebook_runs_top_to_bottom(notebook):
    from matplotlib.figure import Figure

    assert abs(notebook["result"].parameter("alpha").mean - 0.90) < 0.002
    assert isinstance(notebook["corner"], Figure)
    assert notebook["table"].computed == []  # read from the terminal run's cache
    for name in ("report.html", "report.md", "summary.json", "corner.png"):
        assert (notebook["OUT"] / name).exists()


# -- parsing a page ------------------------------------------------------------------------------
class Page(HTMLParser):
    """What a test reads of an HTML page: its text in order, its images, its numbers (the
    ``<data>`` elements, with their place in the text) and its table cells."""

    def __init__(self, text: str) -> None:
        super().__init__(convert_charrefs=True)
        self.parts: list[str] = []
        self.images: list[dict[str, str]] = []
        self.numbers: list[dict[str, str]] = []
        self.cells: list[dict] = []  # {"text", "numbers", "column"}
        self.scripts = 0
        self._data: dict | None = None
        self._cell: dict | None = None
        self._column = 0
        self.feed(text)
        self.close()

    @property
    def text(self) -> str:
        return "".join(self.parts)

    def handle_starttag(self, tag: str, attrs: list) -> None:
        attributes = {k: v or "" for k, v in attrs}
        if tag == "img":
            self.images.append(attributes)
        elif tag == "script":
            self.scripts += 1
        elif tag == "data":
            self._data = {**attributes, "at": len(self.text), "text": ""}
        elif tag == "tr":
            self._column = 0
        elif tag == "td":
            self._cell = {"text": "", "numbers": 0, "column": self._column}
            self._column += 1
        elif tag == "th":
            self._column += 1

    def handle_endtag(self, tag: str) -> None:
        if tag == "data" and self._data is not None:
            self.numbers.append(self._data)
            if self._cell is not None:
                self._cell["numbers"] += 1
            self._data = None
        elif tag == "td" and self._cell is not None:
            self.cells.append(self._cell)
            self._cell = None

    def handle_data(self, data: str) -> None:
        self.parts.append(data)
        if self._data is not None:
            self._data["text"] += data
        if self._cell is not None:
            self._cell["text"] += data


def resolve(document: object, pointer: str) -> object:
    """The value at a JSON pointer (RFC 6901)."""
    for token in pointer.split("/")[1:]:
        token = token.replace("~1", "/").replace("~0", "~")
        document = document[int(token)] if isinstance(document, list) else document[token]
    return document


def check_images(page: Page) -> list[Image.Image]:
    """Every image is embedded PNG data that decodes; the images."""
    decoded = []
    for image in page.images:
        src = image["src"]
        assert src.startswith("data:image/png;base64,"), src[:60]
        data = base64.b64decode(src.removeprefix("data:image/png;base64,"), validate=True)
        picture = Image.open(io.BytesIO(data))
        picture.load()  # decodes every pixel
        assert picture.width > 100 and picture.height > 100
        decoded.append(picture)
    return decoded


def check_numbers(page: Page, document: dict, *, minimum: int) -> None:
    """Every number of the page that names its place is the JSON's number there (times
    its scale), its error too; every table cell that begins with a number (but its row's
    name, and the comparison's reference) is such a number."""
    named = [n for n in page.numbers if "data-source" in n]
    assert len(named) >= minimum
    for shown in named:
        expected = resolve(document, shown["data-source"])
        scale = float(shown.get("data-scale", 1.0))
        value = float(shown["value"])
        if scale == 1.0 and "observed_flights" not in shown["data-source"]:
            assert value == expected, shown
        else:  # a unit changed, or a difference of two onsets the JSON also holds
            assert math.isclose(value, float(expected) * scale, rel_tol=1e-9), shown
        if "data-error-source" in shown:
            assert float(shown["data-error"]) == resolve(document,
                                                         shown["data-error-source"]), shown
    for cell in page.cells:
        if cell["column"] > 0 and re.match(r"\s*[−-]?[0-9]", cell["text"]) \
                and "(reference)" not in cell["text"]:
            assert cell["numbers"] > 0, cell


# -- the estimate's report ------------------------------------------------------------------------
def test_estimate_report_html_is_self_contained_and_its_numbers_are_summary_json_s(notebook):
    out = notebook["OUT"]
    page = Page((out / "report.html").read_text(encoding="utf-8"))
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert page.scripts == 0
    figures = sorted(p.name for p in out.glob("*.png"))
    assert len(check_images(page)) == len(figures) == 6
    check_numbers(page, summary, minimum=60)
    # every warning (and every note) before the first number
    first_number = min(n["at"] for n in page.numbers)
    warnings = [w for d in summary["diagnostics"].values() for w in d["warnings"]]
    assert warnings  # the bundled roll has some
    for text in [*warnings, *summary["notes"]]:
        at = page.text.find(text.strip())
        assert 0 <= at < first_number, text
    # and the order of the report: headline, parameters, comparison, checks, figures
    order = [page.text.find(s) for s in ("Result:", "Parameters (", "Model comparison",
                                         "Does each model describe the onsets?",
                                         "Sampler diagnostics", "Figures", "Onset times")]
    assert -1 not in order and order == sorted(order)


def test_table_html_is_self_contained_and_its_numbers_are_the_json_s(table_run):
    folder = table_run["folder"]
    page = Page((folder / "tension.html").read_text(encoding="utf-8"))
    document = json.loads((folder / "tension.json").read_text(encoding="utf-8"))
    assert page.scripts == 0
    assert len(check_images(page)) == 1  # Figure 5
    check_numbers(page, document, minimum=2 * 5)
    markdown = (folder / "tension.md").read_text(encoding="utf-8")
    for row in document["rows"]:  # the same table as the Markdown
        assert f"| {row['label']} |" in markdown and row["label"] in page.text


def test_committed_example_tables_are_self_contained():
    """The HTML pages examples/reproduce_tables.py wrote into examples/output."""
    pages = sorted((EXAMPLES / "output").glob("*.html"))
    assert {p.stem for p in pages} >= {"table1", "table2", "tension"}
    for path in pages:
        page = Page(path.read_text(encoding="utf-8"))
        assert page.scripts == 0 and len(check_images(page)) == 1
        markdown = path.with_suffix(".md").read_text(encoding="utf-8")
        for number in page.numbers:  # each number as the Markdown table shows it
            assert number["text"] in markdown, number


# -- rendered by a browser ------------------------------------------------------------------------
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="headless Chromium is not installed (Debian's 'chromium' package: "
    ".ci/run installs it where apt-get can)")
WIDTH = 1200


def screenshot(page: Path, png: Path, height: int) -> np.ndarray:
    """``page`` rendered by headless Chromium in a window ``WIDTH`` × ``height``, as an
    (height, width, 3) array of 0–255."""
    profile = png.parent / f"{png.stem}-profile"
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                    "--no-first-run", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync", "--hide-scrollbars",
                    f"--user-data-dir={profile}", f"--screenshot={png}",
                    f"--window-size={WIDTH},{height}", page.resolve().as_uri()],
                   check=True, capture_output=True, timeout=180)
    return np.asarray(Image.open(png).convert("RGB"))


def check_rendering(pixels: np.ndarray, images: list[Image.Image], page: Path) -> None:
    """Neither blank nor cut: ink on a fair share of the page, down to where its images
    alone reach, ending above the window's bottom, nothing past its right margin."""
    ink = np.any(pixels < 230, axis=2)
    rows = np.flatnonzero(ink.any(axis=1))
    assert 0.01 < ink.mean() < 0.6, f"{page}: {ink.mean():.3f} of the pixels inked"
    # each image is shown at most the content's width (66 rem less the padding)
    content_width = 66 * 16 - 2 * 24
    shown = sum(min(1.0, content_width / (im.width * 96 / _dpi(im))) * im.height * 96
                / _dpi(im) for im in images)
    assert rows[-1] > shown, f"{page}: the page ends at {rows[-1]} px, its images alone " \
        f"take {shown:.0f} px"
    assert rows[-1] < pixels.shape[0] - 40, f"{page}: cut at the window's bottom"
    assert not ink[:, -40:].any(), f"{page}: something runs past the right margin"


def _dpi(image: Image.Image) -> float:
    return float(image.info.get("dpi", (150.0, 150.0))[0])


@needs_chromium
def test_estimate_report_renders_whole_in_a_browser(notebook, tmp_path):
    page = notebook["OUT"] / "report.html"
    images = check_images(Page(page.read_text(encoding="utf-8")))
    pixels = screenshot(page, tmp_path / "estimate.png", height=12000)
    check_rendering(pixels, images, page)


@needs_chromium
def test_table_report_renders_whole_in_a_browser(table_run, tmp_path):
    page = table_run["folder"] / "tension.html"
    images = check_images(Page(page.read_text(encoding="utf-8")))
    pixels = screenshot(page, tmp_path / "table.png", height=2400)
    check_rendering(pixels, images, page)


# -- rich display of each result type -----------------------------------------------------------
def _display(obj: object) -> Page:
    html = obj._repr_html_()
    assert html.startswith('<div class="drumroll">') and html.endswith("</div>")
    page = Page(html)
    assert page.scripts == 0
    assert len(check_images(page)) == 1  # the key figure
    assert "<table>" in html
    markdown = obj._repr_markdown_()
    assert "|---" in markdown and "<img" not in markdown
    text = repr(obj)
    assert len(text) < 300 and "\n" not in text
    return page


def test_the_estimate_displays_its_headline_table_and_bounce_series(notebook):
    result = notebook["result"]
    page = _display(result)
    assert "Result:" in page.text and "Parameters (exact pendulum)" in page.text
    assert "Bounce series" in page.text
    check_numbers(page, result.summary.to_json(), minimum=40)
    assert repr(result).startswith("<drumroll estimate of table2_h80.flac: pendulum, 14 onsets;")


def test_the_table_displays_its_table_and_figure_5(notebook):
    from drumroll.table.formatting import to_json

    table = notebook["table"]
    page = _display(table)
    check_numbers(page, json.loads(to_json(table)), minimum=10)
    assert table._repr_markdown_().startswith("**Drumhead tension: d = 131 mm, h = 80 mm**\n")
    assert repr(table).startswith("<drumroll table 'Drumhead tension")


def test_the_onsets_display_their_table_and_flight_times(notebook):
    onsets = notebook["onsets"]
    page = _display(onsets)
    assert "14 impacts from 1.0897 s to 2.9440 s" in page.text
    shown = [float(n["value"]) for n in page.numbers]
    assert all(any(v == t for v in shown) for t in onsets.time_s)
    assert repr(onsets).startswith("<OnsetTable of ")


def test_the_predictions_display_every_model(notebook):
    predictions = notebook["predictions"]
    page = _display(predictions)
    summary = {m: p.summary() for m, p in predictions.items()}
    check_numbers(page, summary, minimum=10)
    assert isinstance(predictions, dict)
    one = predictions["pendulum"]
    page = _display(one)
    check_numbers(page, {"pendulum": summary["pendulum"]}, minimum=5)
    assert repr(one).startswith("<Prediction of pendulum: 5000 of 5000 draws")
