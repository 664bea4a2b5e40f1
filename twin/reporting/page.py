"""One page builder for every HTML report: a summary first, then sections of text, tables and plots.

Every report (compare, calibrate, benchmark, fleet, study) is a :class:`Page`: self-contained
HTML (plots embedded as PNG), one stylesheet, every text escaped, wide tables scrolled inside
their box rather than running off the page, equations wrapped.
"""

from __future__ import annotations

import base64
from pathlib import Path

from twin import html as markup
from twin.io import atomic_write_text
from twin.reporting.plots import PNG_DPI

#: CSS pixels per inch of a figure: every plot's text shows at one size, whatever its figure size
CSS_PX_PER_INCH = 100
#: narrowest a plot is shown [CSS px] (narrower only on a narrower screen)
MIN_FIGURE_PX = 600

STYLE = """
body{font-family:system-ui,sans-serif;max-width:1150px;margin:auto;padding:1em;line-height:1.4;color:#222;
overflow-wrap:break-word}
h1{font-size:1.6em} h2{margin-top:1.6em;border-bottom:1px solid #ddd} h3{margin-top:1.2em} h4{margin:1em 0 .3em}
.summary{background:#f4f7ff;padding:.2em 1em;border-left:4px solid #36c}
.scroll{overflow-x:auto;max-width:100%}
table{border-collapse:collapse;margin:.5em 0}
td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px;vertical-align:top}
th{background:#f3f3f3;text-align:left}
.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap} th.num{text-align:right}
p.empty{color:#777;font-size:13px}
pre{white-space:pre-wrap;overflow-wrap:anywhere;background:#fafafa;padding:.5em;border:1px solid #eee;font-size:13px}
pre .line{display:block;padding-left:4ch;text-indent:-4ch}
figure{display:block;margin:1em 0;max-width:100%} img{max-width:100%;height:auto}
figcaption{font-size:13px;color:#555}
"""


def figure_width(png_base64: str) -> int | None:
    """The width a plot is shown at [CSS px]: its figure width at :data:`CSS_PX_PER_INCH`, at least
    :data:`MIN_FIGURE_PX` (None when ``png_base64`` is not a PNG).

    Parameters
    ----------
    png_base64 : str
        A PNG written at :data:`twin.reporting.plots.PNG_DPI`, base64-encoded.

    Returns
    -------
    int or None
    """
    try:
        head = base64.b64decode(png_base64[:44])
    except ValueError:
        return None
    if not head.startswith(b"\x89PNG") or len(head) < 24:
        return None
    return max(MIN_FIGURE_PX, round(int.from_bytes(head[16:20], "big") * CSS_PX_PER_INCH / PNG_DPI))


class Page:
    """An HTML report built section by section.

    Parameters
    ----------
    title : str
        The page's title and heading.
    summary : list of str
        Plain sentences shown first, in a box.
    """

    def __init__(self, title: str, summary: list[str] | tuple[str, ...] = ()):
        self.title = title
        self._parts: list[str] = [f"<h1>{markup.escape(title)}</h1>", markup.paragraphs(summary, "summary")]

    def heading(self, text: str, level: int = 2) -> Page:
        """Add a section heading.

        Parameters
        ----------
        text : str
        level : int
            HTML heading level, 2 to 4.

        Returns
        -------
        Page
            This page, for chaining.
        """
        self._parts.append(markup.heading(text, level))
        return self

    def text(self, *sentences: str) -> Page:
        """Add a paragraph of plain sentences (empty ones are skipped).

        Parameters
        ----------
        *sentences : str

        Returns
        -------
        Page
            This page, for chaining.
        """
        body = " ".join(s for s in sentences if s)
        if body:
            self._parts.append(markup.paragraphs([body]))
        return self

    def table(self, rows: list[list], header: list[str], caption: str = "", merge: int = 0) -> Page:
        """Add a table (see :func:`twin.html.table_html`); cells are formatted by the caller, units belong
        in the header. Without rows, a line saying there is nothing to list.

        Parameters
        ----------
        rows : list of list
            Cells, row by row.
        header : list of str
            Column names with their units.
        caption : str
        merge : int
            Leading columns whose repeated values are shown once.

        Returns
        -------
        Page
            This page, for chaining.
        """
        self._parts.append(markup.table_html(rows, header, caption, merge) or "<p class='empty'>(nothing to list)</p>")
        return self

    def figure(self, png_base64: str | None, caption: str = "") -> Page:
        """Add a plot (a base64 PNG; nothing when None).

        Parameters
        ----------
        png_base64 : str or None
            The PNG, base64-encoded.
        caption : str

        Returns
        -------
        Page
            This page, for chaining.
        """
        if png_base64 is not None:
            width = figure_width(png_base64)
            cap = f"<figcaption>{markup.escape(caption)}</figcaption>" if caption else ""
            self._parts.append(f"<figure><img src='data:image/png;base64,{png_base64}' alt='{markup.escape(caption)}'"
                               f"{'' if width is None else f' width={width}'}>{cap}</figure>")
        return self

    def code(self, text: str) -> Page:
        """Add preformatted text (an equation, a program), wrapped at the page width.

        Parameters
        ----------
        text : str

        Returns
        -------
        Page
            This page, for chaining.
        """
        self._parts.append(markup.code(text))
        return self

    def render(self) -> str:
        """The whole page as self-contained HTML.

        Returns
        -------
        str
        """
        return (f"<!doctype html><html lang='en'><head><meta charset='utf-8'><meta name='viewport' "
                f"content='width=device-width,initial-scale=1'><title>{markup.escape(self.title)}</title>"
                f"<style>{STYLE}</style></head><body>{''.join(self._parts)}</body></html>")

    def write(self, path: Path) -> Path:
        """Write the page atomically to ``path`` (its folder is created).

        Parameters
        ----------
        path : Path

        Returns
        -------
        Path
            The file written.
        """
        path.parent.mkdir(parents=True, exist_ok=True)
        return atomic_write_text(path, self.render())
