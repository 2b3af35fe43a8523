"""Fuzzing the runs-file reader (issue 14, section 3): whatever a RUNS.toml holds, reading it
and validating each run's whole config (what ``drumroll table`` does before any sampling)
either succeed or raise one :class:`ConfigError` line, never another exception.

Documents are drawn from the format's own vocabulary (its keys, the config sections it may
override, the priors' families and parameters) with values of every TOML type, right and
wrong; and valid files are mutated character by character. Deterministic (derandomize).
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from configs import BALL_CONFIG, PAPER_STICK
from drumroll.distributions import FAMILIES
from drumroll.errors import ConfigError
from drumroll.table.runs import load_runs, validate_estimation, vary_value

#: The files a runs document may name, made once per module (see ``folder``).
BASE = BALL_CONFIG
PENDULUM = PAPER_STICK + """
[priors]
alpha = { dist = "uniform", low = 0.5, high = 1.0 }
pivot_mm = { dist = "normal", mu = 131, sigma = 2 }
height_mm = { dist = "normal", mu = 80, sigma = 3 }
jitter_ms = { dist = "loguniform", low = 0.01, high = 10 }
"""
FILES = {"ball.toml": BASE, "pendulum.toml": 'model = "pendulum"\n' + PENDULUM,
         "broken.toml": "model = \n", "empty.toml": "", "roll.txt": "0.1\n0.5\n0.8\n1.0\n",
         "roll.csv": "time_s\n0.1\n0.5\n0.8\n1.0\n"}


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string (JSON's escapes, and DEL escaped as TOML wants)."""
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def toml_value(value) -> str:
    """A value as TOML, inline (tables and arrays on one line)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{toml_string(k)} = {toml_value(v)}" for k, v in value.items()) + "}"


def toml_document(document: dict) -> str:
    return "".join(f"{toml_string(k)} = {toml_value(v)}\n" for k, v in document.items())


def mostly(good: st.SearchStrategy, bad: st.SearchStrategy) -> st.SearchStrategy:
    """``good`` mostly, ``bad`` now and then (a file with a mistake or two)."""
    return st.one_of(*[good] * 9, bad)


TEXT = st.text(st.characters(blacklist_categories=("Cs",)), max_size=8)
#: Values of every TOML type that break a key: a few of each kind, since Hypothesis explores
#: every branch it is offered, and a space of wrong values would crowd out the right ones.
WRONG = st.sampled_from([0, -1, 2.5, 1e308, -1e-320, 2**63, -(2**64), math.nan, math.inf,
                         -math.inf, True, False, "", " ", "x", "ü\t", "nan", [], {},
                         [1, "a"], {"a": 1}, {"dist": 1}, [{"x": []}]])

PRIOR_KEYS = ["alpha", "t_b", "jitter_ms", "pivot_mm", "height_mm", "release_mm_s", "nu",
              "pivto_mm"]
STICK_KEYS = ["shape", "length_mm", "tip_mm", "radius_mm", "lenght_mm"]
SAMPLER_KEYS = ["walkers", "max_steps", "seed", "evidence", "live_points", "workers",
                "tau_multiple", "target_ess", "max_r_hat", "max_step"]


@st.composite
def priors(draw):
    """A prior as a config gives it: a family with its parameters (the registry's), or a
    number; now and then with a mistake (a parameter missing, unknown or of no sense, a
    family misspelt)."""
    if draw(st.integers(0, 4)) == 4:
        return draw(mostly(st.floats(0.01, 400), WRONG))
    family = draw(st.sampled_from(sorted(FAMILIES)))
    _, required, optional = FAMILIES[family]
    keys = [*required, *draw(st.lists(st.sampled_from(optional), unique=True))
            ] if optional else list(required)
    values = sorted(draw(st.lists(st.floats(0.01, 400), min_size=len(keys),
                                  max_size=len(keys))))
    prior = {"dist": family, **dict(zip(keys, values, strict=True))}
    if draw(st.integers(0, 4)) == 4:
        mistake = draw(st.sampled_from(["missing", "unknown", "value", "family"]))
        if mistake == "missing":
            del prior[draw(st.sampled_from(keys))]
        elif mistake == "unknown":
            prior[draw(st.sampled_from(["mode", "sd", "mean"]))] = 1.0
        elif mistake == "value":
            prior[draw(st.sampled_from(keys))] = draw(WRONG)
        else:
            prior["dist"] = draw(st.sampled_from(["nrmal", "", 1]))
    return prior


def section(keys: list[str], values: st.SearchStrategy) -> st.SearchStrategy:
    """A config section: its keys (now and then an unknown one) with ``values``."""
    return st.dictionaries(mostly(st.sampled_from(keys), st.sampled_from(["", "x", "ü"])),
                           values, max_size=3)


SECTIONS = {
    "priors": section(PRIOR_KEYS, priors()),
    "stick": section(STICK_KEYS, mostly(st.one_of(st.floats(1, 400), priors()), WRONG)),
    "sampler": section(SAMPLER_KEYS, mostly(st.integers(1, 2000), WRONG)),
    "likelihood": section(["noise", "nu"], mostly(st.sampled_from(["gaussian", "student-t"]),
                                                  WRONG)),
    "report": section(["hdi_prob"], mostly(st.floats(0, 1), WRONG)),
}
#: File names a runs file may give, found or not, files or not.
NAMES = st.sampled_from([*FILES, "missing.txt", "missing.toml", ".", "", "../roll.txt",
                         "/dev/null", "ü/€", 3, True])


@st.composite
def runs(draw) -> dict:
    """One ``[[run]]`` table: its keys (mostly a source), each value mostly right."""
    run = {}
    for key in draw(st.lists(st.sampled_from(["source", "config", "group", "roll", "stream",
                                              "label", "colour", *SECTIONS]),
                             max_size=5, unique=True)):
        if key == "label":
            run[key] = draw(mostly(TEXT, st.sampled_from(["a", " ", "", 1, True])))
        elif key == "source":
            run[key] = draw(mostly(st.sampled_from(["roll.txt", "roll.csv"]), NAMES))
        elif key == "config":
            run[key] = draw(mostly(st.sampled_from(["ball.toml", "pendulum.toml"]), NAMES))
        elif key in ("roll", "stream"):
            run[key] = draw(mostly(st.integers(0, 1), WRONG))
        elif key in SECTIONS:
            run[key] = draw(mostly(SECTIONS[key], WRONG))
        else:
            run[key] = draw(mostly(TEXT, WRONG))
    if draw(st.integers(0, 5)) < 5:
        run.setdefault("source", draw(st.sampled_from(["roll.txt", "roll.csv"])))
    return run


@st.composite
def documents(draw) -> dict:
    """A runs document: mostly a base, now and then vary, share, a title, overrides or an
    unknown key; one to four runs, mostly each with its own label."""
    document = {}
    if draw(st.integers(0, 5)) < 5:
        document["base"] = draw(mostly(st.sampled_from(["ball.toml", "pendulum.toml"]),
                                       NAMES))
    if draw(st.integers(0, 2)) == 2:
        document["vary"] = draw(mostly(st.sampled_from(["pivot_mm", "height_mm", "alpha",
                                                        "t_b", "length_mm", "jitter_ms"]),
                                       st.sampled_from(["pivot", 1, True, ""])))
    if draw(st.integers(0, 3)) == 3:
        document["share"] = draw(mostly(st.lists(st.sampled_from(["alpha", "t_b",
                                                                  "height_mm", "jitter_ms",
                                                                  "alfa"]), max_size=3),
                                        st.sampled_from(["alpha", "x", 1, True])))
    if draw(st.integers(0, 5)) == 5:
        document["title"] = draw(mostly(TEXT, WRONG))
    for name in draw(st.lists(st.sampled_from(list(SECTIONS)), max_size=2, unique=True)):
        document[name] = draw(SECTIONS[name])
    if draw(st.integers(0, 8)) == 8:
        document[draw(st.sampled_from(["vray", "runs", "model"]))] = draw(WRONG)
    document["run"] = draw(mostly(st.lists(runs(), min_size=1, max_size=4),
                                  st.one_of(st.just([]), WRONG)))
    if isinstance(document["run"], list) and draw(st.integers(0, 5)) < 5:
        for i, run in enumerate(document["run"]):  # mostly labelled, each its own label
            if isinstance(run, dict):
                run.setdefault("label", f"run {i}")
    return document


@pytest.fixture(scope="module")
def folder():
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for file, text in FILES.items():
            (folder / file).write_text(text)
        yield folder


def read_and_validate(folder: Path, text: str) -> None:
    """Read ``text`` as a runs file and validate each run as ``table`` does; a refusal must
    be one :class:`ConfigError` line naming the runs file (a run's estimation settings:
    naming the run, the table puts the file before it)."""
    path = folder / "runs.toml"
    path.write_text(text, encoding="utf-8")
    try:
        runs = load_runs(path)
    except ConfigError as exc:
        refused(str(exc), f"{path}: ")
        return
    for run in runs.runs:
        try:
            validate_estimation(run)
        except ConfigError as exc:
            refused(str(exc), f"run {run.label!r}: ")
            return
        if runs.vary is not None:
            vary_value(run, runs.vary)
    event("read")  # --hypothesis-show-statistics gives the shares


def refused(message: str, start: str) -> None:
    assert message.startswith(start) and "\n" not in message, message
    event("refused in one line")


@settings(max_examples=300)
@given(documents())
def test_any_runs_document_is_read_or_refused_in_one_line(folder, document):
    read_and_validate(folder, toml_document(document))


VALID = toml_document({"base": "ball.toml", "vary": "t_b", "sampler": {"seed": 3},
                       "run": [{"label": "a", "source": "roll.txt", "group": "g"},
                               {"label": "b", "source": "roll.csv", "roll": 0,
                                "priors": {"t_b": {"dist": "normal", "mu": 0.5,
                                                   "sigma": 0.1}}}]})


@settings(max_examples=200)
@given(st.lists(st.tuples(st.integers(0, len(VALID)), st.integers(0, 2),
                          st.sampled_from([*'"=[]{},.\n#\\ 0a-_ü\t\'', "inf", "nan"])),
                min_size=1, max_size=4))
def test_a_mutated_runs_file_is_read_or_refused_in_one_line(folder, edits):
    """A valid file with characters deleted, replaced or inserted (a typing slip)."""
    text = VALID
    for at, how, what in edits:
        at = min(at, len(text))
        text = (text[:at] + what + text[at:] if how == 0 else
                text[:at] + text[at + 1:] if how == 1 else text[:at] + what + text[at + 1:])
    read_and_validate(folder, text)


def test_the_valid_file_is_read(folder):
    path = folder / "runs.toml"
    path.write_text(VALID)
    runs = load_runs(path)
    assert [r.label for r in runs.runs] == ["a", "b"]
    assert vary_value(runs.runs[1], "t_b") == (0.5, 0.1)
