"""Geometry of a comb cell for rendering: boxes for anchors, spine, moving and fixed fingers, and
their thermal and inertial displacement field (pure numpy; drawing is done elsewhere).

Layout (µm, sensing axis x, fingers along y, thickness j along z):
the moving plate's long beam (spine, width n) lies along x at y ∈ [0, n]; moving fingers (width
m, length i) rise from it; fixed fingers (width h, length g) hang from the fixed beam, their tips
a gap e above the spine, each moving finger flanked by two fixed fingers at gap u. Spring
anchors sit at both ends of the spine, fixed anchors at both ends of the fixed beam.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.materials import KELVIN, silicon_thermal_strain
from sim.microstructure import CombGeometry, displacement_m


@dataclass(frozen=True)
class CombPart:
    """An axis-aligned box [µm] and the point it grows from (its attachment).

    Attributes
    ----------
    name : str
        Label of the part.
    kind : str
        ``"anchor"``, ``"spine"``, ``"moving_finger"``, ``"fixed_finger"`` or ``"fixed_beam"``.
    bounds : tuple of 6 float
        xmin, xmax, ymin, ymax, zmin, zmax [µm].
    origin : tuple of 3 float
        Attachment point the part dilates about [µm].
    moving : bool
        Whether the part belongs to the proof mass.
    """

    name: str
    kind: str  # "anchor" | "spine" | "moving_finger" | "fixed_finger" | "fixed_beam"
    bounds: tuple[float, float, float, float, float, float]  # xmin, xmax, ymin, ymax, zmin, zmax
    origin: tuple[float, float, float]
    moving: bool


def comb_parts(geometry: CombGeometry, fingers: int = 3) -> list[CombPart]:
    """Boxes of one comb cell with ``fingers`` moving fingers.

    Parameters
    ----------
    geometry : CombGeometry
        Comb dimensions [µm].
    fingers : int
        Number of moving fingers (there is one more fixed finger).

    Returns
    -------
    list of CombPart
        Spine, fixed beam, four anchors, then the moving and the fixed fingers.
    """
    g = geometry
    pitch = g.m_um + 2 * g.u_um + g.h_um
    x0 = g.h_um + g.u_um  # first moving finger starts after one fixed finger and a gap
    width = fingers * pitch + g.h_um
    j = g.j_um
    y_tip = g.n_um + g.e_um  # fixed-finger tips
    y_beam = y_tip + g.g_um  # fixed beam bottom
    a = 1.2 * g.n_um  # anchor size
    parts = [
        CombPart("spine", "spine", (0, width, 0, g.n_um, 0, j), (width / 2, 0, 0), True),
        CombPart("fixed beam", "fixed_beam", (0, width, y_beam, y_beam + g.n_um, 0, j),
                 (width / 2, y_beam + g.n_um, 0), False),
        CombPart("spring anchor L", "anchor", (-a - 2, -2, -a / 2 + g.n_um / 2, a / 2 + g.n_um / 2, 0, j),
                 (-2, 0, 0), False),
        CombPart("spring anchor R", "anchor", (width + 2, width + a + 2, -a / 2 + g.n_um / 2, a / 2 + g.n_um / 2, 0, j),
                 (width + 2, 0, 0), False),
        CombPart("fixed anchor L", "anchor", (-a, 0, y_beam, y_beam + a, 0, j), (-a / 2, y_beam, 0), False),
        CombPart("fixed anchor R", "anchor", (width, width + a, y_beam, y_beam + a, 0, j),
                 (width + a / 2, y_beam, 0), False),
    ]
    for k in range(fingers):
        xm = x0 + k * pitch
        parts.append(CombPart(f"moving finger {k}", "moving_finger", (xm, xm + g.m_um, g.n_um, g.n_um + g.i_um, 0, j),
                              (xm + g.m_um / 2, g.n_um, 0), True))
    for k in range(fingers + 1):
        xf = k * pitch
        parts.append(CombPart(f"fixed finger {k}", "fixed_finger", (xf, xf + g.h_um, y_tip, y_beam, 0, j),
                              (xf + g.h_um / 2, y_beam, 0), False))
    return parts


def displacement_field_um(
    points_um: np.ndarray,
    origin_um: np.ndarray,
    moving: bool,
    geometry: CombGeometry,
    temperature_c: float,
    acceleration_g: float = 0.0,
    reading: str = "S",
    reference_c: float = 25.0,
    substrate_origin_um: tuple[float, float, float] = (0.0, 0.0, 0.0),
    is_anchor: bool = False,
) -> np.ndarray:
    """Displacement [µm] of the points of one part.

    Reading ``S`` (and ``P``): each part dilates by ε(T) about its attachment point while the
    anchors stay put (the paper's picture, eq. 15). ``H``/``HE``: everything dilates about the
    substrate origin (monolithic Si on Si). Moving parts also shift by Δu = a/ω0² along x.

    Parameters
    ----------
    points_um : (n, 3) ndarray
        Points of the part [µm].
    origin_um : (3,) ndarray
        The part's attachment point [µm].
    moving : bool
        Whether the part moves with the proof mass.
    geometry : CombGeometry
        Comb dimensions [µm] and resonance [Hz].
    temperature_c : float
        Temperature [°C].
    acceleration_g : float
        Input acceleration along x [g].
    reading : {"P", "S", "H", "HE"}
        Thermal reading (see :mod:`sim.microstructure`).
    reference_c : float
        Strain-free temperature [°C].
    substrate_origin_um : tuple of 3 float
        Centre of the homogeneous dilation under ``H``/``HE`` [µm].
    is_anchor : bool
        Anchors stay put under ``S``/``P``.

    Returns
    -------
    (n, 3) ndarray
        Displacement [µm].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eq. (15); ε(T) of Okada & Tokumaru (1984); Δu = a/ω0²
    is the static spring–mass response (standard result).
    """
    eps = float(silicon_thermal_strain(temperature_c + KELVIN, reference_c + KELVIN))
    pts = np.asarray(points_um, float)
    homogeneous = reading in ("H", "HE")
    centre = np.asarray(substrate_origin_um if homogeneous else origin_um, float)
    # Under S/P the anchors are bonded to a substrate that does not move: only H dilates them.
    disp = eps * (pts - centre) if (homogeneous or not is_anchor) else np.zeros_like(pts)
    if moving and acceleration_g:
        disp[:, 0] += float(displacement_m(acceleration_g, geometry.resonance_hz)) * 1e6
    return disp
