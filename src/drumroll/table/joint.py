"""Joint fits: parameters shared across runs (``share = ["alpha"]``) as one posterior.

Each run keeps its own :class:`~drumroll.inference.posterior.LogPosterior` (its main model,
its onsets, its geometry priors). :class:`JointPosterior` stacks them: one column per shared
parameter, then each run's other columns, and

    log p(θ_shared, θ_1 … θ_n | data) = Σ_i log p_i(θ_shared, θ_i | data_i)
                                         − (n − 1) log π(θ_shared)

(each run's posterior holds the shared prior once; the joint must hold it once). The joint
vector lives in the runs' own :class:`~drumroll.inference.space.SamplerCoordinates` (the
pendulum's (d, h) ridge straightened, scale parameters as logarithms), so
:func:`~drumroll.inference.sampling.run_emcee` samples it as well as a single run; its
column names carry the run's label, so ``run_emcee`` adds no transform of its own.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drumroll.quantities import PARAMETERS
from drumroll.table.execute import (
    CACHE_SCHEMA,
    Estimate,
    RunRow,
    TableResult,
    read_json,
    run_key,
    write_cached,
)
from drumroll.table.runs import RunsFile, validate_estimation

#: Sampler coordinates that are logarithms of the parameter (see SamplerCoordinates).
_LOG_COORDINATES = ("jitter", "t_b")


@dataclass(frozen=True)
class JointSpace:
    """The joint parameter vector: what the samplers use of a ParameterSpace."""

    names: tuple[str, ...]
    posterior: JointPosterior = field(repr=False, compare=False)
    model: str = "joint"

    @property
    def ndim(self) -> int:
        return len(self.names)

    def sampler_bounds(self) -> NDArray:
        """The box the priors allow the joint vector, ``(ndim, 2)``: each run's
        :meth:`SamplerCoordinates.bounds`, the shared columns the first run's (their priors
        are the same in every run)."""
        post = self.posterior
        box = np.empty((self.ndim, 2))
        for i, coords in enumerate(post.coordinates):
            part = coords.bounds()
            if i == 0:
                box[:len(post.shared)] = part[post.shared_columns[0]]
            box[post.own_slices[i]] = part[post.own_columns[i]]
        return box

    def sample_prior(self, rng: np.random.Generator, size: int) -> NDArray:
        """``size`` joint prior draws (in the joint sampler coordinates)."""
        post = self.posterior
        out = np.empty((size, self.ndim))
        for i, (part, coords) in enumerate(zip(post.parts, post.coordinates, strict=True)):
            z = coords.to_sampler(part.space.sample_prior(rng, size))
            if i == 0:
                out[:, :len(post.shared)] = z[:, post.shared_columns[0]]
            out[:, post.own_slices[i]] = z[:, post.own_columns[i]]
        return out


class JointPosterior:
    """Sum of the runs' log posteriors with shared columns (see the module docstring).

    Parameters
    ----------
    parts
        Each run's LogPosterior (same model family; the shared parameters sampled in all).
    labels
        The runs' labels (column names of the joint vector).
    shared
        Internal names of the shared parameters (e.g. ``("alpha",)``).
    coordinates
        Each run's sampler coordinates (default: without the geometry of its effects that
        may be absent, :func:`~drumroll.inference.sampling.sampler_coordinates` gives it).
    """

    def __init__(self, parts: list[Any], labels: list[str], shared: tuple[str, ...],
                 coordinates: list[Any] | None = None) -> None:
        from drumroll.inference.coordinates import SamplerCoordinates

        self.parts, self.labels, self.shared = parts, labels, shared
        self.shared_columns = [[p.space.names.index(s) for s in shared] for p in parts]
        self.coordinates = ([_unsheared(c, cols) for c, cols in
                             zip(coordinates, self.shared_columns, strict=True)] if coordinates
                            else [SamplerCoordinates(p.space, p.data) for p in parts])
        self.own_columns = [[j for j, n in enumerate(p.space.names) if n not in shared]
                            for p in parts]
        names = [f"shared:{s}" for s in shared]
        self.own_slices = []
        for label, part, own in zip(labels, parts, self.own_columns, strict=True):
            self.own_slices.append(slice(len(names), len(names) + len(own)))
            names += [f"{label}:{part.space.names[j]}" for j in own]
        self.shared_priors = [parts[0].space.priors[s] for s in shared]
        self.space = JointSpace(tuple(names), self)

    def split(self, z: NDArray) -> list[NDArray]:
        """Each run's sampler-coordinate vector from joint rows ``z`` (batch, ndim)."""
        out = []
        for part, shared, own, cut in zip(self.parts, self.shared_columns, self.own_columns,
                                          self.own_slices, strict=True):
            zi = np.empty((z.shape[0], part.space.ndim))
            zi[:, shared] = z[:, :len(self.shared)]
            zi[:, own] = z[:, cut]
            out.append(zi)
        return out

    def run_parameters(self, z: NDArray) -> list[NDArray]:
        """Each run's parameter rows x (its own ParameterSpace columns) from joint rows z."""
        return [c.to_parameters(zi)[0] for c, zi in zip(self.coordinates, self.split(z),
                                                        strict=True)]

    def __call__(self, z: NDArray) -> NDArray | float:
        z = np.asarray(z, float)
        single = z.ndim == 1
        z = np.atleast_2d(z)
        total = np.zeros(z.shape[0])
        for part, coords, zi in zip(self.parts, self.coordinates, self.split(z), strict=True):
            x, log_det = coords.to_parameters(zi)
            total += np.asarray(part(x)) + log_det
        n = len(self.parts)
        with np.errstate(all="ignore"):
            for j, (name, prior) in enumerate(zip(self.shared, self.shared_priors,
                                                  strict=True)):
                zj = z[:, j]
                xj = np.exp(zj) if name in _LOG_COORDINATES else zj
                correction = prior.logpdf(xj) + (zj if name in _LOG_COORDINATES else 0.0)
                total -= (n - 1) * correction
        total = np.where(np.isfinite(total), total, -np.inf)
        return float(total[0]) if single else total


def _unsheared(coordinates: Any, shared: list[int]) -> Any:
    """``coordinates`` whose atoms' ridges leave the ``shared`` columns alone: a shared
    parameter is one column of the joint vector, which each run's ridge would move by its own
    amount, so that the runs would no longer share its value."""
    atoms = []
    for geometry in coordinates.atoms:
        if geometry.ridge is not None:
            ridge = np.array(geometry.ridge)
            ridge[shared] = 0.0
            geometry = replace(geometry, ridge=tuple(float(v) for v in ridge))
        atoms.append(geometry)
    return replace(coordinates, atoms=tuple(atoms))


def _value_error(draws: NDArray) -> dict[str, float]:
    return {"value": float(np.mean(draws)), "err": float(np.std(draws, ddof=1))}


def consistency(separate: dict[str, dict[str, float]]) -> str:
    """Whether separate estimates agree: χ² about their inverse-variance weighted mean."""
    from scipy import stats

    values = np.array([v["value"] for v in separate.values()])
    errors = np.array([v["err"] for v in separate.values()])
    weights = errors**-2.0
    mean = float(np.sum(weights * values) / np.sum(weights))
    chi2 = float(np.sum(weights * (values - mean) ** 2))
    dof = values.size - 1
    p = float(stats.chi2.sf(chi2, dof))
    verdict = ("consistent with one common value" if p > 0.01 else
               "NOT consistent with one common value: a shared fit is not justified")
    return f"χ² = {chi2:.3g} for {dof} degree(s) of freedom, p = {p:.2g}: {verdict}"


def joint_key(keys: list[str], share: tuple[str, ...]) -> str:
    """Cache key of a joint fit: its runs' keys and the shared parameters."""
    text = json.dumps({"runs": keys, "share": list(share), "schema": CACHE_SCHEMA})
    return "joint-" + hashlib.sha256(text.encode()).hexdigest()[:40]


def fit_joint(runs: RunsFile, rows: list[RunRow]) -> dict[str, Any]:
    """Sample the joint posterior of ``runs`` (onsets from their ``rows``) and summarise it.

    Returns
    -------
    dict
        ``shared`` (key → value/err/r_hat/ess_bulk, user units), ``rows`` (label →
        ``fitted_t_b`` and the shared values under the joint posterior), ``separate`` (key →
        label → the run's own fit), ``consistency`` (key → a χ² sentence), and the sampler's
        ``converged``, ``n_steps``, ``tau_max``.
    """
    from drumroll.inference.convergence import diagnose
    from drumroll.inference.inference_data import parameter_draws
    from drumroll.inference.likelihood import OnsetData
    from drumroll.inference.missed_impacts import shifted
    from drumroll.inference.posterior import LogPosterior
    from drumroll.inference.sampling import run_emcee, sampler_coordinates
    from drumroll.inference.settings import estimate_settings

    parts, settings = [], None
    for run, row in zip(runs.runs, rows, strict=True):
        config = validate_estimation(run)
        own = estimate_settings(config)
        settings = settings or own
        onsets = row.summary.onsets  # the onsets the run's own fit used, as it numbered them
        data = shifted(OnsetData.from_arrays([o.time_s for o in onsets],
                                             [o.sigma_s for o in onsets],
                                             [o.bounce for o in onsets]), onsets[0].bounce)
        parts.append(LogPosterior.build(config, config.model, data, own.noise, own.nu))
    shared = tuple(PARAMETERS[key].name for key in runs.share)
    # Each run's own coordinates, the geometry of its contact time's atom included: the joint
    # run sees the runs' columns only as sampler coordinates, not as effects that may be
    # absent (without it, two contact times on 3 ms plateaus took 19,566 steps to mix).
    posterior = JointPosterior(parts, [r.label for r in runs.runs], shared,
                               [sampler_coordinates(p, settings.sampler) for p in parts])
    sampler = replace(settings.sampler, walkers=max(settings.sampler.walkers,
                                                    2 * posterior.space.ndim + 2))
    chain = run_emcee(posterior, sampler)
    walkers, draws, ndim = chain.samples.shape
    per_run = posterior.run_parameters(chain.samples.reshape(-1, ndim))
    rng = np.random.default_rng(sampler.seed)
    out_shared, out_rows = {}, {}
    for key, name in zip(runs.share, shared, strict=True):
        column = parts[0].space.names.index(name)
        draws_si = per_run[0][:, column].reshape(walkers, draws)
        values = draws_si / PARAMETERS[key].to_si
        # the R-hat and ESS the sampler stopped on (walkers in groups as chains), not
        # ArviZ's with each walker a chain, which stays above 1.01 for a converged run
        stats = diagnose({key: values})[key]
        out_shared[key] = {**_value_error(values), "r_hat": stats["r_hat"],
                           "ess_bulk": stats["ess_bulk"]}
    for run, part, x in zip(runs.runs, parts, per_run, strict=True):
        variables, _, _ = parameter_draws(part, x.reshape(walkers, draws, -1), rng)
        entry = {"fitted_t_b": _value_error(variables["t_b"].ravel())}
        entry.update({key: out_shared[key] for key in runs.share})
        out_rows[run.label] = entry
    separate = {key: {r.label: (Estimate.of(row.summary.parameters[key]).to_json()
                                if key in row.summary.parameters else None)
                      for r, row in zip(runs.runs, rows, strict=True)}
                for key in runs.share}
    finite = chain.tau[np.isfinite(chain.tau)]
    return {"schema": CACHE_SCHEMA, "shared": out_shared, "rows": out_rows,
            "separate": separate,
            "consistency": {key: consistency(v) for key, v in separate.items()},
            "converged": bool(chain.converged), "n_steps": int(chain.n_steps),
            "tau_max": float(finite.max()) if finite.size else math.nan}


def joint_table(runs: RunsFile, result: TableResult, *, cache_dir: Path | None = None,
                use_cache: bool = True) -> dict[str, Any]:
    """The joint fit of ``result``'s runs, from the cache or sampled (and then cached)."""
    folder = cache_dir if cache_dir is not None else runs.cache_dir
    key = joint_key([run_key(run) for run in runs.runs], runs.share)
    if use_cache:
        cached = read_json(folder / f"{key}.json")
        if cached is not None:
            return cached
    joint = fit_joint(runs, result.rows)
    if use_cache:
        write_cached(folder, key, joint)
    return joint
