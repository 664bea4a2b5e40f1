"""Plots as display objects (scikit-learn's ``*Display`` pattern).

Each display holds the data it draws, is built from a result by a ``from_*`` class method, and
draws on ``plot(ax=None)``: onto the axes given, or a new figure. It never calls ``show()``, so
the same object serves the HTML reports and a notebook. matplotlib is imported only on ``plot``.
"""

from __future__ import annotations

import base64
import io

#: resolution of every embedded plot: 1.5 PNG pixels per CSS pixel of the page (twin.reporting.page)
PNG_DPI = 150


def _axes(ax, figsize):
    # pyplot, without choosing its backend: in a notebook the figure shows inline, on a headless
    # machine matplotlib falls back to Agg by itself
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=figsize)[1]


def figure_grid(figsize: tuple[float, float], rows: int = 1, cols: int = 1):
    """A figure for a file or a report only: a bare :class:`matplotlib.figure.Figure`, outside
    pyplot, so drawing it neither switches the user's backend nor needs closing.

    Parameters
    ----------
    figsize : tuple of float
        Width and height [inch].
    rows, cols : int
        The grid of axes.

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : matplotlib.axes.Axes or numpy.ndarray
        One Axes for a 1 × 1 grid, else a (rows, cols) array.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots(rows, cols, squeeze=rows * cols == 1)


def png_base64(display_or_figure) -> str:
    """The drawn figure of a display (or a matplotlib figure) as base64 PNG; the figure is closed.

    Parameters
    ----------
    display_or_figure : Display or matplotlib.figure.Figure

    Returns
    -------
    str
    """
    import matplotlib.pyplot as plt

    fig = getattr(display_or_figure, "figure_", display_or_figure)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=PNG_DPI, bbox_inches="tight")
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


class Display:
    """Base: ``plot(ax=None)`` draws and returns self, with ``ax_`` and ``figure_`` set."""

    figsize: tuple[float, float] = (7, 3.6)
    title: str = ""

    def plot(self, ax=None):
        """Draw onto ``ax`` (a new figure when None).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional

        Returns
        -------
        Display
            Itself, with ``ax_`` and ``figure_`` set.
        """
        self.ax_ = _axes(ax, self.figsize)
        self.figure_ = self.ax_.figure
        self._draw(self.ax_)
        return self

    def _draw(self, ax) -> None:  # pragma: no cover - every display overrides it
        raise NotImplementedError


def stride(n: int) -> int:
    """Every how many samples a line plot keeps (20 000 points show the same picture).

    Parameters
    ----------
    n : int
        Samples.

    Returns
    -------
    int
    """
    return max(1, n // 20000)
