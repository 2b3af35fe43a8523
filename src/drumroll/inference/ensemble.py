"""emcee's ensemble sampler and differential-evolution move with less Python per step.

emcee decides each walker's acceptance in a Python loop (one random number, one comparison
and a few index operations per walker), and turns the log densities of a vectorised call into
floats one by one (``_scalar`` per walker, after trying each as a blob). With 128 walkers that
bookkeeping was a fifth of a step's time on the README's roll. The classes here do the same
per half-ensemble in array operations. They draw the same random numbers in the same order
(``RandomState.rand(n)`` gives the n numbers of n calls to ``rand()``), so a chain is the
same, number for number, as with emcee's own classes (tests/unit/inference/test_sampling.py).

Imported only where a sampler runs. emcee imports scipy.stats for its KDE move alone, which
drumroll does not use: a third of a second of CPU in the estimate's start-up, before the
samplers can start. :func:`import_emcee` imports emcee with scipy.stats held back and gives
the KDE move scipy's ``gaussian_kde`` when it is first used, so emcee works as before.
"""

from __future__ import annotations

import sys
from types import ModuleType

import numpy as np
from numpy.typing import NDArray


def _gaussian_kde(*args, **kwargs):
    """scipy.stats.gaussian_kde, imported when emcee's KDE move first calls it."""
    from scipy.stats import gaussian_kde

    return gaussian_kde(*args, **kwargs)


def import_emcee() -> ModuleType:
    """emcee, imported without scipy.stats when neither is loaded yet (see the module
    docstring): emcee's KDE move imports it in a ``try`` and does without it; its
    ``gaussian_kde`` is then a function that imports it on first use."""
    if "emcee" in sys.modules or "scipy.stats" in sys.modules:
        import emcee

        return emcee
    sys.modules["scipy.stats"] = None  # type: ignore[assignment]  # import: ImportError
    try:
        import emcee
    finally:
        del sys.modules["scipy.stats"]
    if getattr(emcee.moves.kde, "gaussian_kde", _gaussian_kde) is None:
        emcee.moves.kde.gaussian_kde = _gaussian_kde
    return emcee


emcee = import_emcee()
from emcee.state import State  # noqa: E402  (after emcee, imported as above)


class DEMove(emcee.moves.DEMove):
    """:class:`emcee.moves.DEMove` whose acceptance step is vectorised over the walkers of
    each half-ensemble (same random numbers, same chain)."""

    def propose(self, model, state: State) -> tuple[State, NDArray]:
        """Move each half of the ensemble against the other (emcee's ``RedBlueMove.propose``,
        its walker loop replaced by array operations)."""
        nwalkers, _ = state.coords.shape
        if nwalkers < 2 * state.coords.shape[1] and not self.live_dangerously:
            raise RuntimeError("It is unadvisable to use a red-blue move with fewer walkers "
                               "than twice the number of dimensions.")
        self.setup(state.coords)
        accepted = np.zeros(nwalkers, dtype=bool)
        all_inds = np.arange(nwalkers)
        inds = all_inds % self.nsplits
        if self.randomize_split:
            model.random.shuffle(inds)
        for split in range(self.nsplits):
            subset = inds == split
            sets = [state.coords[inds == j] for j in range(self.nsplits)]
            q, factors = self.get_proposal(sets[split], sets[:split] + sets[split + 1:],
                                           model.random)
            new_log_probs, new_blobs = model.compute_log_prob_fn(q)
            walkers = all_inds[subset]
            log_ratio = factors + new_log_probs - state.log_prob[walkers]
            # emcee draws one uniform per walker, in walker order: the same numbers here.
            accepted[walkers] = log_ratio > np.log(model.random.rand(walkers.size))
            state = self.update(state, State(q, log_prob=new_log_probs, blobs=new_blobs),
                                accepted, subset)
        return state, accepted


class EnsembleSampler(emcee.EnsembleSampler):
    """:class:`emcee.EnsembleSampler` for a vectorised target without blobs: the log densities
    of a call are taken as one array (emcee checks each value for blobs and converts it to a
    float in a Python loop)."""

    def compute_log_prob(self, coords: NDArray) -> tuple[NDArray, None]:
        """The target's log density of every row of ``coords``, with emcee's checks (a
        non-finite coordinate or a NaN density is an error)."""
        if np.any(np.isinf(coords)):
            raise ValueError("At least one parameter value was infinite")
        if np.any(np.isnan(coords)):
            raise ValueError("At least one parameter value was NaN")
        log_prob = np.asarray(self.log_prob_fn(coords), dtype=float).reshape(len(coords))
        if np.any(np.isnan(log_prob)):
            raise ValueError("Probability function returned NaN")
        return log_prob, None


class AtomReflectMove(emcee.moves.MHMove):
    """Each walker proposes its own mirror image across 0 in one column that stands for an
    effect that may be absent (an atom at 0: z < 0 "absent", z ≥ 0 the effect's size; see
    :class:`~drumroll.inference.coordinates.SamplerCoordinates`), the column drawn at random
    per walker, every other coordinate kept.

    Differential evolution moves a walker between "absent" and "present" only where the
    ensemble's differences happen to point across 0, and the share of walkers on each side
    then mixes slowly (its autocorrelation time set how long the small-angle model of the
    README's roll was sampled). The mirror z_j → −z_j is its own inverse with unit Jacobian,
    so Metropolis–Hastings accepts it with the ratio of the densities alone and keeps the
    target invariant; the coordinates' plateau (a few times the effect's posterior spread:
    :data:`~drumroll.inference.sampling.PLATEAU_SDS`) and ridge (the other columns follow
    the effect's size) put the image of a typical "present" walker among the "absent" ones,
    and that of an "absent" one near 0 among the "present" ones.
    """

    def __init__(self, columns: tuple[int, ...]) -> None:
        if not columns:
            raise ValueError("a reflection needs at least one atom column")
        self.columns = np.asarray(columns, dtype=np.intp)
        super().__init__(self._reflect)

    def _reflect(self, coords: NDArray, random) -> tuple[NDArray, NDArray]:
        proposal = coords.copy()
        rows = np.arange(coords.shape[0])
        column = self.columns[random.randint(self.columns.size, size=coords.shape[0])]
        proposal[rows, column] = -coords[rows, column]
        return proposal, np.zeros(coords.shape[0])
