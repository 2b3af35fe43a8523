"""The onset detector's scipy-free primitives against scipy itself (the reference: it stays a
dependency of the inference), and the detector's path free of scipy."""

import itertools
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import ndimage, optimize, signal, special

from drumroll.onsets import dsp, numerics
from drumroll.onsets.odf import OdfParams, band_edges, band_filters, wide_filter
from drumroll.stats import student_t_logpdf, student_t_logpdf_fixed
from paths import DATA

RATES = (8000, 11025, 22050, 44100, 48000, 96000, 192000)


def _designs(rate):
    """Every filter the detector designs at ``rate``, and a few more (odd orders too)."""
    params = OdfParams()
    lo = min(params.highpass_hz, 0.1 * rate)
    out = [(4, lo, "highpass"), (4, min(1000.0, 0.4 * rate), "highpass")]
    for a, b in band_edges(params, rate):
        out.append((2, a, "highpass") if b is None else (2, [a, b], "bandpass"))
    for order in (1, 3, 5, 6):
        out += [(order, 0.02 * rate, "highpass"), (order, [0.01 * rate, 0.2 * rate], "bandpass")]
    return out


@pytest.mark.parametrize("rate", RATES)
def test_butter_sos_is_scipys_to_the_bit(rate):
    for order, cutoff, btype in _designs(rate):
        ours = dsp.butter_sos(order, cutoff, btype, rate)
        theirs = signal.butter(order, cutoff, btype=btype, fs=rate, output="sos")
        assert ours.shape == theirs.shape, (order, cutoff, btype)
        np.testing.assert_array_equal(ours, theirs, err_msg=f"{order} {cutoff} {btype}")
        np.testing.assert_array_equal(dsp.sos_poles(theirs), signal.sos2zpk(theirs)[1])


def test_butter_sos_rejects_bad_settings():
    with pytest.raises(ValueError):
        dsp.butter_sos(2, 30000, "highpass", 48000)
    with pytest.raises(ValueError):
        dsp.butter_sos(2, [500, 100], "bandpass", 48000)
    with pytest.raises(ValueError):
        dsp.butter_sos(2, 100, "lowpass", 48000)


def _relative_error(ours, theirs):
    return float(np.max(np.abs(ours - theirs)) / max(np.max(np.abs(theirs)), 1e-300))


@pytest.mark.parametrize("rate", RATES)
def test_sosfilt_matches_scipy(rate):
    rng = np.random.default_rng(rate)
    # scipy's own rounding is ~1e-13 of the signal at 192 kHz; the block form's a little more.
    tol = 1e-12 if rate <= 48000 else 1e-11
    for order, cutoff, btype in _designs(rate):
        sos = signal.butter(order, cutoff, btype=btype, fs=rate, output="sos")
        for n in (1, 2, 63, 64, 65, 2047, 2048, 2049, 30001):
            # A quiet stretch, then a loud one: rounding is judged on the loud scale.
            x = rng.standard_normal(n) * np.where(np.arange(n) < n // 2, 1e-3, 1.0)
            zi = 0.1 * rng.standard_normal((sos.shape[0], 2))
            y, zf = dsp.sosfilt(sos, x, zi=zi)
            y_ref, zf_ref = signal.sosfilt(sos, x, zi=zi)
            assert _relative_error(y, y_ref) < tol, (order, cutoff, btype, n)
            assert _relative_error(zf, zf_ref) < 10 * tol, (order, cutoff, btype, n)
            assert _relative_error(dsp.sosfilt(sos, x), signal.sosfilt(sos, x)) < tol


def test_sosfilt_catches_a_wrong_filter():
    # The comparison above can fail: a coefficient off by 1e-9 is seen.
    rng = np.random.default_rng(0)
    sos = signal.butter(4, 150, btype="highpass", fs=44100, output="sos")
    x = rng.standard_normal(5000)
    wrong = sos.copy()
    wrong[1, 4] *= 1 + 1e-9
    assert _relative_error(dsp.sosfilt(wrong, x), signal.sosfilt(sos, x)) > 1e-9


def test_sosfilt_streams_blocks_as_one_signal():
    rng = np.random.default_rng(3)
    x = rng.standard_normal(20000)
    cuts = [0, 1, 7, 64, 65, 1000, 4097, 12000, 20000]
    for order, cutoff, btype in _designs(96000)[:6]:
        sos = signal.butter(order, cutoff, btype=btype, fs=96000, output="sos")
        zi = np.zeros((sos.shape[0], 2))
        parts = []
        for a, b in itertools.pairwise(cuts):
            y, zi = dsp.sosfilt(sos, x[a:b], zi=zi)
            parts.append(y)
        assert _relative_error(np.concatenate(parts), signal.sosfilt(sos, x)) < 1e-11
        y, z_same = dsp.sosfilt(sos, np.zeros(0), zi=zi)
        assert y.size == 0
        np.testing.assert_array_equal(z_same, zi)


def test_filter_streams_blocks_as_one_signal():
    rng = np.random.default_rng(3)
    x = rng.standard_normal(20000)
    for stream, sos in [(f, f.sos) for f in band_filters(OdfParams(), 96000)] + [
            (wide_filter(OdfParams(), 96000), wide_filter(OdfParams(), 96000).sos)]:
        cuts = [0, 1, 7, 64, 65, 1000, 4097, 12000, 20000]
        out = np.concatenate([stream(x[a:b]) for a, b in itertools.pairwise(cuts)])
        assert out.size == x.size
        assert _relative_error(out, signal.sosfilt(sos, x)) < 1e-11
        assert stream(np.zeros(0)).size == 0


def test_linear_filter_is_its_recursion():
    # The block form against the plain sample-by-sample recursion it is built from.
    rng = np.random.default_rng(5)
    sos = signal.butter(2, [450, 1350], btype="bandpass", fs=22050, output="sos")
    f = dsp.LinearFilter(sos)
    x = rng.standard_normal(700)
    state = [0.0] * f.order
    direct = np.array([f.step(state, v) for v in x.tolist()])
    y, final = f.filter(x)
    assert _relative_error(y, direct) < 1e-13
    assert _relative_error(final, np.array(state)) < 1e-12
    with pytest.raises(ValueError):
        dsp.LinearFilter(np.zeros((1, 5)))


@pytest.mark.parametrize("size", [1, 3, 5, 7, 11])
def test_running_maximum_and_median_are_ndimages(size):
    rng = np.random.default_rng(size)
    for n in (1, 2, 3, 6, 7, 8, 50, 1001):
        for x in (rng.standard_normal(n), rng.integers(0, 3, n).astype(float)):  # with ties
            np.testing.assert_array_equal(
                dsp.maximum_filter1d(x, size),
                ndimage.maximum_filter1d(x, size=size, mode="nearest"))
            np.testing.assert_array_equal(
                dsp.median_filter1d(x, size),
                ndimage.median_filter(x, size=size, mode="nearest"))
    assert dsp.maximum_filter1d(np.zeros(0), size).size == 0
    with pytest.raises(ValueError):
        dsp.median_filter1d(np.ones(4), 4)


def test_logsumexp_matches_scipy():
    rng = np.random.default_rng(11)
    cases = [rng.normal(0, s, n) for s in (1e-3, 1.0, 30.0, 800.0) for n in (1, 2, 5, 300)]
    cases += [np.array([0.0, 0.0, 0.0]), np.array([-np.inf, 1.0]), np.array([-np.inf] * 3),
              np.array([np.inf, 1.0]), np.array([1e308, 1e308]), np.array([-745.0, -1e4]),
              np.array([5.0, 5.0, -np.inf, 4.0]), np.array([np.nan, 1.0]), np.zeros(0)]
    for a in cases:
        ours, theirs = numerics.logsumexp(a), float(special.logsumexp(a))
        if math.isnan(theirs) or math.isinf(theirs):
            assert ours == theirs or (math.isnan(ours) and math.isnan(theirs)), a
        else:
            assert ours == pytest.approx(theirs, rel=1e-15, abs=1e-15), a


def test_log_ndtr_matches_scipy_in_both_tails():
    a = np.concatenate((np.linspace(-40.0, 8.0, 20001), [-1e3, -38.5, -20.0, -19.999, 0.0,
                                                        6.0, 6.0001, 37.0]))
    ours, theirs = numerics.log_ndtr(a), special.log_ndtr(a)
    assert ours.dtype == np.float64 and ours.shape == a.shape
    np.testing.assert_allclose(ours, theirs, rtol=1e-13, atol=0)
    assert numerics.log_ndtr(-5.5) == pytest.approx(float(special.log_ndtr(-5.5)), rel=1e-14)
    assert math.isnan(numerics.log_ndtr(math.nan))
    # The test can fail: log Φ computed the naive way loses the far tail.
    with np.errstate(divide="ignore"):
        naive = np.log(0.5 * special.erfc(-a[a < -30] / np.sqrt(2)))
    assert not np.allclose(naive, theirs[a < -30], rtol=1e-13)


def _law(p, k):
    i = np.arange(int(k[-1]), dtype=float)
    f = np.exp(np.minimum(p[1] + p[2] * i + (p[3] if p.size > 3 else 0.0) * i * i, 20.0))

    def at(v):
        return np.concatenate(([0.0], np.cumsum(v)))[k]

    cols = [np.ones(k.size), at(f), at(i * f)] + ([at(i * i * f)] if p.size > 3 else [])
    return p[0] + at(f), np.stack(cols, axis=1)


@pytest.mark.parametrize("seed", range(8))
def test_cauchy_least_squares_is_scipys(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(8, 40))
    k = np.cumsum(rng.integers(1, 3 if seed % 2 else 2, n)) - 1
    truth = np.array([0.3, math.log(0.25), math.log(rng.uniform(0.85, 0.97)), 0.0])
    times = _law(truth, k)[0] + rng.normal(0, 2e-4, n)
    times[rng.integers(0, n, 2)] += rng.normal(0, 5e-3, 2)  # mistimed onsets
    weight = np.full(n, 3e-4)
    for p0 in ([times[0], math.log(0.2), math.log(0.9)], [times[0], math.log(0.2),
                                                          math.log(0.9), 0.0]):
        def resid(p):
            return (_law(p, k)[0] - times) / weight

        def jac(p):
            return _law(p, k)[1] / weight[:, None]

        x, cost = numerics.cauchy_least_squares(resid, jac, np.array(p0))
        sol = optimize.least_squares(resid, p0, jac=jac, loss="cauchy", method="trf")
        np.testing.assert_allclose(x, sol.x, rtol=1e-9, atol=1e-12)
        assert cost == pytest.approx(sol.cost, rel=1e-10)


def test_student_t_fixed_is_the_general_one():
    z2 = np.linspace(0.0, 400.0, 101)
    for nu in (1.0, 2.5, 3.0, 4.0, 7.0, 30.0, 1e3):
        # log Γ's last-place rounding (either library's) is all that may differ.
        ulps = 8 * np.finfo(float).eps * abs(math.lgamma(0.5 * (nu + 1.0)))
        np.testing.assert_allclose(student_t_logpdf_fixed(z2, nu, 0.3),
                                   student_t_logpdf(z2, nu, 0.3), rtol=1e-14, atol=ulps)
    assert not np.allclose(student_t_logpdf_fixed(z2, 4.0), student_t_logpdf(z2, 4.5))


@pytest.mark.parametrize("code", [
    "import drumroll.onsets.detector",
    "from drumroll.cli.main import main; main(['onsets', '--help'])",
    f"from drumroll.onsets import detect; detect(r'{DATA / 'table2_h80.flac'}')",
])
def test_onset_detection_imports_no_scipy(code):
    probe = (f"import sys\ntry:\n    {code}\nexcept SystemExit:\n    pass\n"
             "loaded = sorted(m for m in sys.modules if m.split('.')[0] == 'scipy')\n"
             "print('scipy modules:', ','.join(loaded))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, env=env).stdout.splitlines()
    assert out[-1].startswith("scipy modules:")
    assert out[-1] == "scipy modules: ", out[-1]
