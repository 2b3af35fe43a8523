"""The signal-processing primitives onset detection uses, in numpy alone.

Importing :mod:`scipy.signal` takes most of a second (it pulls in :mod:`scipy.stats`), more
than detecting the onsets of a short recording does, and :mod:`scipy.ndimage` a third of one.
The detector needs only a few of their functions, so they are here, each computing what scipy
computes (the tests check them against scipy, which stays a dependency of the inference):

* :func:`butter_sos`: Butterworth high- and band-pass filters as second-order sections, the
  design steps of ``scipy.signal.butter(..., output="sos")`` one for one (analog prototype,
  frequency transform, bilinear transform with prewarping, pole-zero pairing), so the
  coefficients are the same to the last bit;
* :func:`sos_poles`: ``sos2zpk``'s poles;
* :class:`LinearFilter` (and :func:`sosfilt`): causal IIR filtering by cascaded
  second-order sections in direct form II transposed, with the filter's state carried from
  block to block (``sosfilt`` with ``zi``);
* :func:`maximum_filter1d`, :func:`median_filter1d`: ``scipy.ndimage``'s running maximum and
  median with ``mode="nearest"``.

Filtering is the one of them not done by scipy's own arithmetic. A recursion run sample by
sample in Python would be a hundred times slower than scipy's C loop, so the signal is cut into
blocks of :data:`BLOCK` samples and the filter written as a linear state-space system: within a
block the output is the input convolved with the first samples of the impulse response (one
matrix product for all blocks) plus the free response to the state the block starts in, and
the states at the blocks' starts follow from one another by a linear recurrence solved by
doubling (log₂ of the number of blocks vectorised steps). The states are kept in each
section's modal basis, where the powers of the state matrix only shrink (in the delay
registers themselves they grow before they decay, and so does rounding). Nothing is
truncated: the result is the recursion's, to rounding (the tests ask for 1e-12 of the
signal's scale up to 48 kHz, 1e-11 at 96 and 192 kHz, where scipy's own rounding is 1e-13).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

#: Samples per block of :class:`LinearFilter`: each output sample costs about this many
#: multiply-adds in the in-block convolution, and the recurrence between blocks costs less
#: the longer they are; 64 is near the fastest for the filters here (2 to 4 states), and
#: as accurate as any.
BLOCK = 64

#: Blocks per matrix product in :meth:`LinearFilter.filter`, and rows per product in its
#: recurrence between blocks: small enough that BLAS runs each on one thread.
_ROWS = 32
_SCAN_ROWS = 8192


# --- Butterworth design (scipy.signal.butter's steps, same operations, same order) ---

def butter_sos(order: int, cutoff: float | Sequence[float], btype: str, fs: float
               ) -> np.ndarray:
    """A digital Butterworth filter as second-order sections.

    Parameters
    ----------
    order
        Filter order (a band-pass has twice as many poles).
    cutoff
        Cut-off frequency (high-pass) or ``(low, high)`` band edges (band-pass), Hz.
    btype
        ``"highpass"`` or ``"bandpass"``.
    fs
        Sample rate, Hz.

    Returns
    -------
    numpy.ndarray
        ``(sections, 6)`` rows ``b0 b1 b2 a0 a1 a2``, as ``scipy.signal.butter(order, cutoff,
        btype, fs=fs, output="sos")`` returns them.
    """
    wn = np.asarray(cutoff, dtype=np.float64) / (float(fs) / 2)
    if np.any(wn <= 0) or np.any(wn >= 1):
        raise ValueError(f"Digital filter critical frequencies must be 0 < Wn < fs/2 "
                         f"(fs={fs} -> fs/2={fs / 2})")
    # Prewarp for the bilinear transform at a nominal rate of 2 (scipy's convention).
    rate = 2.0
    warped = 2 * rate * np.tan(np.pi * wn / rate)
    # Analog low-pass prototype: poles on the left half of the unit circle.
    m = np.arange(-order + 1, order, 2, dtype=np.float64)
    p = -np.exp(1j * np.pi * m / (2 * order))
    z = np.zeros(0, dtype=np.float64)
    k = 1.0
    if btype == "highpass":
        if wn.size != 1:
            raise ValueError("a high-pass takes one cut-off frequency")
        z, p, k = _lp2hp(z, p, k, float(warped))
    elif btype == "bandpass":
        if wn.size != 2 or not wn[0] < wn[1]:
            raise ValueError("a band-pass takes (low, high) with low < high")
        bw = warped[1] - warped[0]
        wo = np.sqrt(warped[0] * warped[1])
        z, p, k = _lp2bp(z, p, k, float(wo), float(bw))
    else:
        raise ValueError(f"btype must be 'highpass' or 'bandpass', not {btype!r}")
    z, p, k = _bilinear(z, p, k, rate)
    return _zpk2sos(z, p, k)


def _lp2hp(z: np.ndarray, p: np.ndarray, k: float, wo: float
           ) -> tuple[np.ndarray, np.ndarray, float]:
    """Low-pass prototype to high-pass at ``wo`` (scipy's ``lp2hp_zpk``)."""
    degree = p.shape[0] - z.shape[0]
    z_hp = np.concatenate((wo / z, np.zeros(degree)))
    p_hp = wo / p
    k_hp = k * np.real(np.prod(-z) / np.prod(-p))
    return z_hp, p_hp, float(k_hp)


def _lp2bp(z: np.ndarray, p: np.ndarray, k: float, wo: float, bw: float
           ) -> tuple[np.ndarray, np.ndarray, float]:
    """Low-pass prototype to band-pass about ``wo`` of width ``bw`` (scipy's
    ``lp2bp_zpk``)."""
    degree = p.shape[0] - z.shape[0]
    z_lp = (z.astype(np.complex128) * bw / 2).astype(np.complex128)
    p_lp = (p * bw / 2).astype(np.complex128)
    z_bp = np.concatenate((z_lp + np.sqrt(z_lp**2 - wo**2), z_lp - np.sqrt(z_lp**2 - wo**2)))
    p_bp = np.concatenate((p_lp + np.sqrt(p_lp**2 - wo**2), p_lp - np.sqrt(p_lp**2 - wo**2)))
    z_bp = np.concatenate((z_bp, np.zeros(degree)))
    return z_bp, p_bp, k * bw**degree


def _bilinear(z: np.ndarray, p: np.ndarray, k: float, rate: float
              ) -> tuple[np.ndarray, np.ndarray, float]:
    """Analog to digital by the bilinear transform (scipy's ``bilinear_zpk``)."""
    degree = p.shape[0] - z.shape[0]
    fs2 = 2.0 * rate
    z_z = np.concatenate(((fs2 + z) / (fs2 - z), -np.ones(degree)))
    p_z = (fs2 + p) / (fs2 - p)
    k_z = k * np.real(np.prod(fs2 - z) / np.prod(fs2 - p))
    return z_z, p_z, float(k_z)


def _cplxreal(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One of each complex-conjugate pair, and the real values (scipy's ``_cplxreal``)."""
    z = np.atleast_1d(z)
    if z.size == 0:
        return z, z
    tol = 100 * np.finfo((1.0 * z).dtype).eps
    z = z[np.lexsort((abs(z.imag), z.real))]
    real = abs(z.imag) <= tol * abs(z)
    zr = z[real].real
    if len(zr) == len(z):
        return np.array([]), zr
    z = z[~real]
    zp, zn = z[z.imag > 0], z[z.imag < 0]
    if len(zp) != len(zn):
        raise ValueError("Array contains complex value with no matching conjugate.")
    same_real = np.diff(zp.real) <= tol * abs(zp[:-1])
    diffs = np.diff(np.concatenate(([0], same_real, [0])))
    for start, stop in zip(np.nonzero(diffs > 0)[0], np.nonzero(diffs < 0)[0] + 1,
                           strict=True):
        for chunk in (zp[start:stop], zn[start:stop]):
            chunk[...] = chunk[np.lexsort([abs(chunk.imag)])]
    if any(abs(zp - zn.conj()) > tol * abs(zn)):
        raise ValueError("Array contains complex value with no matching conjugate.")
    return (zp + zn.conj()) / 2, zr


def _poly(roots: Sequence) -> np.ndarray:
    """Monic polynomial with the given roots, real when they come in conjugate pairs (the
    1-D ``numpy.poly`` that scipy's ``zpk2tf`` uses)."""
    roots = np.atleast_1d(np.asarray(roots))
    if roots.shape[0] == 0:
        return np.asarray(1.0)
    a = np.ones((1,), dtype=roots.dtype)
    one = np.ones_like(roots[0])
    for root in roots:
        a = np.convolve(a, np.stack((one, -root)), mode="full")
    if np.iscomplexobj(a):
        r = np.asarray(roots, dtype=np.complex128)
        if np.all(np.sort(r.imag) == np.sort(np.conj(r).imag)):
            a = np.asarray(a.real, copy=True)
    return a


def _section(z: list, p: list) -> np.ndarray:
    """One second-order section with unit gain from its zeros and poles."""
    sos = np.zeros(6)
    b = np.atleast_1d(np.multiply(np.asarray([1.0]), _poly(np.asarray(z))))
    a = np.atleast_1d(_poly(np.asarray(p)))
    sos[3 - len(b):3] = b
    sos[6 - len(a):6] = a
    return sos


def _nearest(fro: np.ndarray, to: complex, which: str) -> int:
    """Index of the element of ``fro`` nearest ``to`` among the real, complex or all ones."""
    order = np.argsort(np.abs(fro - to))
    if which == "any":
        return int(order[0])
    mask = np.isreal(fro[order])
    if which == "complex":
        mask = ~mask
    return int(order[np.nonzero(mask)[0][0]])


def _zpk2sos(z: np.ndarray, p: np.ndarray, k: float) -> np.ndarray:
    """Zeros, poles and gain to second-order sections, pairing each pole with the nearest
    zeros and putting the poles nearest the unit circle last (scipy's ``zpk2sos`` with
    ``pairing="nearest"``, digital)."""
    if len(z) == len(p) == 0:
        return np.array([[k, 0.0, 0.0, 1.0, 0.0, 0.0]])
    p = np.concatenate((p, np.zeros(max(len(z) - len(p), 0))))
    z = np.concatenate((z, np.zeros(max(len(p) - len(z), 0))))
    n_sections = (max(len(p), len(z)) + 1) // 2
    if len(p) % 2 == 1:
        p = np.concatenate((p, [0.0]))
        z = np.concatenate((z, [0.0]))
    z = np.concatenate(_cplxreal(z))
    p = np.concatenate(_cplxreal(p))

    def worst(q: np.ndarray) -> int:
        return int(np.argmin(np.abs(1 - np.abs(q))))

    sos = np.zeros((n_sections, 6))
    for si in range(n_sections - 1, -1, -1):
        i1 = worst(p)
        p1 = p[i1]
        p = np.delete(p, i1)
        if np.isreal(p1) and np.isreal(p).sum() == 0:  # the last real pole
            iz = _nearest(z, p1, "real")
            z1 = z[iz]
            z = np.delete(z, iz)
            sos[si] = _section([z1, 0], [p1, 0])
        elif (len(p) + 1 == len(z) and not np.isreal(p1) and np.isreal(p).sum() == 1
              and np.isreal(z).sum() == 1):  # must pair with a complex zero
            iz = _nearest(z, p1, "complex")
            z1 = z[iz]
            z = np.delete(z, iz)
            sos[si] = _section([z1, z1.conj()], [p1, p1.conj()])
        else:
            if np.isreal(p1):
                real = np.flatnonzero(np.isreal(p))
                i2 = real[worst(p[real])]
                p2 = p[i2]
                p = np.delete(p, i2)
            else:
                p2 = p1.conj()
            if len(z) > 0:
                iz = _nearest(z, p1, "any")
                z1 = z[iz]
                z = np.delete(z, iz)
                if not np.isreal(z1):
                    sos[si] = _section([z1, z1.conj()], [p1, p2])
                elif len(z) > 0:
                    iz = _nearest(z, p1, "real")
                    z2 = z[iz]
                    z = np.delete(z, iz)
                    sos[si] = _section([z1, z2], [p1, p2])
                else:
                    sos[si] = _section([z1], [p1, p2])
            else:
                sos[si] = _section([], [p1, p2])
    sos[0][:3] *= k
    return sos


def sos_poles(sos: np.ndarray) -> np.ndarray:
    """The poles of second-order sections (``scipy.signal.sos2zpk(sos)[1]``: numpy's roots
    of each section's denominator, two per section)."""
    sos = np.asarray(sos, dtype=np.float64)
    p = np.zeros(2 * sos.shape[0], dtype=np.complex128)
    for s, row in enumerate(sos):
        roots = np.roots(row[3:] / row[3])
        p[2 * s: 2 * s + roots.shape[0]] = roots
    return p


# --- Causal IIR filtering ---

class LinearFilter:
    """A causal IIR filter of cascaded second-order sections, run in direct form II
    transposed as ``scipy.signal.sosfilt`` runs it, on whole blocks at once (module
    docstring).

    Parameters
    ----------
    sos
        ``(n, 6)`` rows ``b0 b1 b2 a0 a1 a2``, applied one after another.

    Notes
    -----
    The state is the sections' delay registers, two per section, in the layout of scipy's
    ``zi`` flattened. Everything :meth:`filter` needs is derived once, from the recursion
    itself run in Python on an impulse and on each unit state.

    Only cascades of second-order sections: one high-order transfer function (what
    ``sos2tf`` gives) is so sensitive to rounding that even scipy's ``lfilter`` computes it
    to only 1e-9 at 96 kHz, and the powers of its state matrix that the blocks are joined
    with lose far more; its cascade is the same filter, well conditioned.
    """

    def __init__(self, sos: np.ndarray) -> None:
        sos = np.atleast_2d(np.asarray(sos, dtype=np.float64))
        if sos.ndim != 2 or sos.shape[1] != 6:
            raise ValueError("sos must have shape (sections, 6)")
        if np.any(sos[:, 3] == 0):
            raise ValueError("a0 of every section must be non-zero")
        self.sos = sos
        # Each section normalised by its a0, as scipy's sosfilt does.
        self.sections = [((row[:3] / row[3]).tolist(), (row[3:] / row[3]).tolist())
                         for row in sos]
        self.order = 2 * len(self.sections)
        self._blocks = _block_matrices(self)

    def step(self, state: list[float], x: float) -> float:
        """One sample through the recursion (Python floats): updates ``state`` in place and
        returns the output. The reference the block form is built from."""
        for i, (b, a) in enumerate(self.sections):
            y = b[0] * x + state[2 * i]
            state[2 * i] = b[1] * x - a[1] * y + state[2 * i + 1]
            state[2 * i + 1] = b[2] * x - a[2] * y
            x = y
        return x

    def filter(self, x: np.ndarray, state: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        """Filter ``x`` from ``state`` (default: at rest).

        Returns
        -------
        y, state
            The output, and the state after the last sample (to continue from).
        """
        x = np.asarray(x, dtype=np.float64)
        d = self.order
        s0 = np.zeros(d) if state is None else np.asarray(state, dtype=np.float64).ravel()
        n = x.size
        if n == 0:
            return np.zeros(0), s0.copy()
        m = self._blocks
        size = m.conv_t.shape[0]
        nb = -(-n // size)  # blocks
        # Blocks in groups of _ROWS: numpy multiplies stacked matrices one small product
        # each, which BLAS runs on one thread (a large product it splits over threads, and on
        # a busy machine those wait on each other: ten times slower).
        groups = -(-nb // _ROWS)
        xb = np.zeros(groups * _ROWS * size)
        xb[:n] = x
        xg = xb.reshape(groups, _ROWS, size)
        # States at the blocks' starts: s[b+1] = A^size s[b] + (block b's input's share),
        # i.e. s[b] = sum over i <= b of (A^size)^(b-i) w[i] with w = (s0, shares...): a
        # prefix sum under a constant linear map, done by doubling (Hillis-Steele).
        w = np.empty((groups * _ROWS + 1, d))
        w[0] = m.basis_inv @ s0
        w[1:] = (xg @ m.drive_t).reshape(-1, d)
        for shift, power_t in zip(_shifts(nb + 1), m.doubling_t, strict=False):
            # Row chunks small enough for one thread, from the last: a chunk's update reads
            # only rows below it, which later (lower) chunks have not changed yet.
            for hi in range(nb + 1, shift, -_SCAN_ROWS):
                lo = max(hi - _SCAN_ROWS, shift)
                w[lo:hi] += w[lo - shift: hi - shift] @ power_t
        y = np.empty((groups, _ROWS, size))
        np.matmul(xg, m.conv_t, out=y)
        # The free response added a few groups at a time: a temporary as large as y is
        # a fresh mapping of memory every call, whose page faults cost more than the sums.
        free = w[:-1].reshape(groups, _ROWS, d)
        for g in range(0, groups, 4):
            y[g: g + 4] += free[g: g + 4] @ m.free_t
        r = n - (nb - 1) * size  # samples in the last block
        last = m.basis @ (m.powers[r] @ w[nb - 1]
                          + xb[(nb - 1) * size: n] @ m.drive_t[size - r:])
        return y.reshape(-1)[:n], last


def _shifts(count: int) -> list[int]:
    """The doubling steps 1, 2, 4, … below ``count``."""
    out, s = [], 1
    while s < count:
        out.append(s)
        s *= 2
    return out


def _modal_basis(a1: float, a2: float) -> np.ndarray:
    """Columns spanning a section's two delay registers in which its state matrix (that of
    ``[[-a1, 1], [-a2, 0]]``, direct form II transposed) is a rotation and scaling (complex
    poles) or diagonal (distinct real poles).

    In the registers themselves the matrix is far from normal when the poles are near 1 (a
    low cut-off at a high rate): a small state rings up to a large output, its powers grow
    before they decay, and the rounding of each product is magnified as much (1e-10 of the
    signal at 192 kHz). In this basis its powers only shrink. Poles too close to tell apart
    keep the registers (identity).
    """
    disc = a1 * a1 - 4.0 * a2
    if disc < 0:  # complex pair σ ± iω: eigenvector (1, a1 + σ + iω)
        sigma, omega = -0.5 * a1, 0.5 * math.sqrt(-disc)
        basis = np.array([[1.0, 0.0], [a1 + sigma, omega]])
    elif disc > 1e-12:  # distinct real poles
        r = 0.5 * math.sqrt(disc)
        p1, p2 = -0.5 * a1 + r, -0.5 * a1 - r
        basis = np.array([[1.0, 1.0], [a1 + p1, a1 + p2]])
    else:
        return np.eye(2)
    return basis / np.linalg.norm(basis, axis=0)


class _Blocks(NamedTuple):
    """What :meth:`LinearFilter.filter` needs, in the sections' modal bases
    (:func:`_modal_basis`); products are taken as ``rows @ matrix``, so most are stored
    transposed."""

    #: ``(d, d)`` block-diagonal: the registers (scipy's ``zi`` flattened) are ``basis @
    #: state``; and its inverse.
    basis: np.ndarray
    basis_inv: np.ndarray
    #: ``(size, size)`` lower-triangular Toeplitz, transposed: the first ``size`` samples of
    #: the impulse response (a block's output due to its own input, from rest).
    conv_t: np.ndarray
    #: ``(d, size)``: the output over a block from each unit state with no input.
    free_t: np.ndarray
    #: ``(size, d)``: the state at a block's end due to a unit sample at each position.
    drive_t: np.ndarray
    #: ``(size + 1, d, d)``: the state transition over k samples, k = 0 … size.
    powers: np.ndarray
    #: ``(A^size)^(2^j)``, transposed, for j = 0, 1, … (fewer once they underflow to 0).
    doubling_t: list[np.ndarray]


def _block_matrices(f: LinearFilter, size: int = BLOCK, levels: int = 40) -> _Blocks:
    """The block matrices of ``f`` (:class:`_Blocks`), from its recursion run in Python."""
    d = f.order
    # The recursion as a linear map, in the registers: one step from each unit register
    # (no input) and from rest with a unit input.
    a_reg, c_reg = np.zeros((d, d)), np.zeros(d)
    for j in range(d):
        state = [0.0] * d
        state[j] = 1.0
        c_reg[j] = f.step(state, 0.0)
        a_reg[:, j] = state
    state = [0.0] * d
    f.step(state, 1.0)
    b_reg = np.array(state)
    basis = np.zeros((d, d))
    for i, (_, a) in enumerate(f.sections):
        basis[2 * i: 2 * i + 2, 2 * i: 2 * i + 2] = _modal_basis(a[1], a[2])
    a_mod = np.linalg.solve(basis, a_reg @ basis)
    b_mod = np.linalg.solve(basis, b_reg)
    c_mod = c_reg @ basis
    powers = np.zeros((size + 1, d, d))
    powers[0] = np.eye(d)
    for k in range(size):
        powers[k + 1] = a_mod @ powers[k]
    free = np.stack([c_mod @ powers[k] for k in range(size)])
    # drive[:, k]: a unit sample at position k has size - 1 - k more steps to go.
    drive = np.stack([powers[size - 1 - k] @ b_mod for k in range(size)], axis=1)
    # The impulse response by the recursion itself (no state basis involved).
    state = [0.0] * d
    h = np.array([f.step(state, 1.0 if k == 0 else 0.0) for k in range(size)])
    conv = np.zeros((size, size))
    for k in range(size):
        conv[k:, k] = h[: size - k]
    doubling = []
    m = powers[size]
    for _ in range(levels):
        doubling.append(np.ascontiguousarray(m.T))
        if not np.any(m):
            break
        m = m @ m
    return _Blocks(basis, np.linalg.inv(basis), np.ascontiguousarray(conv.T),
                   np.ascontiguousarray(free.T), np.ascontiguousarray(drive.T), powers,
                   doubling)


@functools.lru_cache(maxsize=64)
def _cached_filter(coefficients: tuple[float, ...]) -> LinearFilter:
    return LinearFilter(np.asarray(coefficients, dtype=np.float64).reshape(-1, 6))


def sosfilt(sos: np.ndarray, x: np.ndarray, zi: np.ndarray | None = None
            ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.sosfilt`` for a 1-D ``x``: the output, and with ``zi`` (``(sections,
    2)``) also the final state in the same layout. (The filter's block matrices are cached
    by coefficients; hold a :class:`LinearFilter` to skip even the look-up.)"""
    sos = np.atleast_2d(np.asarray(sos, dtype=np.float64))
    f = _cached_filter(tuple(sos.ravel().tolist()))
    y, state = f.filter(x, None if zi is None else np.asarray(zi).ravel())
    return y if zi is None else (y, state.reshape(sos.shape[0], 2))


# --- Running maximum and median (scipy.ndimage, mode="nearest") ---

def _windows(x: np.ndarray, size: int) -> np.ndarray:
    """Centred windows of ``size`` (odd) samples, the ends extended with the edge values."""
    if size < 1 or size % 2 == 0:
        raise ValueError("size must be odd and positive")
    half = size // 2
    padded = np.pad(np.asarray(x, dtype=np.float64), half, mode="edge")
    return np.lib.stride_tricks.sliding_window_view(padded, size)


def maximum_filter1d(x: np.ndarray, size: int) -> np.ndarray:
    """Running maximum over ``size`` (odd) samples centred on each, the ends extended with
    the edge values (``scipy.ndimage.maximum_filter1d(x, size, mode="nearest")``)."""
    if np.asarray(x).size == 0:
        return np.zeros(0)
    return _windows(x, size).max(axis=1)


def median_filter1d(x: np.ndarray, size: int) -> np.ndarray:
    """Running median over ``size`` (odd) samples centred on each, the ends extended with
    the edge values (``scipy.ndimage.median_filter(x, size, mode="nearest")`` on 1-D)."""
    if np.asarray(x).size == 0:
        return np.zeros(0)
    return np.median(_windows(x, size), axis=1)
