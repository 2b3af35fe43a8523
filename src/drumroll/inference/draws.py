"""One fit's draws in ArviZ's groups, names and dimensions, as plain numpy arrays.

``estimate`` returns ArviZ InferenceData and ``posterior.nc`` is one, but ArviZ (with xarray,
pandas, matplotlib.pyplot and, where numba is installed, the compilation of ArviZ's ECDF
kernels at import) costs about a second of CPU to import, while the command reads nothing of
an InferenceData but arrays by name. :class:`Draws` holds the same groups, variables,
dimensions, coordinates and attributes, and answers the part of InferenceData's interface
that drumroll's summaries, checks and figures use (``draws.posterior["alpha"].values``,
``draws.posterior.data_vars``, ``draws.groups()``, ``draws.sample_stats.attrs``,
``draws.observed_data["onset_time"]["onset"].values``), so those functions take either.
:mod:`drumroll.reporting.posterior_file` writes it as ArviZ writes an InferenceData, and
:meth:`Draws.to_inference_data` makes the InferenceData itself (what
:attr:`drumroll.pipeline.Result.idatas` gives).
"""

from __future__ import annotations

import datetime
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    import arviz as az

#: The groups whose variables have ``chain`` and ``draw`` dimensions (thinned together).
SAMPLE_GROUPS = ("posterior", "posterior_predictive", "log_likelihood", "sample_stats")


class Variable:
    """One variable (or coordinate) of a group: its values, dimension names, attributes and
    the coordinates of its dimensions (as an xarray DataArray has them)."""

    __slots__ = ("attrs", "coords", "dims", "values")

    def __init__(self, values: NDArray, dims: tuple[str, ...],
                 coords: Mapping[str, NDArray] | None = None,
                 attrs: dict[str, Any] | None = None) -> None:
        self.values = values
        self.dims = tuple(dims)
        self.coords = {d: np.asarray(c) for d, c in (coords or {}).items() if d in self.dims}
        self.attrs = {} if attrs is None else attrs

    @property
    def shape(self) -> tuple[int, ...]:
        return self.values.shape

    @property
    def ndim(self) -> int:
        return self.values.ndim

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray:
        return np.asarray(self.values, dtype=dtype)

    def __getitem__(self, coord: str) -> Variable:
        """A coordinate of this variable, e.g. ``variable["onset"]``."""
        return Variable(self.coords[coord], (coord,), self.coords)


class Group(Mapping[str, Variable]):
    """One group (``posterior``, ``observed_data``, …): variables by name, the coordinates of
    its dimensions and its attributes. Iterating or ``in`` see the variables and the
    coordinates, as for an xarray Dataset; :attr:`data_vars` the variables alone."""

    def __init__(self, variables: dict[str, tuple[tuple[str, ...], NDArray]],
                 coords: Mapping[str, NDArray], attrs: dict[str, Any] | None = None) -> None:
        dims = dict.fromkeys(d for d_, _ in variables.values() for d in d_)
        #: Coordinate values of every dimension of the group (ArviZ gives each one).
        self.coords = {d: np.asarray(coords[d]) if d in coords
                       else np.arange(_size(variables, d)) for d in dims}
        self.data_vars = {name: Variable(np.asarray(values), d, self.coords)
                          for name, (d, values) in variables.items()}
        self.attrs = {} if attrs is None else attrs

    @property
    def sizes(self) -> dict[str, int]:
        """Dimension name → length."""
        return {d: len(c) for d, c in self.coords.items()}

    def __getitem__(self, name: str) -> Variable:
        if name in self.data_vars:
            return self.data_vars[name]
        return Variable(self.coords[name], (name,), self.coords)

    def __iter__(self) -> Iterator[str]:
        yield from self.data_vars
        yield from self.coords

    def __len__(self) -> int:
        return len(self.data_vars) + len(self.coords)

    def thinned(self, keep: NDArray) -> Group:
        """The group with the draws at indices ``keep`` (coordinates and attributes kept)."""
        variables = {name: (v.dims, v.values[:, keep] if v.dims[:2] == ("chain", "draw")
                            else v.values) for name, v in self.data_vars.items()}
        group = Group(variables, {**self.coords, "draw": self.coords["draw"][keep]},
                      dict(self.attrs))
        for name, variable in self.data_vars.items():
            group.data_vars[name].attrs = dict(variable.attrs)
        return group


def _size(variables: dict[str, tuple[tuple[str, ...], NDArray]], dim: str) -> int:
    for dims, values in variables.values():
        if dim in dims:
            return np.shape(values)[dims.index(dim)]
    raise KeyError(dim)


class Draws:
    """A fit's groups (see the module docstring); ``draws.<group>`` is a :class:`Group`.

    Parameters
    ----------
    groups
        Group name → :class:`Group`, in ArviZ's order.
    attrs
        The fit's own attributes (InferenceData's ``attrs``: model, noise model, version).
    """

    def __init__(self, groups: dict[str, Group], attrs: dict[str, Any] | None = None) -> None:
        self._groups = groups
        self.attrs = {} if attrs is None else attrs

    def groups(self) -> list[str]:
        """The group names, as :meth:`arviz.InferenceData.groups`."""
        return list(self._groups)

    def __getattr__(self, name: str) -> Group:
        if name.startswith("_"):
            raise AttributeError(name)
        try:
            return self._groups[name]
        except KeyError:
            raise AttributeError(f"no group {name!r}") from None

    def __getstate__(self) -> dict[str, Any]:
        return {"_groups": self._groups, "attrs": self.attrs}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)

    @classmethod
    def from_dict(cls, groups: dict[str, dict[str, NDArray]], coords: dict[str, NDArray],
                  dims: dict[str, list[str]], attrs: dict[str, Any],
                  data_attrs: tuple[str, ...] = ("observed_data", "constant_data")) -> Draws:
        """Groups from arrays, as ``arviz.from_dict`` makes them: variables of the sample
        groups have dimensions ``chain``, ``draw`` and then those named in ``dims`` (or
        ``<name>_dim_<i>``), those of ``observed_data`` and ``constant_data`` only the
        latter; every group is stamped with its creation time and ArviZ's version, and the
        data groups also carry ``attrs``."""
        stamp = {"created_at": datetime.datetime.now(datetime.UTC).isoformat(),
                 "arviz_version": arviz_version()}
        out = {}
        for group, variables in groups.items():
            sampled = group not in data_attrs
            named = {}
            for name, values in variables.items():
                values = np.asarray(values)
                lead = ("chain", "draw") if sampled else ()
                rest = values.ndim - len(lead)
                extra = list(dims.get(name, []))[:rest]
                extra += [f"{name}_dim_{i}" for i in range(len(extra), rest)]
                named[name] = ((*lead, *extra), values)
            group_attrs = {**stamp, **(attrs if not sampled else {})}
            out[group] = Group(named, coords, group_attrs)
        return cls(out, dict(attrs))

    def thinned(self, keep: NDArray) -> Draws:
        """The fit with only the draws at indices ``keep`` in the sample groups (the other
        groups and every attribute as they are)."""
        return Draws({name: group.thinned(keep) if name in SAMPLE_GROUPS else group
                      for name, group in self._groups.items()}, dict(self.attrs))

    def to_inference_data(self) -> az.InferenceData:
        """The same groups as an :class:`arviz.InferenceData` (imports ArviZ)."""
        import arviz as az
        import xarray as xr

        datasets = {}
        for name, group in self._groups.items():
            datasets[name] = xr.Dataset(
                {key: xr.Variable(v.dims, v.values, dict(v.attrs))
                 for key, v in group.data_vars.items()},
                coords=group.coords, attrs=dict(group.attrs))
        idata = az.InferenceData(**datasets)
        idata.attrs.update(self.attrs)
        return idata


def arviz_version() -> str:
    """The installed ArviZ's version, read from its metadata (ArviZ is not imported)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("arviz")
    except PackageNotFoundError:
        return "unknown"
