"""Off-screen pyvista images of the solved package cross-section (sim.fem), deformed and coloured
by displacement magnitude; a temperature sweep as a GIF. The displacement is from the stress-free
(cure) state, drawn × ``exaggeration`` (stated in the title). pyvista is imported inside the
functions so that ``import twin`` stays light; headless use goes through :mod:`twin.reporting.render`'s
EGL set-up."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

MM = 1e3


def _pyvista():
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
    return pv


def _grid(sol):
    """The mesh's quadrilaterals (corner nodes) as a pyvista grid [mm], material per cell."""
    pv = _pyvista()
    mesh = sol.system.basis.mesh
    points = np.column_stack([mesh.p[0] * MM, mesh.p[1] * MM, np.zeros(mesh.p.shape[1])])
    cells = np.hstack([np.full((mesh.t.shape[1], 1), 4), mesh.t.T]).ravel()
    grid = pv.UnstructuredGrid(cells, np.full(mesh.t.shape[1], pv.CellType.QUAD, np.uint8), points)
    grid.cell_data["material"] = sol.material_index
    return grid, points


def vertex_displacement_m(sol, temperature_c: float) -> np.ndarray:
    """(n_vertices, 2) displacement [m] at the mesh corners at ``temperature_c`` (from the cure state).

    Parameters
    ----------
    sol : object
        A solved package cross-section (:mod:`sim.fem`).
    temperature_c : float
        Temperature [°C].

    Returns
    -------
    np.ndarray
        Displacement x, y per corner node [m].
    """
    u = sol.displacement(temperature_c)
    return u[sol.system.basis.nodal_dofs].T


def _deform(grid, rest, sol, temperature_c, exaggeration):
    d = vertex_displacement_m(sol, temperature_c)
    grid.points = rest + exaggeration * np.column_stack([d * MM, np.zeros(len(d))])
    mag_um = np.linalg.norm(d, axis=1) * 1e6
    grid.point_data["displacement [um]"] = mag_um
    return float(mag_um.max())


def _title(temperature_c, exaggeration):
    return f"T = {temperature_c:.1f} °C   displacement from cure x{exaggeration:g}"


def _plotter(pv):
    p = pv.Plotter(off_screen=True, window_size=(1100, 500))
    p.set_background("white")
    return p


def _draw(p, grid, clim, title):
    p.add_mesh(grid, scalars="displacement [um]", cmap="viridis", clim=clim, show_edges=True, edge_color="gray",
               line_width=0.3, scalar_bar_args={"title": "|u| [µm]", "color": "black", "fmt": "%.1f"})
    p.add_text(title, font_size=11, color="black", name="title")
    p.view_xy()
    p.camera.zoom(1.3)


def write_atomically(path: Path, write) -> Path:
    """Run ``write(tmp)`` and rename the result onto ``path``; Ctrl-C at any moment leaves no file.

    The renderer runs in C (VTK, the GIF encoder) and can swallow the KeyboardInterrupt a SIGINT
    raises while it is inside, so the signal is also recorded and honoured before the rename.

    Parameters
    ----------
    path : Path
        The file to produce.
    write : callable
        ``write(tmp)`` writes the file at the temporary path ``tmp``.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    KeyboardInterrupt
        Ctrl-C during the write; no file is left.
    """
    import signal
    import threading

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{path.suffix}")
    interrupted: list[int] = []

    def on_sigint(signum, frame):
        interrupted.append(signum)
        raise KeyboardInterrupt

    # only where Ctrl-C is live: a process started with SIGINT ignored (nohup, a background job) keeps ignoring it
    main = threading.current_thread() is threading.main_thread() and \
        signal.getsignal(signal.SIGINT) is not signal.SIG_IGN
    previous = signal.signal(signal.SIGINT, on_sigint) if main else None
    try:
        write(tmp)
        if interrupted:
            raise KeyboardInterrupt
        os.replace(tmp, path)
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)
        tmp.unlink(missing_ok=True)
    return path


def render_fem_png(sol, temperature_c: float, path: str | Path, *, exaggeration: float = 50.0) -> Path:
    """One image of the cross-section deformed at ``temperature_c``, written atomically.

    Parameters
    ----------
    sol : object
        A solved package cross-section (:mod:`sim.fem`).
    temperature_c : float
        Temperature [°C].
    path : str or Path
        The PNG to write.
    exaggeration : float
        Displacement drawn × this [1].

    Returns
    -------
    Path
        The file written.
    """
    pv = _pyvista()
    grid, rest = _grid(sol)
    peak = _deform(grid, rest, sol, temperature_c, exaggeration)

    def write(tmp):
        p = _plotter(pv)
        try:
            _draw(p, grid, [0.0, max(peak, 1e-9)], _title(temperature_c, exaggeration))
            p.screenshot(str(tmp))
        finally:
            p.close()

    return write_atomically(path, write)


def render_fem_sweep(sol, temperatures_c, path: str | Path, *, exaggeration: float = 50.0, progress=None) -> Path:
    """Animated GIF (or MP4 by suffix), one frame per temperature, colour scale fixed over the sweep. Each frame costs a
    linear combination of the unit-load solutions, not a solve.

    Parameters
    ----------
    sol : object
        A solved package cross-section (:mod:`sim.fem`).
    temperatures_c : array_like
        One frame per temperature [°C].
    path : str or Path
        The GIF (or ``.mp4``) to write.
    exaggeration : float
        Displacement drawn × this [1].
    progress : callable, optional
        Called with each frame's temperature [°C].

    Returns
    -------
    Path
        The file written.
    """
    pv = _pyvista()
    temps = np.asarray(temperatures_c, float)
    grid, rest = _grid(sol)
    peak = max(_deform(grid, rest, sol, t, exaggeration) for t in temps)

    def write(tmp):
        p = _plotter(pv)
        try:
            _deform(grid, rest, sol, temps[0], exaggeration)
            _draw(p, grid, [0.0, max(peak, 1e-9)], _title(temps[0], exaggeration))
            if Path(path).suffix.lower() == ".mp4":  # needs imageio-ffmpeg
                p.open_movie(str(tmp), framerate=4)
            else:
                p.open_gif(str(tmp), fps=4)
            for t in temps:
                _deform(grid, rest, sol, t, exaggeration)
                p.add_text(_title(t, exaggeration), font_size=11, color="black", name="title")
                p.write_frame()
                if progress is not None:
                    progress(t)
        finally:
            p.close()

    return write_atomically(path, write)
