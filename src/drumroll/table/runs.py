"""Reading a RUNS.toml file: the set of recordings that make one table.

The format (a contract; paths are relative to the RUNS.toml file)::

    base = "config.toml"          # the shared config
    vary = "pivot_mm"             # the quantity in the first column (optional)
    title = "Table 1"             # optional caption
    share = ["alpha"]             # optional: parameters fitted jointly across the runs

    [sampler]                     # optional overrides applied to every run: [priors],
    evidence = false              # [stick], [sampler], [likelihood], [report]

    [[run]]
    label = "d110"
    source = "roll_d110.flac"     # audio or onset file
    group = "pivot"               # optional: runs sharing a group share a Figure 5 panel
    roll = 1                      # optional: which roll of the source (default the longest)
    stream = 1                    # optional: which audio stream of a video (default 0)
    config = "other.toml"         # optional: instead of base
    [run.priors]                  # per-run overrides, same keys as the config's [priors]
    pivot_mm = { dist = "normal", mu = 110, sigma = 2 }

Everything is validated here, before any sampling starts: each problem is one
:class:`~drumroll.errors.ConfigError` line naming the file, the run and the key.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from drumroll.config import Config, parse_config
from drumroll.config.loader import read_toml
from drumroll.config.validate import check_keys, did_you_mean, number, string, table, type_name
from drumroll.errors import ConfigError
from drumroll.physics.models import parameter_keys
from drumroll.quantities import PARAMETERS, STICK_DIMENSIONS, Quantity

#: Config sections a RUNS file (top level or one run) may override.
OVERRIDABLE = ("priors", "stick", "sampler", "likelihood", "report")
_TOP_LEVEL = ("base", "vary", "title", "share", "run", *OVERRIDABLE)
_RUN_KEYS = ("label", "source", "config", "group", "roll", "stream", *OVERRIDABLE)
#: Sections of a config that estimation never reads (left out of the effective config).
_IGNORED_SECTIONS = ("simulate",)
#: Sections parsed by the estimation code (validated by :func:`validate_estimation`).
ESTIMATION_SECTIONS = ("sampler", "likelihood", "report")
#: Parameters whose sampler coordinates depend on other columns: they cannot be shared.
_NOT_SHAREABLE = ("height_mm",)


@dataclass(frozen=True)
class Run:
    """One row of the table.

    Attributes
    ----------
    label
        Unique name of the run.
    source
        The recording or onset file (absolute).
    raw
        The effective config (base or the run's own, with the overrides merged in and
        ``[sampler] workers = 1``), as a TOML document: what is hashed and sent to workers.
    config
        ``raw`` parsed and validated, except the estimation sections (``[sampler]``, …; see
        :func:`validate_estimation`).
    group
        Figure 5 panel (``None``: the single default panel).
    roll
        Which roll of the source to fit (0, 1, 2, … in time order; ``None``: the longest).
    stream
        Which audio stream of the source (0-based; ``None``: the first).
    """

    label: str
    source: Path
    raw: dict[str, Any]
    config: Config
    group: str | None = None
    roll: int | None = None
    stream: int | None = None


@dataclass(frozen=True)
class RunsFile:
    """A parsed RUNS.toml.

    Attributes
    ----------
    path
        The file.
    runs
        The runs, in file order.
    vary
        Config key of the first column's quantity (``pivot_mm``, ``length_mm``, …) or None.
    share
        Config keys of the parameters fitted jointly across runs (empty: independent fits).
    title
        Caption, if given.
    """

    path: Path
    runs: tuple[Run, ...]
    vary: str | None = None
    share: tuple[str, ...] = ()
    title: str | None = None
    groups: tuple[str | None, ...] = field(default=())

    @property
    def cache_dir(self) -> Path:
        """Default cache folder: ``.drumroll-cache/`` beside the RUNS file."""
        return self.path.parent / ".drumroll-cache"


def vary_spec(key: str) -> Quantity:
    """The parameter behind a ``vary`` key (a ``[priors]`` or ``[stick]`` key)."""
    return PARAMETERS.get(key) or STICK_DIMENSIONS[key]


def load_runs(path: str | Path) -> RunsFile:
    """Read and validate the RUNS.toml at ``path`` (see the module docstring).

    Raises
    ------
    ConfigError
        One line: ``RUNS.toml: run 'd110': priors.pivto_mm: unknown key (did you mean
        'pivot_mm'?)``, a missing source or config file, a duplicate label, an unknown
        ``vary`` or ``share`` key, malformed TOML.
    """
    path = Path(path)
    raw = read_toml(path, "runs file")
    try:
        return parse_runs(raw, path)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def parse_runs(raw: Mapping[str, Any], path: Path) -> RunsFile:
    """Validate an already-parsed RUNS document; ``path`` anchors its relative paths."""
    check_keys(raw, _TOP_LEVEL, "")
    folder = path.parent
    vary = raw.get("vary")
    if vary is not None:
        known = (*PARAMETERS, *STICK_DIMENSIONS)
        vary = string(vary, "vary")
        if vary not in known:
            raise ConfigError(f"vary: {vary!r} is not a parameter{did_you_mean(vary, known)}")
    share = _parse_share(raw.get("share", []))
    title = string(raw["title"], "title") if "title" in raw else None
    common = {name: table(raw[name], name) for name in OVERRIDABLE if name in raw}
    base_raw = (_read_config(folder, raw["base"], "base", complete=False) if "base" in raw
                else None)
    entries = raw.get("run")
    if not isinstance(entries, list) or not entries:
        raise ConfigError("run: no runs (add [[run]] tables with a label and a source)")
    runs: list[Run] = []
    seen: dict[str, int] = {}
    for index, entry in enumerate(entries):
        run = _parse_run(entry, index, folder, base_raw, common)
        if run.label in seen:
            raise ConfigError(f"run[{index}]: duplicate label {run.label!r} (also "
                              f"run[{seen[run.label]}])")
        seen[run.label] = index
        _check_run(run, vary, share)
        runs.append(run)
    if share and len(runs) < 2:
        raise ConfigError("share: a joint fit needs at least two runs")
    for key in share:
        name = PARAMETERS[key].name
        first = runs[0].config.priors.get(name)
        for run in runs[1:]:
            if run.config.priors.get(name) != first:
                raise ConfigError(f"share: {key} has different priors in runs "
                                  f"{runs[0].label!r} and {run.label!r}; a shared parameter "
                                  "needs one prior")
    groups = tuple(dict.fromkeys(r.group for r in runs))
    return RunsFile(path=path, runs=tuple(runs), vary=vary, share=share, title=title,
                    groups=groups)


def _parse_share(value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list):
        raise ConfigError(f"share: expected a list of parameter names, got {type_name(value)}")
    out = []
    for i, key in enumerate(value):
        key = string(key, f"share[{i}]")
        if key not in PARAMETERS:
            raise ConfigError(f"share[{i}]: {key!r} is not a parameter"
                              f"{did_you_mean(key, PARAMETERS)}")
        if key in _NOT_SHAREABLE:
            raise ConfigError(f"share[{i}]: {key} cannot be shared (its sampler coordinates "
                              "depend on each run's geometry)")
        out.append(key)
    return tuple(dict.fromkeys(out))


def _read_config(folder: Path, value: Any, key: str, *, complete: bool = True
                 ) -> dict[str, Any]:
    """The raw TOML of a config named at ``key`` (sections estimation never reads dropped).

    A ``complete`` config (a run's own) has its physics validated here, the estimation
    sections by :func:`validate_estimation`. The base need not be complete: a prior every
    run gives itself may be absent from it, so it is checked merged into each run (its
    syntax, here).
    """
    name = string(value, key)
    path = (folder / name).resolve()
    raw = read_toml(path, "config file", prefix=f"{key}: ")
    for section in _IGNORED_SECTIONS:
        raw.pop(section, None)
    if complete:
        try:
            parse_config(raw)
        except ConfigError as exc:
            raise ConfigError(f"{key}: {path}: {exc}") from None
    return raw


def validate_estimation(run: Run) -> Config:
    """The run's whole effective config, ``[sampler]``, ``[likelihood]``, ``[report]``
    included, parsed (this imports the samplers: done only for runs about to be estimated).

    Raises
    ------
    ConfigError
        One line naming the run and the key.
    """
    from drumroll.inference.settings import estimate_settings

    try:
        config = parse_config(run.raw)
        estimate_settings(config)
        return config
    except ConfigError as exc:
        raise ConfigError(f"run {run.label!r}: {exc}") from None


def _merge(raw: dict[str, Any], overrides: Mapping[str, dict[str, Any]]) -> dict[str, Any]:
    """``raw`` with each override section's keys replacing (or adding to) its own."""
    out = copy.deepcopy(raw)
    for section, values in overrides.items():
        out[section] = {**out.get(section, {}), **copy.deepcopy(values)}
    return out


def _parse_run(entry: Any, index: int, folder: Path, base_raw: dict[str, Any] | None,
               common: dict[str, dict[str, Any]]) -> Run:
    where = f"run[{index}]"
    entry = table(entry, where)
    if "label" not in entry:
        raise ConfigError(f"{where}: missing 'label'")
    label = string(entry["label"], f"{where}.label")
    if not label.strip():
        raise ConfigError(f"{where}.label: must not be empty")
    where = f"run {label!r}"
    try:
        check_keys(entry, _RUN_KEYS, "")
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    if "source" not in entry:
        raise ConfigError(f"{where}: missing 'source' (a recording or onset file)")
    source = (folder / string(entry["source"], f"{where}.source")).resolve()
    if not source.exists():
        raise ConfigError(f"{where}.source: {source}: no such file")
    if source.is_dir():
        raise ConfigError(f"{where}.source: {source}: is a directory, expected a file")
    if "config" in entry:
        raw = _read_config(folder, entry["config"], f"{where}.config")
    elif base_raw is not None:
        raw = base_raw
    else:
        raise ConfigError(f"{where}: no config (give 'base' at the top or 'config' here)")
    group = string(entry["group"], f"{where}.group") if "group" in entry else None
    roll = (int(number(entry["roll"], f"{where}.roll", nonnegative=True, integer=True))
            if "roll" in entry else None)
    stream = (int(number(entry["stream"], f"{where}.stream", nonnegative=True, integer=True))
              if "stream" in entry else None)
    overrides = {**{k: dict(v) for k, v in common.items()}}
    for section in OVERRIDABLE:
        if section in entry:
            own = table(entry[section], f"{where}.{section}")
            overrides[section] = {**overrides.get(section, {}), **own}
    raw = _merge(raw, overrides)
    for section in _IGNORED_SECTIONS:
        raw.pop(section, None)
    raw.setdefault("sampler", {})["workers"] = 1  # the table's executor runs runs side by side
    try:
        config = parse_config(raw)
        for section in ESTIMATION_SECTIONS:
            if section in raw:
                table(raw[section], section)
    except ConfigError as exc:
        of = "" if "config" in entry else " (the base config with this run's overrides)"
        raise ConfigError(f"{where}{of}: {exc}") from None
    return Run(label=label, source=source, raw=raw, config=config, group=group, roll=roll,
               stream=stream)


def _check_run(run: Run, vary: str | None, share: tuple[str, ...]) -> None:
    where = f"run {run.label!r}"
    if vary is not None and vary_value(run, vary) is None:
        raise ConfigError(f"{where}: vary = {vary!r} but this run's config has no value for it")
    for key in share:
        prior = run.config.priors.get(PARAMETERS[key].name)
        if key not in _model_keys(run.config) or prior is None:
            raise ConfigError(f"{where}: share lists {key!r}, which the {run.config.model} "
                              "model does not have")
        if prior.is_fixed:
            raise ConfigError(f"{where}: share lists {key!r}, but it is fixed in this run")


def _model_keys(config: Config) -> tuple[str, ...]:
    return (*parameter_keys(config.model), "jitter_ms")


def vary_value(run: Run, key: str) -> tuple[float, float | None] | None:
    """The ``vary`` quantity of a run and its ± in the user's units, from its prior.

    Normal: (mu, sigma); uniform: (centre, half-width); a fixed number: (value, None); other
    families: the median and half the central 68 % interval. None if the config lacks it.
    """
    section = "stick" if key in STICK_DIMENSIONS else "priors"
    value = run.raw.get(section, {}).get(key)
    if value is None:
        spec = vary_spec(key)
        prior = run.config.priors.get(spec.field)
        if prior is None or not prior.is_fixed:
            return None
        return float(prior.median()) / spec.to_si, None
    if isinstance(value, int | float):
        return float(value), None
    dist = value.get("dist")
    if dist == "normal":
        return float(value["mu"]), float(value["sigma"])
    if dist == "uniform":
        low, high = float(value["low"]), float(value["high"])
        return 0.5 * (low + high), 0.5 * (high - low)
    spec = vary_spec(key)
    prior = (run.config.priors.get(spec.field) if section == "priors"
             else getattr(run.config.stick, spec.field))
    low, mid, high = (float(prior.ppf(q)) / spec.to_si for q in (0.1587, 0.5, 0.8413))
    spread = 0.5 * (high - low)
    return mid, spread if math.isfinite(spread) and spread > 0 else None
