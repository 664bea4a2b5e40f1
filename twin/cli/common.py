"""What every subcommand shares: the app, ``--json``, the one-line error and the output guard.

Conventions: ``--json PATH`` writes the machine-readable result (``-`` for stdout); bad input
exits with status 2 and one line naming what and where, never a traceback.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.errors import TwinError
from twin.io import not_a_regular_file

app = typer.Typer(
    name="twin",
    help="Digital twin of the temperature drift error (TDE) of MEMS accelerometers.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    # help texts are plain text: a unit in brackets ("[mg/°C]") is not a markup tag to drop
    rich_markup_mode=None,
)

JsonOpt = Annotated[Optional[str], typer.Option("--json", help="write the result as JSON to PATH ('-' for stdout)")]


def fail(message: str) -> None:
    """Print ``twin: error: message`` on one line and exit with status 2.

    Parameters
    ----------
    message : str
        The error (whitespace runs, newlines included, become one space).

    Raises
    ------
    typer.Exit
        Always, with code 2.
    """
    typer.echo(f"twin: error: {' '.join(str(message).split())}", err=True)
    raise typer.Exit(2)


def emit_json(result: dict, dest: str | None) -> None:
    """Write ``result`` to ``dest`` atomically ('-' = stdout).

    Parameters
    ----------
    result : dict
        JSON-able; NaN and infinities are written as strict JSON (:func:`twin.io.strict_json`).
    dest : str or None
        The ``--json`` value: a file, ``-`` (stdout) or None (nothing written).
    """
    if dest is None:
        return
    from twin.io import strict_json

    text = json.dumps(strict_json(result), indent=2, default=str, allow_nan=False) + "\n"
    if dest == "-":
        sys.stdout.write(text)
        return
    from twin.io import atomic_write_text

    if Path(dest).is_dir():
        fail(f"--json {dest}: is a directory; expected a file path")
    try:
        atomic_write_text(Path(dest), text)
    except OSError as exc:  # a full disk, a read-only folder, a parent that is a file: one line
        fail(f"cannot write --json {dest}: {exc.strerror or exc}")


def check_outputs(inputs, outputs) -> None:
    """Refuse an output that is one of the inputs or a directory (missing folders are created).

    Parameters
    ----------
    inputs : iterable of str or Path or None
        The command's input files (None entries skipped).
    outputs : iterable of str or Path or None
        Its output files (None and ``-`` skipped).

    Raises
    ------
    TwinError
        An output that overwrites an input, is not a regular file, lies under a file, is in a
        folder that cannot be written, or is named twice.
    """
    resolved = {_resolved(Path(p)) for p in inputs if p is not None}
    for out in outputs:
        if out is None or str(out) == "-":
            continue
        out = Path(out)
        if _resolved(out) in resolved:
            raise TwinError(f"{out}: the output would overwrite an input; choose another path")
        kind = not_a_regular_file(out)
        if kind == "a directory":
            raise TwinError(f"{out}: is a directory; expected a file path")
        if kind is not None:
            raise TwinError(f"{out}: is {kind}; expected a regular file or a new path (it is never replaced)")
        blocked = next((p for p in out.parents if p.exists() and not p.is_dir()), None)
        if blocked is not None:  # found now, before anything is written
            raise TwinError(f"{out}: {blocked} is a file, not a folder; expected a path in a folder")
        _check_writable(out)
    named = [_resolved(Path(p)) for p in outputs if p is not None and str(p) != "-"]
    twice = next((p for i, p in enumerate(named) if p in named[:i]), None)
    if twice is not None:  # the second write would replace the first
        raise TwinError(f"{twice}: two outputs name one file (e.g. --json and -o name the same file); "
                        "choose a path for each")


def _resolved(path: Path) -> Path:
    """``path.resolve()``, or a one-line refusal for a path that cannot be resolved (a symlink loop)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError) as exc:
        raise TwinError(f"{path}: cannot be resolved ({exc}); expected a path that is not a symlink loop") from None


def _check_writable(out: Path) -> None:
    """Create and remove a probe file in the nearest existing folder of ``out`` (a read-only folder,
    /proc or a full quota is found before the work, not after it)."""
    import tempfile

    folder = next((p for p in out.parents if p.exists()), None)
    if folder is None:
        return
    try:
        fd, probe = tempfile.mkstemp(prefix=".twin-probe-", dir=folder)
    except OSError as exc:
        raise TwinError(f"{out}: cannot write in {folder}: {exc.strerror or exc}; expected a writable folder") from None
    os.close(fd)
    os.unlink(probe)


@contextmanager
def guard(inputs=(), outputs=()) -> Iterator[None]:
    """Check the outputs against the inputs, then run the body: our errors and OS errors end in one line.

    Warnings raised on the way (a NumPy division on a malformed column) are held back: after an
    error the one line stands alone; after success they are shown as usual.

    Parameters
    ----------
    inputs, outputs : iterable of str or Path or None
        As :func:`check_outputs`.

    Yields
    ------
    None
        The body runs here; a :class:`TwinError` or ``OSError`` in it ends with :func:`fail`.
    """
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        try:
            check_outputs(inputs, outputs)
            yield
        except TwinError as exc:
            fail(str(exc))
        except OSError as exc:
            fail(f"{exc.filename or ''}: {exc.strerror or exc}")
    for w in caught:
        warnings.showwarning(w.message, w.category, w.filename, w.lineno)


def column_map(columns: Path | None, **overrides):
    """A column map from ``--columns`` (YAML) with the command-line overrides that were given.

    Parameters
    ----------
    columns : Path or None
        The ``--columns`` YAML (None: the default map).
    **overrides
        Column-map attributes; those that are None (not given) are left alone.

    Returns
    -------
    ColumnMap
    """
    from twin.measurement import ColumnMap

    cmap = ColumnMap.from_yaml(columns) if columns else ColumnMap()
    for key, value in overrides.items():
        if value is not None:
            setattr(cmap, key, value)
    return cmap


def parse_axes(text: str) -> list[str]:
    """``--axes x,y,z`` as a list; anything but a subset of x, y, z is an error.

    Parameters
    ----------
    text : str
        The ``--axes`` value, comma-separated.

    Returns
    -------
    list of str
        The axes, in the order given.

    Raises
    ------
    TwinError
        An empty list, or an axis other than x, y, z.
    """
    axes = [a.strip() for a in text.split(",") if a.strip()]
    if not axes or any(a not in ("x", "y", "z") for a in axes):
        raise TwinError(f"--axes expects a comma-separated subset of x,y,z, got {text!r}")
    return axes
