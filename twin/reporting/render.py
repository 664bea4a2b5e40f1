"""Off-screen pyvista images of the deformed comb (no display needed).

pyvista is imported inside the functions so that ``import twin`` stays light.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from sim.comb_mesh import comb_parts, displacement_field_um
from sim.microstructure import CombGeometry

_COLORMAP = "viridis"


def _pyvista():
    """Import pyvista for off-screen use; without a display, go straight to VTK's EGL window
    (else VTK first tries X, warns, then falls back)."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    return pv


def _meshes(geometry: CombGeometry, fingers: int):
    pv = _pyvista()

    meshes = []
    for part in comb_parts(geometry, fingers):
        xmin, xmax, ymin, ymax, zmin, zmax = part.bounds
        # Subdivide so the colour varies along each part.
        box = pv.Box(bounds=(xmin, xmax, ymin, ymax, zmin, zmax), level=6, quads=True)
        meshes.append((part, box, box.points.copy()))
    return meshes


def _deform(meshes, geometry, temperature_c, acceleration_g, reading, exaggeration):
    peak = 0.0
    for part, box, rest in meshes:
        d = displacement_field_um(rest, np.array(part.origin), part.moving, geometry, temperature_c, acceleration_g, reading,
                                 is_anchor=part.kind == "anchor")
        box.points = rest + exaggeration * d
        mag_nm = np.linalg.norm(d, axis=1) * 1e3
        box.point_data["displacement [nm]"] = mag_nm
        peak = max(peak, float(mag_nm.max()))
    return peak


def _plotter(window_size=(1000, 700)):
    p = _pyvista().Plotter(off_screen=True, window_size=window_size)
    p.set_background("white")
    return p


def _draw(p, meshes, clim, title):
    for i, (_, box, _) in enumerate(meshes):
        p.add_mesh(box, scalars="displacement [nm]", cmap=_COLORMAP, clim=clim, show_edges=False,
                   show_scalar_bar=(i == 0),
                   scalar_bar_args={"title": "displacement [nm]", "color": "black", "vertical": True,
                                    "position_x": 0.85, "position_y": 0.15, "fmt": "%.0f"})
    p.add_text(title, font_size=11, color="black", name="title")
    p.view_xy()
    p.camera.zoom(1.15)


def _title(temperature_c, exaggeration, reading, acceleration_g):
    accel = f", a = {acceleration_g:g} g" if acceleration_g else ""
    return f"T = {temperature_c:.1f} °C   displacement x{exaggeration:g}   reading {reading}{accel}"


def render_png(geometry: CombGeometry, temperature_c: float, path: str | Path, *, exaggeration: float = 2000.0,
               acceleration_g: float = 0.0, reading: str = "S", fingers: int = 6) -> Path:
    """One image of the comb deformed at ``temperature_c``, written atomically to ``path``.

    Parameters
    ----------
    geometry : CombGeometry
    temperature_c : float
        Temperature [°C].
    path : str or Path
        The PNG to write.
    exaggeration : float
        Displacement drawn × this [1].
    acceleration_g : float
        Applied acceleration [g].
    reading : str
        How the thermal expansion is read (``P``, ``S``, ``H``, ``HE``: :data:`twin.reporting.comb.MEANING`).
    fingers : int
        Comb fingers drawn.

    Returns
    -------
    Path
        The file written.
    """
    meshes = _meshes(geometry, fingers)
    peak = _deform(meshes, geometry, temperature_c, acceleration_g, reading, exaggeration)
    p = _plotter()
    _draw(p, meshes, [0.0, max(peak, 1e-6)], _title(temperature_c, exaggeration, reading, acceleration_g))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.png")
    try:
        p.screenshot(str(tmp))
        os.replace(tmp, path)
    finally:
        p.close()
        tmp.unlink(missing_ok=True)
    return path


def render_sweep(geometry: CombGeometry, temperatures_c: np.ndarray, path: str | Path, *, exaggeration: float = 2000.0,
                 acceleration_g: float = 0.0, reading: str = "S", fingers: int = 6,
                 progress=None) -> Path:
    """Animated GIF (or MP4 by suffix, needs imageio-ffmpeg) of a temperature sweep, one frame per temperature.

    The colour scale is fixed over the sweep so frames compare.

    Parameters
    ----------
    geometry : CombGeometry
    temperatures_c : np.ndarray
        One frame per temperature [°C].
    path : str or Path
        The GIF (or ``.mp4``) to write.
    exaggeration, acceleration_g, reading, fingers
        As for :func:`render_png` ([1], [g], reading, count).
    progress : callable, optional
        Called with each frame's temperature [°C].

    Returns
    -------
    Path
        The file written.
    """
    temps = np.asarray(temperatures_c, float)
    meshes = _meshes(geometry, fingers)
    peak = max(_deform(meshes, geometry, t, acceleration_g, reading, exaggeration) for t in (temps.min(), temps.max()))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{path.suffix}")
    try:
        p = _plotter()
        try:
            _deform(meshes, geometry, temps[0], acceleration_g, reading, exaggeration)
            _draw(p, meshes, [0.0, max(peak, 1e-6)], _title(temps[0], exaggeration, reading, acceleration_g))
            if path.suffix.lower() == ".mp4":
                p.open_movie(str(tmp), framerate=4)
            else:
                p.open_gif(str(tmp), fps=4)
            for t in temps:
                _deform(meshes, geometry, t, acceleration_g, reading, exaggeration)
                p.add_text(_title(t, exaggeration, reading, acceleration_g), font_size=11, color="black", name="title")
                p.write_frame()
                if progress:
                    progress(t)
        finally:
            p.close()  # once: closing also finishes the GIF/MP4 writer, so it precedes the move
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


MAX_FRAMES = 1000  # a sweep's frames (each a full render; 1000 take minutes)


def check_temperature_c(temperature_c: float, what: str = "--temperature") -> float:
    """A temperature inside the silicon model's validity (Okada & Tokumaru 1984, 120-1500 K), else ValueError.

    Parameters
    ----------
    temperature_c : float
        Temperature [°C].
    what : str
        The option named in the error.

    Returns
    -------
    float
        ``temperature_c`` [°C].

    Raises
    ------
    ValueError
        Not finite, or outside the model's range.
    """
    from sim.materials import KELVIN, OKADA_VALID_K

    lo, hi = (k - KELVIN for k in OKADA_VALID_K)
    if not (math.isfinite(temperature_c) and lo <= temperature_c <= hi):
        raise ValueError(f"{what} {temperature_c:g} °C is outside the silicon model's range (Okada & Tokumaru 1984: "
                         f"{OKADA_VALID_K[0]:g}-{OKADA_VALID_K[1]:g} K = {lo:.2f}..{hi:.2f} °C)")
    return temperature_c


def parse_sweep(spec: str) -> np.ndarray:
    """``"-20:50:5"`` → [-20, -15, …, 50] (end included when on the grid); at most :data:`MAX_FRAMES`
    frames, every temperature inside the silicon model's range.

    Parameters
    ----------
    spec : str
        ``START:STOP:STEP`` [°C].

    Returns
    -------
    np.ndarray
        The temperatures [°C].

    Raises
    ------
    ValueError
        A malformed spec, too many frames, or an end outside the model's range.
    """
    try:
        start, stop, step = (float(x) for x in spec.split(":"))
    except ValueError:
        raise ValueError(f"--sweep expects START:STOP:STEP in °C, e.g. -20:50:5; got {spec!r}") from None
    if not all(math.isfinite(v) for v in (start, stop, step)) or step <= 0 or stop < start:
        raise ValueError(f"--sweep {spec!r}: need finite numbers, STEP > 0 and STOP >= START")
    check_temperature_c(start, "--sweep START")
    check_temperature_c(stop, "--sweep STOP")
    frames = math.floor((stop - start) / step + 0.5) + 1
    if frames > MAX_FRAMES:
        raise ValueError(f"--sweep {spec!r} makes {frames:.4g} frames; the limit is {MAX_FRAMES}: take a larger STEP")
    return np.arange(start, stop + step / 2, step)
