"""Stick geometry (eqs. 12–16) against numerical integration over the solid.

The reference integrates a uniform-density solid of revolution slice by slice: a slice at
distance x from the butt is a thin disc of radius r(x), mass ρ π r² dx, whose moment about a
transverse axis through the pivot is ρ π r² [r²/4 + (x − d)²] dx. No formula of the package is
reused.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.integrate import quad

from drumroll.physics import StickGeometry, cylinder_cone, thin_rod

PAPER_STICK = {"cylinder_length": 0.348, "tip_length": 0.060, "radius": 0.0075}


def solid_of_revolution(radius_at, length: float, pivot: float, breakpoints=()):
    """Centre of mass and radius of gyration of a uniform solid of revolution, by quadrature.

    Parameters
    ----------
    radius_at
        r(x): the radius at distance x from the butt (m).
    length
        Total length L (m).
    pivot
        Pivot distance d from the butt (m).
    breakpoints
        Where r(x) has a kink (passed to ``quad``).

    Returns
    -------
    centre_of_mass, radius_of_gyration
        l_C and K_O = sqrt(I_O / M) (m).
    """
    opts = {"points": list(breakpoints) or None, "epsabs": 0.0, "epsrel": 1e-13, "limit": 200}
    mass = quad(lambda x: np.pi * radius_at(x) ** 2, 0.0, length, **opts)[0]
    moment = quad(lambda x: np.pi * radius_at(x) ** 2 * x, 0.0, length, **opts)[0]
    inertia = quad(lambda x: np.pi * radius_at(x) ** 2
                   * (radius_at(x) ** 2 / 4.0 + (x - pivot) ** 2), 0.0, length, **opts)[0]
    return moment / mass, np.sqrt(inertia / mass)


def cylinder_cone_by_slices(l1: float, l2: float, r: float, d: float):
    """l_C and K_O of a cylinder (l1, R) with a cone (l2, base R) on its end, by slices."""

    def radius_at(x):
        return r if x <= l1 else r * (1.0 - (x - l1) / l2)

    return solid_of_revolution(radius_at, l1 + l2, d, breakpoints=(l1,))


def thin_rod_by_slices(length: float, d: float):
    """l_C and K_O of a uniform line of mass: K_O² = (1/L) ∫ (x − d)² dx."""
    centre = quad(lambda x: x, 0.0, length)[0] / length
    inertia = quad(lambda x: (x - d) ** 2, 0.0, length, epsrel=1e-14)[0] / length
    return centre, np.sqrt(inertia)


CASES = list(itertools.product(
    [0.348, 0.2],            # l1
    [0.060, 0.01, 0.15],     # l2
    [0.0075, 0.02],          # R
    [0.0, 0.110, 0.131, 0.152, 0.25],  # d (0.25 is past the centre of mass: still geometry)
))


@pytest.mark.parametrize(("l1", "l2", "r", "d"), CASES)
def test_eq14_and_eq16_match_integration_over_slices(l1, l2, r, d):
    """K_O (eq. 14) and l_C (eq. 16) equal the uniform solid's, integrated numerically."""
    length, centre, gyration = cylinder_cone(l1, l2, r, d)
    centre_ref, gyration_ref = cylinder_cone_by_slices(l1, l2, r, d)
    assert length == pytest.approx(l1 + l2, rel=1e-15)
    assert centre == pytest.approx(centre_ref, rel=1e-12)
    assert gyration == pytest.approx(gyration_ref, rel=1e-12)


@pytest.mark.parametrize(("length", "d"), [(0.408, 0.0), (0.408, 0.131), (0.408, 0.204),
                                           (0.408, 0.408), (1.0, 0.3)])
def test_eq12_matches_integration(length, d):
    """Thin rod: K_O = sqrt(L²/3 + d² − L d), l_C = L/2 (eq. 12, eq. 13's parallel axis)."""
    total, centre, gyration = thin_rod(length, d)
    centre_ref, gyration_ref = thin_rod_by_slices(length, d)
    assert total == length
    assert centre == pytest.approx(centre_ref, rel=1e-14)
    assert gyration == pytest.approx(gyration_ref, rel=1e-13)


@pytest.mark.parametrize("d", [0.0, 0.110, 0.131, 0.152, 0.204])
def test_eq14_reduces_to_eq12_as_tip_and_radius_vanish(d):
    """As l2, R → 0 the cylinder + cone becomes the thin rod; at 0 they are equal."""
    l1 = 0.408
    _, centre_rod, gyration_rod = thin_rod(l1, d)
    _, centre0, gyration0 = cylinder_cone(l1, 0.0, 0.0, d)
    assert centre0 == pytest.approx(centre_rod, rel=1e-15)
    assert gyration0 == pytest.approx(gyration_rod, rel=1e-15)
    gaps = []
    for eps in [1e-2, 1e-3, 1e-4, 1e-5]:
        _, centre, gyration = cylinder_cone(l1, eps * l1, eps * l1, d)
        # The rod to compare with has the same total length l1 + l2.
        _, centre_rod_eps, gyration_rod_eps = thin_rod(l1 + eps * l1, d)
        gaps.append((abs(centre / centre_rod_eps - 1), abs(gyration / gyration_rod_eps - 1)))
        assert centre == pytest.approx(l1 / 2, rel=2 * eps)  # eq. 16 → L/2
    gaps = np.array(gaps)
    assert np.all(np.diff(gaps, axis=0) < 0)  # shrinks monotonically …
    assert np.all(gaps[-1] < 1e-4)  # … to nothing


def test_paper_stick_mass_properties_match_test_vectors():
    """physics.md's K_O and l_C (mm, to the printed digits) for the paper's stick."""
    for d, k_o in [(0.110, 130.0644), (0.131, 119.3245), (0.152, 111.5434)]:
        total, centre, gyration = cylinder_cone(**PAPER_STICK, pivot=d)
        assert round(float(gyration) * 1e3, 4) == k_o
        assert round(float(centre) * 1e3, 4) == 184.2717
        assert total == pytest.approx(0.408)


def test_paper_claims_about_the_thin_rod_error():
    """Paper: eq. 12 vs eq. 14 differ by about 15 % near d ≈ L/3; l_C by about 10 %."""
    for d in (0.110, 0.131, 0.136, 0.152):
        _, centre_rod, gyration_rod = thin_rod(0.408, d)
        _, centre, gyration = cylinder_cone(**PAPER_STICK, pivot=d)
        assert 0.12 < gyration_rod / gyration - 1 < 0.18
        assert 0.08 < centre_rod / centre - 1 < 0.12


def test_geometry_broadcasts_over_a_batch():
    """A batch of sticks (l1 = 348 ± 1 mm) and pivots is one call, element by element."""
    rng = np.random.default_rng(5)
    l1 = 0.348 + 0.001 * rng.standard_normal(7)
    d = np.linspace(0.1, 0.16, 7)
    batch = cylinder_cone(l1, 0.060, 0.0075, d)
    for i in range(7):
        single = cylinder_cone(l1[i], 0.060, 0.0075, d[i])
        for got, want in zip(batch, single, strict=True):
            assert got[i] == want
    grid = cylinder_cone(l1[:, None], 0.060, 0.0075, d[None, :])
    assert all(x.shape == (7, 7) for x in grid)
    rods = thin_rod(0.408, d)
    assert all(x.shape == (7,) for x in rods)


def test_stick_geometry_dispatches_to_the_shapes():
    """StickGeometry gives the same numbers as the functions and knows its length and l_C."""
    cone = StickGeometry("cylinder-cone", length=0.348, tip=0.060, radius=0.0075)
    rod = StickGeometry("thin-rod", length=0.408)
    for d in (0.0, 0.131):
        assert cone.mass_properties(d) == tuple(cylinder_cone(**PAPER_STICK, pivot=d))
        assert rod.mass_properties(d) == tuple(thin_rod(0.408, d))
    assert cone.total_length() == pytest.approx(0.408)
    assert rod.total_length() == pytest.approx(0.408)
    assert cone.centre_of_mass() == pytest.approx(0.1842717, abs=1e-7)
    assert rod.centre_of_mass() == pytest.approx(0.204)
    with pytest.raises(ValueError, match="unknown stick shape"):
        StickGeometry("banana", length=0.4).mass_properties(0.1)  # type: ignore[arg-type]


def test_effective_height_of_eq_8_from_the_papers_test_vector():
    """h_eff = h K_O² / ((l_C − d)(L − d)) with physics.md's K_O = 119.3245 mm and
    l_C = 184.2717 mm for the paper's stick at d = 131 mm (computed independently)."""
    from drumroll.physics.geometry import effective_height

    h_eff, ratio = effective_height("cylinder-cone", 0.348, 0.060, 0.0075, 0.131, 0.080)
    k_o, l_c, arm = 0.1193245, 0.1842717, 0.408 - 0.131
    assert h_eff == pytest.approx(0.080 * k_o**2 / ((l_c - 0.131) * arm), rel=1e-6)
    assert ratio == pytest.approx(k_o**2 / arm**2, rel=1e-6)
