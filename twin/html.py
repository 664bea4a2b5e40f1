"""HTML pieces every page and notebook display is made of: sentences, tables, equations.

One way to write them, shared by the report pages (:class:`twin.reporting.page.Page`) and the
results' ``_repr_html_`` (a notebook shows a result as a :func:`fragment`): every text escaped,
numeric columns right-aligned, no value ever printed as Python would (``None``, ``nan``, ``True``
become words or a dash through :func:`number` and :func:`yes_no`).
"""

from __future__ import annotations

import html
import math
import re
from collections.abc import Iterable, Sequence

#: what a cell holds when there is no value
DASH = "–"
_NUMBER = re.compile(r"^[+\-−]?(\d[\d,]*\.?\d*|\.\d+)([eE][+\-−]?\d+)?( ?%)?$")
_EMPTY = {"", "-", DASH, "—"}

#: the stylesheet of a fragment shown alone (a notebook cell); a page has its own
FRAGMENT_STYLE = (".twin-result{line-height:1.4;max-width:100%} .twin-result .scroll{overflow-x:auto;max-width:100%}"
                  " .twin-result table{border-collapse:collapse;margin:.4em 0}"
                  " .twin-result td,.twin-result th{border:1px solid #ccc;padding:2px 6px;vertical-align:top;font-size:.9em}"
                  " .twin-result th{background:#f3f3f3;text-align:left}"
                  " .twin-result .num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}")


def escape(text: object) -> str:
    """``text`` as HTML text (``<``, ``>``, ``&`` and quotes escaped).

    Parameters
    ----------
    text : object
        Turned into a string first.

    Returns
    -------
    str
    """
    return html.escape(str(text))


def number(value: float | int | None, spec: str = ".3g", scale: float = 1.0, suffix: str = "") -> str:
    """A figure as a person reads it: formatted with ``spec``, a dash when there is none.

    Parameters
    ----------
    value : float, int or None
        The figure (None, NaN and infinities have no value to show).
    spec : str
        Format specification, e.g. ``".3f"``.
    scale : float
        Multiplies the value first (``1e3`` for g → mg).
    suffix : str
        Appended to a value, e.g. ``" %"``.

    Returns
    -------
    str
    """
    if value is None or isinstance(value, bool) or not math.isfinite(value):
        return DASH
    return f"{value * scale:{spec}}{suffix}"


def yes_no(flag: bool | None) -> str:
    """``yes``, ``no``, or a dash for an unknown flag.

    Parameters
    ----------
    flag : bool or None

    Returns
    -------
    str
    """
    return DASH if flag is None else "yes" if flag else "no"


def paragraphs(sentences: Iterable[str], css_class: str = "") -> str:
    """One ``<p>`` per non-empty sentence, in a ``<div>`` of ``css_class`` when given.

    Parameters
    ----------
    sentences : iterable of str
    css_class : str

    Returns
    -------
    str
        ``""`` when every sentence is empty.
    """
    body = "".join(f"<p>{escape(s)}</p>" for s in sentences if s)
    if not body or not css_class:
        return body
    return f"<div class='{css_class}'>{body}</div>"


def heading(text: str, level: int = 2) -> str:
    """A heading of ``level`` (2 to 4).

    Parameters
    ----------
    text : str
    level : int

    Returns
    -------
    str
    """
    level = min(max(level, 2), 4)
    return f"<h{level}>{escape(text)}</h{level}>"


def _numeric(column: list[str]) -> bool:
    """A column of numbers (and dashes for missing ones)."""
    values = [c for c in column if c not in _EMPTY]
    return bool(values) and all(_NUMBER.match(c) for c in values)


def _spans(rows: list[list[str]], merge: int) -> list[list[int]]:
    """Row span of each cell: in the first ``merge`` columns a value repeated in the rows below
    (with the same values to its left) is shown once; 0 marks a cell covered by the one above."""
    spans = [[1] * len(r) for r in rows]
    for j in range(merge):
        top = 0
        for i in range(1, len(rows) + 1):
            same = i < len(rows) and j < len(rows[i]) and rows[i][:j + 1] == rows[top][:j + 1]
            if not same:
                spans[top][j] = i - top
                for k in range(top + 1, i):
                    spans[k][j] = 0
                top = i
    return spans


def table_html(rows: Sequence[Sequence[object]], header: Sequence[str], caption: str = "", merge: int = 0) -> str:
    """A table in a box that scrolls sideways when it is wider than the page.

    Cells are formatted by the caller (units belong in the header; :func:`number` writes a figure);
    a column whose every cell is a number (or a dash) is right-aligned with its header.

    Parameters
    ----------
    rows : sequence of sequence
        Cells, row by row (turned into strings and escaped).
    header : sequence of str
        Column names with their units.
    caption : str
    merge : int
        Leading columns whose repeated values are shown once, spanning their rows.

    Returns
    -------
    str
        ``""`` when there is no row.
    """
    cells = [[str(c) for c in r] for r in rows]
    if not cells:
        return ""
    width = max(len(header), *(len(r) for r in cells))
    numeric = [_numeric([r[j] for r in cells if j < len(r)]) for j in range(width)]
    num = lambda j: " class='num'" if numeric[j] else ""  # noqa: E731
    spans = _spans(cells, merge)
    head = "".join(f"<th{num(j)}>{escape(h)}</th>" for j, h in enumerate(header))
    body = "".join("<tr>" + "".join(f"<td{num(j)}{'' if s == 1 else f' rowspan={s}'}>{escape(c)}</td>"
                                    for j, (c, s) in enumerate(zip(r, span)) if s) + "</tr>"
                   for r, span in zip(cells, spans))
    cap = f"<caption>{escape(caption)}</caption>" if caption else ""
    return f"<div class='scroll'><table>{cap}<tr>{head}</tr>{body}</table></div>"


def code(text: str) -> str:
    """Preformatted lines (an equation, a program): a line longer than the page wraps, indented
    under its start.

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    lines = "".join(f"<span class='line'>{escape(line) or ' '}</span>" for line in text.splitlines() or [""])
    return f"<pre>{lines}</pre>"


def fragment(title: str, sentences: Iterable[str], *parts: str) -> str:
    """A result shown alone (a notebook cell): its title, plain sentences first, then its tables.

    Parameters
    ----------
    title : str
    sentences : iterable of str
        The summary, one sentence (or short paragraph) each.
    *parts : str
        HTML from :func:`table_html`, :func:`heading`, :func:`code` (empty ones are skipped).

    Returns
    -------
    str
        A ``<div class='twin-result'>`` with its own small stylesheet.
    """
    return (f"<div class='twin-result'><style>{FRAGMENT_STYLE}</style><strong>{escape(title)}</strong>"
            f"{paragraphs(sentences)}{''.join(p for p in parts if p)}</div>")
