"""A large delimited log cut into pieces of whole lines and parsed on threads.

pandas' C parser lets go of the interpreter lock while it splits fields and converts numbers, so
pieces of one file parse side by side. Each piece is the file's header line followed by whole
lines, parsed with the options of the whole file: a row is read the same wherever the file is cut,
so the values are those of one parser reading the file (tests/test_readers.py, bit for bit).
The work on each piece's columns that needs no other piece (checks, unit conversion) runs on the
thread that parsed it; only the copy into the final arrays keeps the file's order.

The head is cut only where bytes and the parser's lines agree (:func:`data_head`); anywhere else
one parser reads on (:func:`read_on`), as before.
"""

from __future__ import annotations

import os
import re
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path


def data_head(path: Path, skip_lines: int, header: bool) -> tuple[bytes, int] | None:
    """The header line (``b""`` without one) and the byte offset of the first data row, when the
    file's head can be cut as the parser reads it; ``None`` otherwise (one parser reads on).

    Cut only where bytes and the parser's lines agree: no bare ``\\r`` line end and no quote
    before the data (either could make one of the parser's lines two of ours, or the reverse), and
    a header line that is not blank (the parser would skip it and take the next).

    Parameters
    ----------
    path : Path
        The delimited log.
    skip_lines : int
        Banner lines before the header (or the data).
    header : bool
        Whether a header line follows the banner.

    Returns
    -------
    (bytes, int) or None
        The header line with its line end, and where the data starts [bytes].
    """
    with path.open("rb") as f:
        head = [f.readline() for _ in range(skip_lines + header)]
        start = f.tell()
    text = b"".join(head)
    if not all(line.endswith(b"\n") for line in head) or b'"' in text or b"\r" in text.replace(b"\r\n", b""):
        return None
    if header and not head[-1].strip():
        return None
    return (head[-1] if header else b""), start


_CONTENT = re.compile(rb"[^\r\n]")


def _pieces(path: Path, head: bytes, start: int, piece_bytes: int) -> Iterator[bytes]:
    """``head`` followed by the next whole lines of ``path`` from ``start``, about ``piece_bytes`` at a
    time (the last piece ends where the file does); one copy of each line."""
    with path.open("rb") as f:
        pos = start
        while True:
            f.seek(pos)
            data = f.read(piece_bytes)
            if not data:
                return
            cut = data.rfind(b"\n") + 1
            while not cut:  # a line longer than a piece: read on to its end (or the file's)
                more = f.read(piece_bytes)
                data += more
                cut = data.rfind(b"\n") + 1 if more else len(data)
            pos += cut
            if _CONTENT.search(data, 0, cut):  # not only line ends, which the parser skips (spaces are a row)
                yield b"".join((head, memoryview(data)[:cut]))


def parse_threads() -> int:
    """Threads that parse a large log's pieces: the CPUs this process may run on, at most 4.

    Returns
    -------
    int
        Thread count (≥ 1).
    """
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return max(1, min(4, cpus))


@contextmanager
def parsed_pieces(path: Path, head: bytes, start: int, parse: Callable[[bytes], object], piece_bytes: int):
    """``path`` from ``start`` cut into pieces of whole lines, each behind ``head``, parsed on a pool
    of threads; the results in file order, at most one piece per thread waiting (bounded memory).

    Parameters
    ----------
    path : Path
        The delimited log.
    head : bytes
        The header line each piece starts with (``b""`` without one: :func:`data_head`).
    start : int
        Byte offset of the first data row.
    parse : callable
        ``parse(piece)``: the result of one piece (bytes: the header line, then whole lines).
    piece_bytes : int
        About how many bytes of lines each piece holds.

    Yields
    ------
    iterator
        The pieces' results, in file order; a piece's error is raised where its result would be.
    """
    threads = parse_threads()
    pool = ThreadPoolExecutor(threads, thread_name_prefix="parse")

    def results():
        pending = deque()
        for piece in _pieces(path, head, start, piece_bytes):
            pending.append(pool.submit(parse, piece))
            if len(pending) > threads:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()

    try:
        yield results()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def read_on(open_reader: Callable[[], object]) -> Callable:
    """``open_frames`` of one parser reading the file on, chunk after chunk, in this thread.

    Parameters
    ----------
    open_reader : callable
        Returns the parser's chunk iterator as a context manager (``pandas.read_csv(..., chunksize=)``).

    Returns
    -------
    callable
        ``open_frames(prepare)``: a context manager of ``prepare(frame)`` per chunk.
    """
    @contextmanager
    def open_frames(prepare: Callable) -> Iterator[Iterable]:
        with open_reader() as reader:
            yield map(prepare, reader)

    return open_frames


def in_pieces(path: Path, head: bytes, start: int, parse: Callable[[bytes], object],
              piece_bytes: int) -> Callable:
    """``open_frames`` of the file cut into pieces parsed on threads (:func:`parsed_pieces`).

    Parameters
    ----------
    path, head, start, piece_bytes
        As :func:`parsed_pieces`.
    parse : callable
        ``parse(piece)``: the parser's frame of one piece (bytes).

    Returns
    -------
    callable
        ``open_frames(prepare)``: a context manager of ``prepare(frame)`` per piece, ``prepare`` run
        on the thread that parsed the piece.
    """
    return lambda prepare: parsed_pieces(path, head, start, lambda piece: prepare(parse(piece)), piece_bytes)
