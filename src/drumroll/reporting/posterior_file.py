"""``posterior.nc``: every model's InferenceData in one netCDF-4 file, and reading it back.

The main model is in ArviZ's standard groups (``az.from_netcdf`` opens it directly) and every
compared model in groups suffixed with its name, e.g. ``posterior_small_angle``;
:func:`load_posteriors` splits them back into one InferenceData per model.

The file is written in one pass through h5netcdf (the library xarray itself writes netCDF-4
with): ArviZ's ``to_netcdf`` reopens the file for each of its ~20 groups, and each reopening
walks every group written before, three times the work of writing the numbers. It is built
in memory and written to disk by Python in one piece: HDF5 writing into the file itself
fails badly on a full disk (errors from its destructors, then a segmentation fault), a
plain write fails as an ``OSError`` the caller can report.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import arviz as az

    from drumroll.inference.draws import Draws


def model_suffix(model: str) -> str:
    """The suffix of ``model``'s groups (``small-angle`` → ``small_angle``)."""
    return model.replace("-", "_")


def _attribute(value: Any) -> Any:
    """An attribute as netCDF stores it (booleans as 0/1, sequences as arrays, text as
    variable-length strings)."""
    import h5py

    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, list | tuple | np.ndarray):
        array = np.asarray(value)
        if array.dtype.kind in "OUS":
            return np.asarray(array.astype(str), dtype=h5py.string_dtype())
        return array.astype(np.int8) if array.dtype.kind == "b" else array
    return value


def _variable_data(values: np.ndarray) -> tuple[np.ndarray, Any]:
    """Data and dtype of a variable: text as variable-length strings, booleans as bytes."""
    if values.dtype.kind in "OUS":
        return np.asarray(values.astype(str), dtype=object), str
    if values.dtype.kind == "b":
        return values.astype(np.int8), np.int8
    return values, values.dtype


def write_groups(path: str | os.PathLike[str], groups: dict[str, Any],
                 attrs: dict[str, Any]) -> None:
    """Write groups as the netCDF-4 groups of one new file (ArviZ's layout).

    Parameters
    ----------
    path
        The file to create (it is truncated if it exists: callers write into a staging
        folder).
    groups
        Group name → :class:`xarray.Dataset` or :class:`~drumroll.inference.draws.Group`.
    attrs
        The file's own attributes.

    Raises
    ------
    OSError
        If the file cannot be written (a full disk among others: see
        :func:`drumroll.fileio.no_space`).
    """
    import h5netcdf

    image = io.BytesIO()
    with h5netcdf.File(image, "w") as handle:
        handle.attrs.update({key: _attribute(value) for key, value in attrs.items()})
        for name, dataset in groups.items():
            group = handle.create_group(name)
            group.dimensions = dict(dataset.sizes)
            # Coordinates first, so each dimension's scale exists before the data use it.
            for key in [*dataset.coords, *dataset.data_vars]:
                variable = dataset[key]
                variable = getattr(variable, "variable", variable)  # an xarray DataArray's
                data, dtype = _variable_data(np.asarray(variable.values))
                written = group.create_variable(key, variable.dims, dtype=dtype, data=data)
                for attr, value in variable.attrs.items():
                    written.attrs[attr] = _attribute(value)
            for attr, value in dataset.attrs.items():
                group.attrs[attr] = _attribute(value)
    with open(path, "wb") as file:
        file.write(image.getbuffer())


def save_posteriors(idatas: dict[str, Draws | az.InferenceData], main: str,
                    path: str | os.PathLike[str]) -> None:
    """All models' InferenceData (or :class:`~drumroll.inference.draws.Draws`, which hold
    the same groups) in one netCDF file (main model in the standard groups)."""
    groups = {}
    for model, idata in idatas.items():
        suffix = "" if model == main else f"_{model_suffix(model)}"
        groups.update({f"{group}{suffix}": getattr(idata, group) for group in idata.groups()})
    write_groups(Path(path), groups, {"models": ",".join(idatas), "main_model": main})


def load_posteriors(path: str | os.PathLike[str]) -> dict[str, az.InferenceData]:
    """Reopen ``posterior.nc``: model name → InferenceData (main model first).

    Example
    -------
    >>> fits = load_posteriors("roll-estimate/posterior.nc")  # doctest: +SKIP
    >>> az.summary(fits["pendulum"])                           # doctest: +SKIP
    """
    import arviz as az

    combined = az.from_netcdf(str(path))
    models = str(combined.attrs.get("models", combined.attrs.get("model", "model"))).split(",")
    main = str(combined.attrs.get("main_model", models[0]))
    out: dict[str, az.InferenceData] = {}
    for model in models:
        suffix = "" if model == main else f"_{model_suffix(model)}"
        groups = {}
        for group in combined.groups():
            base = group[: -len(suffix)] if suffix and group.endswith(suffix) else group
            if suffix and not group.endswith(suffix):
                continue
            if not suffix and any(group.endswith(f"_{model_suffix(m)}") for m in models
                                  if m != main):
                continue
            groups[base] = getattr(combined, group)
        idata = az.InferenceData(**groups)
        idata.attrs.update({"model": model})
        out[model] = idata
    return out
