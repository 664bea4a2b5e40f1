"""One page builder for every HTML report: a summary first, then sections of text, tables and plots.

Every report (compare, calibrate, benchmark, fleet, study) is a :class:`Page`: self-contained
HTML (plots embedded as PNG), one stylesheet, every text escaped, wide tables scrolled inside
their box rather than running off the page, equations wrapped.
"""

from __future__ import annotations

import html
from pathlib import Path

from twin.io import atomic_write_text

STYLE = """
body{font-family:system-ui,sans-serif;max-width:1150px;margin:auto;padding:1em;line-height:1.4;color:#222}
h1{font-size:1.6em} h2{margin-top:1.6em;border-bottom:1px solid #ddd} h3{margin-top:1.2em}
.summary{background:#f4f7ff;padding:.8em 1em;border-left:4px solid #36c}
.scroll{overflow-x:auto;max-width:100%}
table{border-collapse:collapse;margin:.5em 0}
td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px;vertical-align:top}
th{background:#f3f3f3;text-align:left}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
pre{white-space:pre-wrap;overflow-wrap:anywhere;background:#fafafa;padding:.5em;border:1px solid #eee;font-size:13px}
figure{display:inline-block;margin:6px;max-width:100%} img{max-width:100%;height:auto}
figcaption{font-size:13px;color:#555}
"""


def _cell(value) -> str:
    """A table cell: numbers right-aligned (already formatted by the caller), everything escaped."""
    text = html.escape(str(value))
    numeric = text.replace(".", "", 1).replace("-", "", 1).replace("+", "", 1).replace(" %", "").isdigit()
    return f"<td class='num'>{text}</td>" if numeric else f"<td>{text}</td>"


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
        self._parts: list[str] = [f"<h1>{html.escape(title)}</h1>"]
        if summary:
            self._parts.append("<div class='summary'>" + "".join(f"<p>{html.escape(s)}</p>" for s in summary if s)
                               + "</div>")

    def heading(self, text: str, level: int = 2) -> Page:
        """Add a section heading.

        Parameters
        ----------
        text : str
        level : int
            HTML heading level, 2 or 3.

        Returns
        -------
        Page
            This page, for chaining.
        """
        self._parts.append(f"<h{level}>{html.escape(text)}</h{level}>")
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
            self._parts.append(f"<p>{html.escape(body)}</p>")
        return self

    def table(self, rows: list[list], header: list[str], caption: str = "") -> Page:
        """Add a table; cells are formatted by the caller (units belong in the header).

        Parameters
        ----------
        rows : list of list
            Cells, row by row.
        header : list of str
            Column names with their units.
        caption : str

        Returns
        -------
        Page
            This page, for chaining.
        """
        head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
        body = "".join("<tr>" + "".join(_cell(c) for c in r) + "</tr>" for r in rows)
        cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
        self._parts.append(f"<div class='scroll'><table>{cap}<tr>{head}</tr>{body}</table></div>")
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
            cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
            self._parts.append(f"<figure><img src='data:image/png;base64,{png_base64}' alt='{html.escape(caption)}'>"
                               f"{cap}</figure>")
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
        self._parts.append(f"<pre>{html.escape(text)}</pre>")
        return self

    def render(self) -> str:
        """The whole page as self-contained HTML.

        Returns
        -------
        str
        """
        return (f"<!doctype html><html lang='en'><head><meta charset='utf-8'><meta name='viewport' "
                f"content='width=device-width,initial-scale=1'><title>{html.escape(self.title)}</title>"
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
