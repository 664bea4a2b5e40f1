"""Small I/O helpers shared by the CLI and the writers."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path


def umask_mode() -> int:
    """0o666 less the process umask: what ``open()`` would have given a new file.

    Returns
    -------
    int
        Permission bits.
    """
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def not_a_regular_file(path: Path) -> str | None:
    """What ``path`` is when it exists and is not a regular file a writer may replace (a device,
    a FIFO, a socket, a folder), else None. Renaming over /dev/null as root would replace it.

    Parameters
    ----------
    path : Path
        The path a writer would replace.

    Returns
    -------
    str or None
        E.g. ``"a directory"``; None for a regular file or a new path.
    """
    import stat

    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:  # a symlink loop, a name too long: not a path to write either
        return f"not usable ({exc.strerror or exc})"
    kinds = ((stat.S_ISDIR, "a directory"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
             (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"))
    return next((what for test, what in kinds if test(mode)), None if stat.S_ISREG(mode) else "not a regular file")


@contextmanager
def atomic_path(path: Path, suffix: str = ".tmp"):
    """Yield a temporary path beside ``path``; on success it is renamed over ``path`` (with the
    permissions ``open()`` would give), on any error or interrupt it is removed. A ``path`` that
    exists and is not a regular file is refused (``IsADirectoryError``/``OSError``), never replaced.

    Parameters
    ----------
    path : Path
        Final path.
    suffix : str
        Suffix of the temporary file.

    Yields
    ------
    Path
        The temporary path to write.
    """
    path = Path(path)
    kind = not_a_regular_file(path)
    if kind is not None:
        raise OSError(f"{path}: is {kind}; expected a regular file or a new path")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, umask_mode())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: Path, data: bytes) -> Path:
    """Write ``data`` to a temporary file beside ``path``, then rename it into place; a failure
    (full disk, file-size limit, read-only folder) raises ``OSError`` and leaves no file behind.

    Parameters
    ----------
    path : Path
        Final path.
    data : bytes
        Contents.

    Returns
    -------
    Path
        ``path``.
    """
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
    return Path(path)


@contextmanager
def atomic_hdf5(path: Path):
    """Yield a new HDF5 file built in memory; on success its image is written atomically to ``path``.

    The HDF5 C library never writes to disk here, so a full disk or a file-size limit is an
    ``OSError`` of Python's own write (one line), not a crash inside the library.

    Parameters
    ----------
    path : Path
        Final path.

    Yields
    ------
    h5py.File
        The in-memory file to fill.
    """
    import h5py

    path = Path(path)
    with h5py.File(f"<memory {path.name}>", "w", driver="core", backing_store=False) as f:
        yield f
        f.flush()
        image = f.id.get_file_image()
    atomic_write_bytes(path, image)


def remove_stale_temporaries(folder: Path, names) -> list[Path]:
    """Remove the temporary files (``.NAME.*.tmp``) that a killed writer of ``names`` left in ``folder``.

    Parameters
    ----------
    folder : Path
        Where the files were written.
    names : iterable of str
        Final file names.

    Returns
    -------
    list of Path
        The files removed.
    """
    removed = []
    folder = Path(folder)
    if folder.is_dir():
        for name in names:
            for tmp in folder.glob(f".{name}.*.tmp"):
                tmp.unlink(missing_ok=True)
                removed.append(tmp)
    return removed


def atomic_write_text(path: Path, text: str) -> Path:
    """Write ``text`` to a temporary file beside ``path``, then rename it into place.

    Parameters
    ----------
    path : Path
        Final path.
    text : str
        Contents, written as UTF-8.

    Returns
    -------
    Path
        ``path``.
    """
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def read_text(path: str | Path, what: str, error: type[Exception]) -> str:
    """The UTF-8 text of ``path``; a missing, unreadable or non-UTF-8 file raises ``error`` in one
    line naming the file and ``what`` it should be (e.g. "scenario file").

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What it should be, for messages.
    error : type of Exception
        The exception raised.

    Returns
    -------
    str
        The text.
    """
    p = Path(path)
    if not p.is_file():
        raise error(f"{p}: {what} not found" if not p.is_dir() else f"{p}: is a directory; expected a {what}")
    try:
        return p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{p}: {what} is not UTF-8 text (byte {exc.start}); expected a text file") from None
    except OSError as exc:
        raise error(f"{p}: cannot read {what}: {exc.strerror or exc}") from None


class RepeatedKeyError(ValueError):
    """A JSON object holds one key twice."""


def read_json(path: str | Path, what: str, error: type[Exception]):
    """The JSON value in ``path``; malformed JSON, nesting too deep for the parser, or an integer
    beyond Python's 4300-digit limit raise ``error`` in one line naming the file.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What it should be, for messages.
    error : type of Exception
        The exception raised (also for a key repeated in one object).

    Returns
    -------
    object
        The parsed value.
    """
    import json

    text = read_text(path, what, error)

    def unique(pairs):  # json keeps the last of a repeated key in silence: a hand edit could hide
        out = dict(pairs)
        if len(out) < len(pairs):
            keys = [k for k, _ in pairs]
            twice = next(k for i, k in enumerate(keys) if k in keys[:i])
            raise RepeatedKeyError(f"key {twice!r} appears twice in one object; expected each key once")
        return out

    try:
        return json.loads(text, object_pairs_hook=unique)
    except json.JSONDecodeError as exc:
        raise error(f"{path}:{exc.lineno}: {what} is not JSON ({exc.msg})") from None
    except RecursionError:
        raise error(f"{path}: {what} is nested too deep to read; expected the document a twin command wrote") from None
    except RepeatedKeyError as exc:
        raise error(f"{path}: {what}: {exc}") from None
    except ValueError as exc:  # an integer of more than 4300 digits
        raise error(f"{path}: {what} holds a value JSON readers refuse ({' '.join(str(exc).split())[:120]})") from None


def strict_json(value):
    """``value`` as plain JSON data: NumPy scalars and arrays as Python numbers and lists, tuples as
    lists, and every NaN or infinity as ``None`` (JSON has no NaN; a reader that meets a bare
    ``NaN`` token fails, and strict parsers are the norm outside Python).

    Parameters
    ----------
    value : object
        Nested dicts, lists, tuples, NumPy values, result dataclasses and plain values.

    Returns
    -------
    object
        The same structure as plain JSON data.
    """
    from twin.results import to_json  # one converter: typed results are written by the same code

    return to_json(value)
