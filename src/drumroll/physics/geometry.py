"""Stick geometry: centre of mass and radius of gyration about the pivot (eqs. 12–16).

All lengths are in metres and every function broadcasts over numpy arrays, so a batch of
sticks (for example a Monte Carlo draw of l1 = 348 ± 1 mm) is one call.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

StickShape = Literal["thin-rod", "cylinder-cone"]
STICK_SHAPES: tuple[str, ...] = ("thin-rod", "cylinder-cone")


def mass_properties_squared(shape: str, length, tip, radius, pivot) -> tuple:
    """L, l_C and K_O² without broadcasting or conversion: the kernel of eqs. 12–16.

    For hot paths that already hold numpy arrays (or floats) of compatible shapes; see
    :func:`thin_rod` and :func:`cylinder_cone` for the documented, broadcasting versions.
    """
    d = pivot
    if shape == "thin-rod":
        return length, 0.5 * length, length**2 / 3.0 + d**2 - length * d
    l1, l2, r = length, tip, radius
    weight = 3.0 * l1 + l2
    cylinder = 3.0 * l1 * (0.25 * (r**2 + l1**2 / 3.0) + (0.5 * l1 - d) ** 2)
    cone = l2 * (3.0 / 80.0 * (4.0 * r**2 + l2**2) + (l1 - d + 0.25 * l2) ** 2)
    centre_of_mass = (6.0 * l1**2 + l2 * (4.0 * l1 + l2)) / (4.0 * weight)
    return overall_length(shape, l1, l2), centre_of_mass, (cylinder + cone) / weight


def overall_length(shape: str, length, tip):
    """The stick's whole length L: the rod's, or the cylinder's l1 and the cone's l2 (the
    first of :func:`mass_properties_squared`'s values, for a caller that needs no more)."""
    return length if shape == "thin-rod" else length + tip


def thin_rod(length: ArrayLike, pivot: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """Homogeneous thin rod pivoted at ``pivot`` from its butt (eqs. 12–13).

    Parameters
    ----------
    length
        Rod length L (m).
    pivot
        Pivot distance d from the butt end (m).

    Returns
    -------
    total_length, centre_of_mass, radius_of_gyration
        L, l_C = L/2 and K_O = sqrt(L²/3 + d² − L d) (m), broadcast together.
    """
    length, pivot = np.broadcast_arrays(np.asarray(length, float), np.asarray(pivot, float))
    total, centre, k_o_squared = mass_properties_squared("thin-rod", length, 0.0, 0.0, pivot)
    return total, centre, np.sqrt(k_o_squared)


def cylinder_cone(
    cylinder_length: ArrayLike, tip_length: ArrayLike, radius: ArrayLike, pivot: ArrayLike
) -> tuple[NDArray, NDArray, NDArray]:
    """Cylinder of radius R and length l1 with a conical tip of length l2 (eqs. 14–16).

    Parameters
    ----------
    cylinder_length, tip_length, radius
        l1, l2 and R (m); the cone's base radius equals the cylinder's.
    pivot
        Pivot distance d from the butt end (m).

    Returns
    -------
    total_length, centre_of_mass, radius_of_gyration
        L = l1 + l2, l_C of eq. 16 and K_O of eq. 14 (m), broadcast together.

    Notes
    -----
    The cylinder and the cone have masses in the ratio 3 l1 : l2 (same density and radius);
    each one's moment about its own centre of mass (eq. 15) is moved to the pivot with the
    parallel-axis theorem. As l2, R → 0 this reduces to the thin rod of eq. 12.
    """
    l1, l2, r, d = np.broadcast_arrays(*(np.asarray(x, float) for x in
                                         (cylinder_length, tip_length, radius, pivot)))
    total, centre, k_o_squared = mass_properties_squared("cylinder-cone", l1, l2, r, d)
    return total, centre, np.sqrt(k_o_squared)


@dataclass(frozen=True)
class StickGeometry:
    """The stick's shape and dimensions (SI units; fields may be arrays for a batch).

    Parameters
    ----------
    shape
        ``"thin-rod"`` (eq. 12) or ``"cylinder-cone"`` (eqs. 14–16).
    length
        l1 (m): the cylinder's length, or the whole length L of a thin rod.
    tip
        l2 (m): the cone's length (cylinder-cone only).
    radius
        R (m) (cylinder-cone only).
    """

    shape: StickShape = "cylinder-cone"
    length: ArrayLike = 0.348
    tip: ArrayLike = 0.0
    radius: ArrayLike = 0.0

    def mass_properties(self, pivot: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
        """Total length L, centre of mass l_C and radius of gyration K_O about ``pivot``."""
        if self.shape == "thin-rod":
            return thin_rod(self.length, pivot)
        if self.shape == "cylinder-cone":
            return cylinder_cone(self.length, self.tip, self.radius, pivot)
        raise ValueError(f"unknown stick shape {self.shape!r}; expected one of {STICK_SHAPES}")

    def total_length(self) -> NDArray:
        """L (m): l1 + l2 for a cylinder-cone, l1 for a thin rod."""
        if self.shape == "thin-rod":
            return np.asarray(self.length, float)
        return np.asarray(self.length, float) + np.asarray(self.tip, float)

    def centre_of_mass(self) -> NDArray:
        """l_C (m) from the butt end (eq. 12 or eq. 16); it does not depend on the pivot."""
        return self.mass_properties(0.0)[1]


def effective_height(shape: str, length, tip, radius, pivot, height) -> tuple:
    """The effective height h_eff = h K_O² / ((l_C − d)(L − d)) (eq. 8) and the tip's
    effective mass ratio K_O² / (L − d)² of a set-up (SI; arrays or floats).

    A pivoted stick falls like a point mass dropped from h_eff (the small-angle fall, eq. 7);
    K_O² / (L − d)² is how much heavier the stick is at its tip than its mass would be there
    alone (what the head feels at an impact).
    """
    total_length, centre_of_mass, k_o_squared = mass_properties_squared(
        shape, length, tip, radius, pivot)
    arm = total_length - pivot
    return height * k_o_squared / ((centre_of_mass - pivot) * arm), k_o_squared / arm**2
