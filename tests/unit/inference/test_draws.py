"""A fit's draws without ArviZ (:mod:`drumroll.inference.draws`) against ArviZ itself.

* :meth:`Draws.from_dict` makes the groups, dimensions, coordinates and attributes that
  ``arviz.from_dict`` makes from the same arrays, and :meth:`Draws.to_inference_data` gives
  that InferenceData back;
* :meth:`Draws.thinned` keeps what ``InferenceData.isel(draw=…)`` keeps (the original draw
  indices as coordinates);
* ``posterior.nc`` written from draws and from their InferenceData is the same file;
* the summaries read both alike, and a pickled copy (how draws reach the figure workers) is
  the same.
"""

from __future__ import annotations

import pickle

import arviz as az
import numpy as np
import pytest

from drumroll.inference.draws import Draws
from drumroll.inference.summary import onset_residuals, parameter_summary
from drumroll.reporting.posterior_file import load_posteriors, save_posteriors

BOUNCES = np.array([0, 1, 2, 4, 5])  # bounce 3 unheard


@pytest.fixture(scope="module")
def arrays():
    rng = np.random.default_rng(2)
    chains, draws, onsets = 6, 40, BOUNCES.size
    return {
        "groups": {
            "posterior": {"alpha": rng.normal(0.9, 0.01, (chains, draws)),
                          "t_b": rng.normal(0.25, 0.001, (chains, draws))},
            "posterior_predictive": {
                "onset_time": rng.normal(1.0, 0.1, (chains, draws, onsets)),
                "flight_time_model": rng.normal(0.2, 0.01, (chains, draws, 5))},
            "log_likelihood": {"onset_time": rng.normal(-1.0, 0.3, (chains, draws, onsets))},
            "sample_stats": {"lp": rng.normal(size=(chains, draws))},
            "prior": {"alpha": rng.uniform(0.5, 1.0, (1, 100))},
            "observed_data": {"onset_time": np.sort(rng.uniform(0, 2, onsets))},
            "constant_data": {"onset_sigma_s": np.full(onsets, 1e-4)},
        },
        "coords": {"onset": BOUNCES, "flight": np.arange(1, 6)},
        "dims": {"onset_time": ["onset"], "flight_time_model": ["flight"],
                 "onset_sigma_s": ["onset"]},
        "attrs": {"model": "powerlaw", "noise": "gaussian", "drumroll_version": "x"},
    }


def _from_arviz(arrays) -> az.InferenceData:
    return az.from_dict(**arrays["groups"], coords=arrays["coords"], dims=arrays["dims"],
                        attrs=arrays["attrs"])


def _assert_same(ours: az.InferenceData, theirs: az.InferenceData) -> None:
    assert ours.groups() == theirs.groups()
    assert dict(ours.attrs) == dict(theirs.attrs)
    for group in theirs.groups():
        a, b = getattr(ours, group), getattr(theirs, group)
        assert a.drop_attrs(deep=False).identical(b.drop_attrs(deep=False)), group
        stamp = ("created_at",)
        assert {k: v for k, v in a.attrs.items() if k not in stamp} == \
            {k: v for k, v in b.attrs.items() if k not in stamp}, group


def test_groups_are_arviz_s(arrays):
    draws = Draws.from_dict(**arrays)
    _assert_same(draws.to_inference_data(), _from_arviz(arrays))
    observed = draws.observed_data["onset_time"]
    np.testing.assert_array_equal(observed["onset"].values, BOUNCES)
    assert "onset" in draws.log_likelihood["onset_time"].coords
    assert draws.posterior.sizes == {"chain": 6, "draw": 40}
    assert "alpha" in draws.posterior and "chain" in draws.posterior
    assert list(draws.posterior.data_vars) == ["alpha", "t_b"]
    np.testing.assert_array_equal(np.asarray(draws.posterior["alpha"]),
                                  arrays["groups"]["posterior"]["alpha"])


def test_thinning_keeps_what_isel_keeps(arrays):
    keep = np.arange(3, 40, 4)
    ours = Draws.from_dict(**arrays).thinned(keep).to_inference_data()
    theirs = _from_arviz(arrays).isel(draw=keep, groups=["posterior", "posterior_predictive",
                                                         "log_likelihood", "sample_stats"])
    _assert_same(ours, theirs)


def test_posterior_file_from_draws_equals_that_from_inference_data(arrays, tmp_path):
    draws = {"powerlaw": Draws.from_dict(**arrays),
             "other": Draws.from_dict(**{**arrays, "attrs": {"model": "other"}})}
    draws["powerlaw"].posterior["alpha"].attrs["r_hat"] = 1.001
    save_posteriors(draws, "powerlaw", tmp_path / "a.nc")
    save_posteriors({m: d.to_inference_data() for m, d in draws.items()}, "powerlaw",
                    tmp_path / "b.nc")
    a, b = load_posteriors(tmp_path / "a.nc"), load_posteriors(tmp_path / "b.nc")
    assert list(a) == list(b) == ["powerlaw", "other"]
    for model in a:
        _assert_same(a[model], b[model])
    assert a["powerlaw"].posterior["alpha"].attrs["r_hat"] == 1.001


def test_summaries_read_draws_and_inference_data_alike(arrays):
    draws = Draws.from_dict(**arrays)
    idata = draws.to_inference_data()
    assert parameter_summary(draws) == parameter_summary(idata)
    assert onset_residuals(draws) == onset_residuals(idata)
    copy = pickle.loads(pickle.dumps(draws))
    assert copy.groups() == draws.groups() and copy.attrs == draws.attrs
    np.testing.assert_array_equal(copy.posterior["t_b"].values, draws.posterior["t_b"].values)


def _h5netcdf_file(path, groups, attrs):
    """The same groups written through h5netcdf, as posterior.nc was written before."""
    import h5netcdf

    from drumroll.reporting.posterior_file import _attribute, _variable_data

    with h5netcdf.File(path, "w") as handle:
        handle.attrs.update({key: _attribute(value) for key, value in attrs.items()})
        for name, dataset in groups.items():
            group = handle.create_group(name)
            group.dimensions = dict(dataset.sizes)
            for key in [*dataset.coords, *dataset.data_vars]:
                variable = dataset[key]
                data, dtype = _variable_data(np.asarray(variable.values))
                written = group.create_variable(key, variable.dims, dtype=dtype, data=data)
                for attr, value in variable.attrs.items():
                    written.attrs[attr] = _attribute(value)
            for attr, value in dataset.attrs.items():
                group.attrs[attr] = _attribute(value)


def _layout(path) -> dict:
    """Every group, variable and attribute of an HDF5 file (references by name)."""
    import h5py

    out = {}

    def visit(name, obj):
        attrs = {}
        for key in obj.attrs:
            if key == "_NCProperties":
                continue
            value = obj.attrs[key]
            if key == "DIMENSION_LIST":
                value = [[obj.file[r].name for r in refs] for refs in value]
            elif key == "REFERENCE_LIST":
                value = sorted((obj.file[r].name, int(i)) for r, i in value)
            else:
                value = (np.asarray(value).dtype.str, np.asarray(value).tolist())
            attrs[key] = value
        data = None
        if isinstance(obj, h5py.Dataset):
            data = (obj.dtype.str, obj.shape, obj.chunks, np.asarray(obj[()]).tolist())
        out[name] = (attrs, data)

    with h5py.File(path, "r") as handle:
        handle.visititems(visit)
        out["/"] = ({k: str(handle.attrs[k]) for k in handle.attrs if k != "_NCProperties"},
                    list(handle.attrs)[-1])
    return out


def test_posterior_file_is_laid_out_as_h5netcdf_lays_it_out(arrays, tmp_path):
    """posterior.nc is written through h5py directly (h5netcdf looked each dimension up some
    thirty times per variable): every group, dimension scale, variable, attribute and
    netCDF-4 marker as h5netcdf writes them."""
    from drumroll.reporting.posterior_file import write_groups

    draws = Draws.from_dict(**arrays)
    draws.posterior["alpha"].attrs.update(r_hat=1.001, ess_bulk=1500.0)
    draws.sample_stats.attrs.update(tau_parameters=["alpha", "t_b"], converged=True)
    groups = {name: getattr(draws, name) for name in draws.groups()}
    attrs = {"models": "powerlaw", "main_model": "powerlaw"}
    write_groups(tmp_path / "ours.nc", groups, attrs)
    _h5netcdf_file(tmp_path / "theirs.nc", groups, attrs)
    assert _layout(tmp_path / "ours.nc") == _layout(tmp_path / "theirs.nc")
