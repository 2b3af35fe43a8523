"""``posterior.nc``: every model's InferenceData in one netCDF-4 file, and reading it back.

The main model is in ArviZ's standard groups (``az.from_netcdf`` opens it directly) and every
compared model in groups suffixed with its name, e.g. ``posterior_small_angle``;
:func:`load_posteriors` splits them back into one InferenceData per model.

The file is written in one pass through h5py, in netCDF-4's layout as h5netcdf (the library
xarray itself writes netCDF-4 with) lays it out: each dimension a dimension scale (its
coordinate variable, or an empty stand-in), ``_Netcdf4Dimid`` numbering the dimensions across
the file, ``_Netcdf4Coordinates`` listing each variable's, scalar attributes as one-element
arrays. ArviZ's ``to_netcdf`` reopens the file for each of its ~20 groups, and each reopening
walks every group written before; h5netcdf itself looks each dimension up some thirty times
per variable, three quarters of the writing (0.25 of 0.33 CPU-s for table2_h80's file). It is
built in memory and written to disk by Python in one piece: HDF5 writing into the file itself
fails badly on a full disk (errors from its destructors, then a segmentation fault), a plain
write fails as an ``OSError`` the caller can report.
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
    variable-length strings, a number as an array of one, as h5netcdf stores it)."""
    import h5py

    if isinstance(value, bool | np.bool_):
        value = int(value)
    if isinstance(value, list | tuple | np.ndarray):
        array = np.asarray(value)
        if array.dtype.kind in "OUS":
            return np.asarray(array.astype(str), dtype=h5py.string_dtype())
        return array.astype(np.int8) if array.dtype.kind == "b" else array
    if np.isscalar(value) and not isinstance(value, str | bytes):
        return np.atleast_1d(value)
    return value


def _variable_data(values: np.ndarray) -> tuple[np.ndarray, Any]:
    """Data and dtype of a variable: text as variable-length strings, booleans as bytes."""
    if values.dtype.kind in "OUS":
        import h5py

        return np.asarray(values.astype(str), dtype=object), h5py.string_dtype()
    if values.dtype.kind == "b":
        return values.astype(np.int8), np.int8
    return values, values.dtype


#: netCDF-C's name of a dimension without a coordinate variable (as h5netcdf writes it).
_NOT_A_VARIABLE = b"This is a netCDF dimension but not a netCDF variable."


def write_groups(path: str | os.PathLike[str], groups: dict[str, Any],
                 attrs: dict[str, Any]) -> None:
    """Write groups as the netCDF-4 groups of one new file (ArviZ's layout, the file h5netcdf
    would write: see the module docstring).

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
    import h5py

    from drumroll import __version__

    properties = (f"version=2,drumroll={__version__},hdf5={h5py.version.hdf5_version},"
                  f"h5py={h5py.__version__}")
    dim_id = 0
    image = io.BytesIO()
    # Creation order tracked, as netCDF-C requires.
    with h5py.File(image, "w", track_order=True) as handle:
        for key, value in attrs.items():
            handle.attrs[key] = _attribute(value)
        for name, dataset in groups.items():
            group = handle.create_group(name, track_order=True)
            scales = {}
            for dim, size in dataset.sizes.items():  # the coordinates: the dimension scales
                if dim in dataset.coords:
                    data, dtype = _variable_data(np.asarray(_variable(dataset, dim).values))
                    scale = group.create_dataset(dim, data=data, dtype=dtype, track_order=True)
                    label = dim
                else:
                    scale = group.create_dataset(dim, shape=(size,), dtype=">f4",
                                                 track_order=True)
                    label = _NOT_A_VARIABLE + f"{size:10}".encode("ascii")
                scale.attrs["_Netcdf4Dimid"] = np.array(dim_id, dtype=np.int32)
                scale.make_scale(label)
                if dim in dataset.coords:
                    scale.attrs["_Netcdf4Coordinates"] = np.array([dim_id], dtype=np.int32)
                scales[dim] = (scale, dim_id)
                dim_id += 1
            for key in dataset.coords:
                if key not in scales:  # a coordinate that is no dimension's
                    _write_variable(group, key, _variable(dataset, key), scales)
            for key in dataset.data_vars:
                _write_variable(group, key, _variable(dataset, key), scales)
            for attr, value in dataset.attrs.items():
                group.attrs[attr] = _attribute(value)
        handle.attrs["_NCProperties"] = np.array(  # last, where h5netcdf writes it
            properties, dtype=h5py.string_dtype(encoding="ascii", length=len(properties)))
    with open(path, "wb") as file:
        file.write(image.getbuffer())


def _variable(dataset: Any, key: str) -> Any:
    """Variable ``key`` of a group: values, dims and attrs (an xarray DataArray's Variable)."""
    variable = dataset[key]
    return getattr(variable, "variable", variable)


def _write_variable(group: Any, key: str, variable: Any, scales: dict[str, tuple]) -> None:
    """One variable, its dimension scales attached, its dimensions' ids and attributes."""
    data, dtype = _variable_data(np.asarray(variable.values))
    written = group.create_dataset(key, data=data, dtype=dtype, track_order=True)
    ids = np.array([scales[dim][1] for dim in variable.dims], dtype=np.int32)
    for axis, dim in enumerate(variable.dims):
        written.dims[axis].attach_scale(scales[dim][0])
    if ids.size:
        written.attrs["_Netcdf4Coordinates"] = ids
        written.attrs["_Netcdf4Dimid"] = ids[0]
    for attr, value in variable.attrs.items():
        written.attrs[attr] = _attribute(value)


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
