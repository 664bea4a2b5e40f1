"""The ``twin`` command line: one module per subsystem's commands, all on one typer app.

Conventions for every subcommand: ``--json PATH`` writes the machine-readable result (``-`` for
stdout); bad input, usage errors included, exits with status 2 and one line naming what and where,
never a traceback; outputs are written atomically and never over an input.
"""

from __future__ import annotations

import atexit
import copy
import os
import signal
import sys
import threading
import traceback
from typing import Annotated

import typer
from typer.exceptions import TyperException

from twin.cli import diagnosis, field, fleet, model, package, plan, studies  # noqa: F401  (each registers its commands)
from twin.cli.common import app


def _version(value: bool) -> None:
    if value:
        from twin import __version__

        typer.echo(f"twin {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True, help="print the version")] = False,
    debug: Annotated[bool, typer.Option("--debug", help="print the traceback of an internal error (also TWIN_DEBUG=1)")] = False,
) -> None:
    """Digital twin of the temperature drift error (TDE) of MEMS accelerometers."""
    if debug:
        os.environ["TWIN_DEBUG"] = "1"


def _internal_error(exc: BaseException) -> None:
    """An error of ours, not of the input: exit 1 with one line; the traceback only when asked."""
    if os.environ.get("TWIN_DEBUG", "") not in ("", "0"):
        traceback.print_exception(exc)
    detail = " ".join(str(exc).split())[:300]
    typer.echo(f"twin: internal error: {type(exc).__name__}: {detail} (rerun with --debug for the traceback)",
               err=True)
    sys.exit(1)


_SIGINTS: list[int] = []


def _on_sigint(signum, frame) -> None:
    """Ctrl-C as usual (KeyboardInterrupt), remembered: a library that turns it into another
    error (an extension module's import fails with ImportError) still ends as 'interrupted'."""
    _SIGINTS.append(signum)
    signal.default_int_handler(signum, frame)


def _interrupted() -> None:
    typer.echo("twin: interrupted", err=True)
    sys.exit(130)


def main(argv: list[str] | None = None) -> None:
    """Console entry point: usage errors and our errors exit 2 with one line.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``twin`` (default: ``sys.argv[1:]``).

    Raises
    ------
    SystemExit
        Always: 0 on success, 1 for an internal error, 2 for bad input, 130 when interrupted.
    """
    _SIGINTS.clear()
    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.default_int_handler:
        try:
            signal.signal(signal.SIGINT, _on_sigint)
        except ValueError:  # not the main thread: leave Ctrl-C alone
            previous = None
    try:
        _main(argv)
    finally:
        if previous is signal.default_int_handler:
            signal.signal(signal.SIGINT, previous)


def console() -> None:
    """The ``twin`` executable (and ``python -m twin.cli``): :func:`main`, then the process ends
    without the interpreter's teardown of every module.

    That teardown frees scipy's, pandas' and pyarrow's objects one by one: 0.3-0.6 s after a
    ``twin compare`` on this machine kind, a tenth of the command (mypy ends the same way). The atexit
    handlers run and the standard streams are flushed first; while another non-daemon thread runs
    the interpreter exits as usual. :func:`main` itself only raises ``SystemExit``, so that a
    caller in Python keeps its process.

    Raises
    ------
    SystemExit
        Only when a thread other than the main one is still running (then as :func:`main`).
    """
    try:
        main()
        code: object = 0
    except SystemExit as exc:
        code = exc.code
    if any(t is not threading.main_thread() and not t.daemon for t in threading.enumerate()):
        sys.exit(code)
    if code is not None and not isinstance(code, int):  # sys.exit("text"): the text, status 1
        print(code, file=sys.stderr)
        code = 1
    atexit._run_exitfuncs()  # logging's and multiprocessing's handlers, weakref finalizers
    status = code or 0
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: status 120, as the interpreter's own exit
            status = status or 120
    os._exit(status)


def app_for(argv: list[str]) -> typer.Typer:
    """The app with only the command ``argv`` names (the whole app when it names none).

    Typer builds every registered command's parameters from its signature on each call, 50-80 ms
    for all nineteen, of which one command needs its own. Help, usage errors and options are the
    same.

    Parameters
    ----------
    argv : list of str
        The arguments after ``twin``.

    Returns
    -------
    typer.Typer
        The app to call with ``argv``.
    """
    from typer.main import get_command_name

    name = next((a for a in argv if not a.startswith("-")), None)
    chosen = [c for c in app.registered_commands if (c.name or get_command_name(c.callback.__name__)) == name]
    if len(chosen) != 1 or app.registered_groups:
        return app
    slim = copy.copy(app)
    slim.registered_commands = chosen
    return slim


def _main(argv: list[str] | None) -> None:
    """The command, with every way it can end turned into an exit status and at most one line."""
    if hasattr(signal, "SIGXFSZ"):  # a file-size limit: a write then fails with EFBIG (one line), not a kill
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    try:
        code = app_for(sys.argv[1:] if argv is None else argv)(args=argv, standalone_mode=False)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except (typer.Abort, KeyboardInterrupt):
        _interrupted()
    except TyperException as exc:  # usage: missing argument, unknown option, bad value: one line
        ctx = getattr(exc, "ctx", None)
        hint = f" (see 'twin {ctx.info_name} --help')" if ctx is not None and ctx.parent is not None else ""
        # no command at all: its "message" is the whole help text (plain, with rich markup off)
        # (typer vendors click, so the class is named rather than imported)
        bare = type(exc).__name__ == "NoArgsIsHelpError"
        message = "" if bare else " ".join(exc.format_message().split())
        message = message or "missing command (see 'twin --help')"
        typer.echo(f"twin: error: {message}{hint}", err=True)
        sys.exit(2)
    except MemoryError:
        typer.echo("twin: error: out of memory; shorten the run or lower its sample rate", err=True)
        sys.exit(2)
    except Exception as exc:  # noqa: BLE001  (the last line of defence: never a bare traceback)
        if _SIGINTS:
            _interrupted()
        _internal_error(exc)
    if code == 130:  # Ctrl-C inside a command: click swallows it into this code, say so in one line
        _interrupted()
    sys.exit(code if isinstance(code, int) else 0)
