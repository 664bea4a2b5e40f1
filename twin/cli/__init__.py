"""The ``twin`` command line: one module per subsystem's commands, all on one typer app.

Conventions for every subcommand: ``--json PATH`` writes the machine-readable result (``-`` for
stdout); bad input, usage errors included, exits with status 2 and one line naming what and where,
never a traceback; outputs are written atomically and never over an input.
"""

from __future__ import annotations

import sys
from typing import Annotated

import typer
from typer.exceptions import TyperException

from twin.cli import diagnosis, field, model, studies  # noqa: F401  (each registers its commands)
from twin.cli.common import app


def _version(value: bool) -> None:
    if value:
        from twin import __version__

        typer.echo(f"twin {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True, help="print the version")] = False,
) -> None:
    """Digital twin of the temperature drift error (TDE) of MEMS accelerometers."""


def main(argv: list[str] | None = None) -> None:
    """Console entry point: usage errors and our errors exit 2 with one line."""
    try:
        code = app(args=argv, standalone_mode=False)  # returns a command's exit code (typer.Exit)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except typer.Abort:
        typer.echo("twin: interrupted", err=True)
        sys.exit(130)
    except KeyboardInterrupt:
        typer.echo("twin: interrupted", err=True)
        sys.exit(130)
    except TyperException as exc:  # usage: missing argument, unknown option, bad value: one line
        ctx = getattr(exc, "ctx", None)
        hint = f" (see 'twin {ctx.info_name} --help')" if ctx is not None and ctx.parent is not None else ""
        typer.echo(f"twin: error: {' '.join(exc.format_message().split())}{hint}", err=True)
        sys.exit(2)
    sys.exit(code if isinstance(code, int) else 0)
