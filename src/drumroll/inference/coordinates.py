"""The coordinates emcee moves in: an exact, better-conditioned bijection of the parameters."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from drumroll.distributions import OrZero
from drumroll.inference.likelihood import OnsetData
from drumroll.inference.space import SCATTER, ParameterSpace
from drumroll.physics.release import swing


@dataclass(frozen=True)
class AtomGeometry:
    """How the walkers move between "absent" and "present" for one effect that may be absent
    (see :class:`SamplerCoordinates`).

    Attributes
    ----------
    plateau
        The width in z of the stretch that stands for "absent".
    ridge
        b, per column of z: how far each other coordinate moves per unit of the effect's
        size along the posterior's ridge (0 in the atom's own column); None: nowhere.
    """

    plateau: float
    ridge: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if not self.plateau > 0.0:
            raise ValueError("the plateau must be wider than 0")


@dataclass(frozen=True)
class SamplerCoordinates:
    """Better-conditioned coordinates z for MCMC, an exact bijection of the parameters x.

    The moves emcee uses are affine invariant, so linear correlations cost nothing; what slows
    them is curvature and scale that changes across the posterior. Three maps remove the worst
    of it, each column depending only on columns mapped before it:

    * the scale parameters ``jitter``, ``t_b`` and the restitution's scatter → their
      logarithms (∂x/∂z = x); the scatter's posterior piles against s = 0 under a prior that
      allows none, where moves in s itself step below 0 and are refused (a scatter whose
      prior has an atom at 0 is mapped as the atoms below are, not through its logarithm).
      The ensemble walks with ``fold_scatter``, where the scatter is |z| instead: the density
      of z is the posterior's mirrored across 0, a bump about 0 where s piles against it,
      while in log s the walkers spread over several e-folds towards s = 0 (on the README's
      roll, the exact pendulum under a half-normal scatter, seeds 0–4: the scatter's
      autocorrelation time 76–114 steps in log s, 58–69 in |z|, α's 57–72 and 46–56, and
      half the steps to the ESS targets). The map is two-to-one, so integrals over z (the
      evidence, a screen's Laplace estimate) keep the logarithm;
    * ``height`` → q = ω_C/γ of the model's own linearised kinematics,
      q² = (ω0² + 2γ(θ_C − θ0)) / γ², with θ_C = asin(h / (L − d)) (pendulum) or
      h / (L − d) (small-angle). The data pin down t_B ≈ 2q, which in (d, h) is a curved ridge
      (physics.md) and in (d, q) nearly a straight line. Inverse:
      θ_C = θ0 + (γ²q² − ω0²)/(2γ), h = (L − d) sin θ_C (or (L − d) θ_C), with
      ∂h/∂q = (L − d) cos θ_C γ q (or (L − d) γ q);
    * ``t0`` (sampled under Student-t noise, when ``data`` is given) → its non-centred
      offset δ = (T0 − T̂0(θ)) / s(θ), where T̂0 = Σ w_k (t_k − τ_k(θ)) / Σ w_k is T0's
      weighted least-squares value given the other parameters, w_k = 1/(σ² + s_k²), and
      s = (Σ w_k)^(-1/2) its standard error (∂T0/∂δ = s). T0 otherwise follows every change
      of the flights and scales with the jitter (a funnel); δ is nearly independent of both,
      which halves the slowest autocorrelation time.

    * an effect that may be absent (:class:`~drumroll.distributions.OrZero`, the default
      contact time), whose coordinate u stands for the atom at 0 on [−w, 0), the prior's
      ``width`` w, and for the effect's size τ = u above 0. Two maps, each from
      ``atoms`` (one :class:`AtomGeometry` per atom column, set from the start by
      :func:`~drumroll.inference.sampling.atom_geometry`; by default none), let walkers move
      between "absent" and "present". The plateau is scaled to the slab's posterior width
      (u = z · w / plateau below 0, ∂u/∂z = w / plateau): walkers spread over a 3 ms
      plateau rarely step into a slab 10 µs wide, and the two mixed a thousand times too
      slowly. And the other coordinates follow the effect's size along the posterior's
      ridge, z_i + b_i τ (unit Jacobian): a contact time is taken up by the flights (α and
      t_B shrink as τ grows), so without it a walker leaving the plateau, where α sits at
      its best without contact, finds the slab's α several sds away. Neither changes the
      density of x: the posterior probability of "absent" is the same whatever they are.

    The density of z is p(x(z)) |det ∂x/∂z|; the Jacobian is triangular, so its log
    determinant is the sum of the log derivatives above. z points outside the image of the
    valid parameter set map to NaN (log posterior −inf), so the map is a bijection between the
    valid sets.
    """

    space: ParameterSpace
    data: OnsetData | None = None
    #: The geometry of each atom column (:attr:`atom_columns`, in order); empty: the prior's
    #: own width and no ridge.
    atoms: tuple[AtomGeometry, ...] = ()
    #: The restitution's scatter (under a prior without an atom) as the absolute value of its
    #: column, not through its logarithm: the coordinates the ensemble walks in
    #: (:func:`~drumroll.inference.sampling.run_emcee`); two-to-one, so not for integrals.
    fold_scatter: bool = False

    def __post_init__(self) -> None:
        names = self.space.names
        priors = getattr(self.space, "priors", {})  # a joint fit's space has none of its own
        scales = ("jitter", "t_b") if self.fold_scatter else ("jitter", "t_b", SCATTER)
        logs = tuple(names.index(n) for n in scales
                     if n in names and not isinstance(priors.get(n), OrZero))
        folded = tuple(names.index(n) for n in (SCATTER,) if self.fold_scatter
                       and n in names and not isinstance(priors.get(n), OrZero))
        height = (names.index("height") if "height" in names
                  and self.space.forward.needs_stick else None)
        t0 = names.index("t0") if "t0" in names and self.data is not None else None
        object.__setattr__(self, "_logs", logs)
        object.__setattr__(self, "_folded", folded)
        object.__setattr__(self, "_height", height)
        object.__setattr__(self, "_t0", t0)
        atoms = tuple(i for i, n in enumerate(names) if isinstance(priors.get(n), OrZero))
        geometry = self.atoms or tuple(AtomGeometry(priors[names[i]].width) for i in atoms)
        if len(geometry) != len(atoms):
            raise ValueError("one AtomGeometry per atom column")
        object.__setattr__(self, "_atoms", atoms)
        # u = stretch · z on the plateau (z < 0), per atom column.
        object.__setattr__(self, "_stretch", tuple(
            priors[names[i]].width / g.plateau for i, g in zip(atoms, geometry, strict=True)))
        ridges = [np.zeros(len(names)) if g.ridge is None else np.array(g.ridge, float)
                  for g in geometry]
        object.__setattr__(self, "_ridges", tuple(ridges))

    @property
    def atom_columns(self) -> tuple[int, ...]:
        """The columns of effects that may be absent (an atom at 0: see the class docstring)."""
        return self._atoms

    @property
    def folded_columns(self) -> tuple[int, ...]:
        """The columns whose parameter is |z| (the scatter, with ``fold_scatter``)."""
        return self._folded

    @property
    def t0_column(self) -> int | None:
        """The column of T0's non-centred offset δ, when T0 is sampled (else None)."""
        return self._t0

    def bounds(self) -> NDArray:
        """The box of z the priors allow, shape ``(ndim, 2)``: each column's prior support
        mapped as the column is (its logarithm for the scale parameters), 1e-9 of its width
        inside, unbounded for the columns whose map depends on others (q, T0's offset δ). The
        start's climb keeps inside it (:func:`~drumroll.inference.sampling.find_start`).
        A space whose columns are already sampler coordinates (a joint fit's,
        :class:`~drumroll.table.joint.JointSpace`) gives its own box."""
        own_box = getattr(self.space, "sampler_bounds", None)
        if own_box is not None:
            return own_box()
        box = np.array([self.space.priors[name].support for name in self.space.names], float)
        # An effect that may be absent (OrZero: u < 0 stands for the atom at 0) climbs on its
        # slab: below 0 the density is flat in u, so a climb there has no gradient to follow
        # and would stop wherever it started, while the atom's own density is the slab's
        # lower end, the likelihood being continuous there.
        for i in self._atoms:
            box[i, 0] = 0.0
        with np.errstate(divide="ignore"):
            for i in self._logs:
                box[i] = np.log(box[i])
        for i in (self._height, self._t0):
            if i is not None:
                box[i] = (-np.inf, np.inf)
        # A hair inside: a point on a bound in z can map back (exp of a log) a rounding error
        # outside the prior, where the density is −inf, and a walker started there has none.
        width = np.where(np.isfinite(box[:, 1] - box[:, 0]), box[:, 1] - box[:, 0],
                         np.maximum(np.abs(np.where(np.isfinite(box), box, 0.0)).max(axis=1), 1.0))
        return box + 1e-9 * width[:, None] * np.array([1.0, -1.0])

    def _gamma_arm_speed(self, x: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """γ, L − d, ω0 and θ0 per row (only the columns other than h are used; h is given
        a placeholder, since q, not h, is what the rows hold)."""
        space = self.space
        v = space.value
        theta0 = v(x, "release_angle") * np.ones(x.shape[0])
        _, (gamma, arm, _, omega0) = swing(
            space.config.stick.shape, v(x, "stick_length"), v(x, "stick_tip"),
            v(x, "stick_radius"), v(x, "pivot"), 0.0, v(x, "release_speed"), theta0,
            space.config.gravity)
        ones = np.ones(x.shape[0])
        return gamma * ones, arm * ones, omega0 * ones, theta0

    def _t0_centre(self, x: NDArray, impacts: NDArray) -> tuple[NDArray, NDArray]:
        """T̂0 and its standard error s per row, given the rows' impact times τ_0 … τ_K."""
        data = self.data
        jitter = self.space.value(x, "jitter")
        weight = 1.0 / (np.reshape(jitter, (-1, 1)) ** 2 + data.sigmas**2)
        sum_w = weight.sum(axis=1)
        residual = data.times - data.at_onsets(impacts)
        return (weight * residual).sum(axis=1) / sum_w, 1.0 / np.sqrt(sum_w)

    def to_sampler(self, x: NDArray, *, t0_centred: bool = False) -> NDArray:
        """z of each row of the parameters ``x`` (NaN where x is invalid).

        With ``t0_centred``, a sampled T0 is put at its best value given the rest (offset
        δ = 0) whatever ``x`` says, and the forward model, which only δ needs, is not run:
        the start search's prior draws (:func:`~drumroll.inference.sampling.find_start`),
        whose density is then evaluated anyway."""
        x = np.atleast_2d(np.asarray(x, float))
        z = x.copy()
        with np.errstate(all="ignore"):
            for i in self._logs:
                z[:, i] = np.log(x[:, i])
            if self._height is not None:
                gamma, arm, omega0, theta0 = self._gamma_arm_speed(x)
                theta_c = self.space.forward.contact_angle(x[:, self._height] / arm)
                z[:, self._height] = np.sqrt(omega0**2 + 2.0 * gamma * (theta_c - theta0)) / gamma
            if self._t0 is not None and not t0_centred:
                impacts, valid = self.space.impacts(x, self.data.n_flights)
                centre, scale = self._t0_centre(x, impacts)
                z[:, self._t0] = np.where(valid, (x[:, self._t0] - centre) / scale, np.nan)
            for i, stretch, ridge in zip(self._atoms, self._stretch, self._ridges, strict=True):
                z -= np.maximum(x[:, i], 0.0)[:, None] * ridge
                z[:, i] = np.where(x[:, i] < 0.0, x[:, i] / stretch, x[:, i])
        if self._t0 is not None and t0_centred:
            z[:, self._t0] = 0.0
        return z

    def to_parameters(self, z: NDArray) -> tuple[NDArray, NDArray]:
        """The parameters x of each row of ``z``, and log |det ∂x/∂z|."""
        x, log_det, _ = self.to_parameters_and_impacts(z)
        return x, log_det

    def to_parameters_and_impacts(self, z: NDArray
                                  ) -> tuple[NDArray, NDArray, tuple[NDArray, NDArray] | None]:
        """:meth:`to_parameters`, and the impact times with their validity
        (:meth:`ParameterSpace.impacts`) when the T0 map needed them (else None), so that the
        sampler's target does not run the forward model twice."""
        z = np.atleast_2d(np.asarray(z, float))
        log_det = np.zeros(z.shape[0])
        impacts = None
        with np.errstate(all="ignore"):
            for i, ridge in zip(self._atoms, self._ridges, strict=True):
                z = z + np.maximum(z[:, i], 0.0)[:, None] * ridge  # the ridge: unit Jacobian
            x = z.copy()
            for i, stretch in zip(self._atoms, self._stretch, strict=True):
                plateau = z[:, i] < 0.0
                x[:, i] = np.where(plateau, stretch * z[:, i], z[:, i])
                log_det += np.where(plateau, math.log(stretch), 0.0)
            for i in self._logs:
                x[:, i] = np.exp(z[:, i])
                log_det += z[:, i]
            for i in self._folded:  # |∂x/∂z| = 1
                x[:, i] = np.abs(z[:, i])
            if self._height is not None:
                self._height_from_q(z, x, log_det)
            if self._t0 is not None:
                impacts = self.space.impacts(x, self.data.n_flights)
                centre, scale = self._t0_centre(x, impacts[0])
                x[:, self._t0] = centre + scale * z[:, self._t0]
                log_det += np.log(scale)
        return x, log_det, impacts

    def _height_from_q(self, z: NDArray, x: NDArray, log_det: NDArray) -> None:
        """Fill x's height column from q (in place), and add log |∂h/∂q| to ``log_det``."""
        gamma, arm, omega0, theta0 = self._gamma_arm_speed(x)
        q = z[:, self._height]
        theta_c = theta0 + (gamma * gamma * q * q - omega0 * omega0) / (2.0 * gamma)
        ratio, slope, possible = self.space.forward.height_ratio(theta_c)
        ok = (q > 0.0) & (gamma * q > omega0) & possible & (gamma > 0.0)
        x[:, self._height] = arm * ratio
        log_det += np.log(arm * slope * gamma * q)
        if not ok.all():
            x[~ok, self._height] = np.nan
            log_det[~ok] = 0.0

    def to_parameters_one(self, z: NDArray) -> tuple[NDArray, float, NDArray | None] | None:
        """:meth:`to_parameters_and_impacts` for one point ``(ndim,)`` (nested sampling's path):
        scalars in ``math``, one small array for the onsets. Returns ``None`` where ``z`` maps
        outside the valid parameters."""
        for i, ridge in zip(self._atoms, self._ridges, strict=True):
            if z[i] > 0.0:
                z = z + z[i] * ridge
        row = z.tolist()
        log_det = 0.0
        try:
            for i, stretch in zip(self._atoms, self._stretch, strict=True):
                if row[i] < 0.0:
                    row[i] *= stretch
                    log_det += math.log(stretch)
            for i in self._logs:
                log_det += row[i]
                row[i] = math.exp(row[i])
            for i in self._folded:
                row[i] = abs(row[i])
            if self._height is not None:
                log_det_h = self._height_from_q_one(row)
                if log_det_h is None:
                    return None
                log_det += log_det_h
        except (OverflowError, ValueError, ZeroDivisionError):
            return None
        x = np.array(row)
        if self._t0 is None:
            return x, log_det, None
        impacts = self.space.impacts_one(x, self.data.n_flights)
        if impacts is None:
            return None
        centre, scale = self._t0_centre(x[None], impacts[None])
        x[self._t0] = float(centre[0]) + float(scale[0]) * row[self._t0]
        return x, log_det + math.log(float(scale[0])), impacts

    def _height_from_q_one(self, row: list[float]) -> float | None:
        """Replace q by h in ``row`` (in place); log |∂h/∂q|, or ``None`` where q is invalid
        (the batch map on one row: the formulas are written once)."""
        z = np.asarray([row], float)
        x, log_det = z.copy(), np.zeros(1)
        with np.errstate(all="ignore"):
            self._height_from_q(z, x, log_det)
        h = float(x[0, self._height])
        if not (math.isfinite(h) and math.isfinite(float(log_det[0]))):
            return None
        row[self._height] = h
        return float(log_det[0])
