"""Structured layered quadrilateral meshes built in code (no mesh files).

A cross-section is a grid of rectangles: ``x_breaks_m`` × ``y_breaks_m``, each rectangle given a
material index or ``VOID`` (-1, not meshed). Every rectangle is split into equal elements no larger
than the target sizes, so layer interfaces and part edges are always element edges.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

VOID = -1


@dataclass(frozen=True)
class LayeredMesh:
    """A quadrilateral mesh with one material index per element.

    Attributes
    ----------
    mesh : skfem.MeshQuad
        The mesh [m] (use it with ``ElementQuad2`` for quadratic fields).
    material : ndarray of int
        Material index of each element.
    x_nodes_m, y_nodes_m : ndarray
        Grid lines [m].
    """

    mesh: object
    material: np.ndarray
    x_nodes_m: np.ndarray
    y_nodes_m: np.ndarray


def subdivide(breaks_m: np.ndarray, max_size_m: np.ndarray | float, min_divisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Grid lines splitting each interval of ``breaks_m`` into equal parts ≤ its ``max_size_m``.

    Parameters
    ----------
    breaks_m : ndarray
        Increasing break points [m].
    max_size_m : float or ndarray
        Largest part [m], scalar or one per interval.
    min_divisions : int
        Fewest parts per interval.

    Returns
    -------
    lines : ndarray
        Grid lines [m].
    owner : ndarray of int
        For each new interval, the index of the original interval it lies in.
    """
    breaks = np.asarray(breaks_m, float)
    sizes = np.broadcast_to(np.asarray(max_size_m, float), (breaks.size - 1,))
    lines, owner = [breaks[:1]], []
    for k, (a, b) in enumerate(pairwise(breaks)):
        if not b > a:
            raise ValueError(f"mesh breaks must increase, got {a:g} then {b:g}")
        n = max(min_divisions, int(np.ceil((b - a) / sizes[k] - 1e-9)))
        lines.append(np.linspace(a, b, n + 1)[1:])
        owner += [k] * n
    return np.concatenate(lines), np.asarray(owner, int)


def layered_mesh(x_breaks_m, y_breaks_m, cell_material, max_dx_m, max_dy_m, min_divisions: int = 1) -> LayeredMesh:
    """Mesh the non-void rectangles of a grid; unused nodes are dropped.

    Parameters
    ----------
    x_breaks_m, y_breaks_m : array_like
        Increasing grid lines of the rectangles [m].
    cell_material : int array (len(y_breaks)-1, len(x_breaks)-1)
        Material index per rectangle, row = y interval; ``VOID`` = empty.
    max_dx_m, max_dy_m : float or array_like
        Largest element size per x / y interval [m] (scalar or one per interval).
    min_divisions : int
        Fewest elements per interval and direction.

    Returns
    -------
    LayeredMesh
        Mesh [m] with one material index per element.
    """
    from skfem import MeshQuad

    cells = np.asarray(cell_material, int)
    xs, xo = subdivide(x_breaks_m, max_dx_m, min_divisions)
    ys, yo = subdivide(y_breaks_m, max_dy_m, min_divisions)
    if cells.shape != (len(y_breaks_m) - 1, len(x_breaks_m) - 1):
        raise ValueError(f"cell_material must have shape {(len(y_breaks_m) - 1, len(x_breaks_m) - 1)}, got {cells.shape}")
    nx = xs.size
    mat = cells[yo][:, xo]  # (ny_el, nx_el) material of every element
    jj, ii = np.nonzero(mat != VOID)
    n00 = jj * nx + ii  # counter-clockwise corners
    t = np.vstack([n00, n00 + 1, n00 + nx + 1, n00 + nx])
    used, t_compact = np.unique(t, return_inverse=True)
    gx, gy = np.meshgrid(xs, ys)
    p = np.vstack([gx.ravel()[used], gy.ravel()[used]])
    return LayeredMesh(MeshQuad(p, t_compact.reshape(t.shape)), mat[jj, ii], xs, ys)
