"""The CLI's last line of defence: an internal error is one line and exit 1; ``--debug`` shows the traceback."""

import pytest

import twin.cli.model
from twin.cli import main


def _boom(*_args, **_kwargs):
    raise RuntimeError("boom\nsecond line")


def _run(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    return exc.value.code, capsys.readouterr().err


def test_an_internal_error_is_one_line_with_exit_1(monkeypatch, capsys):
    monkeypatch.setattr(twin.cli.model, "emit_json", _boom)
    monkeypatch.delenv("TWIN_DEBUG", raising=False)
    code, err = _run(["paper", "--json", "-"], capsys)
    assert code == 1
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("twin: internal error: RuntimeError: boom second line")
    assert "--debug" in err


def test_debug_prints_the_traceback(monkeypatch, capsys):
    monkeypatch.setattr(twin.cli.model, "emit_json", _boom)
    monkeypatch.delenv("TWIN_DEBUG", raising=False)
    code, err = _run(["--debug", "paper", "--json", "-"], capsys)
    monkeypatch.delenv("TWIN_DEBUG", raising=False)  # --debug sets it for the process
    assert code == 1
    assert "Traceback" in err and "_boom" in err
    assert err.rstrip().splitlines()[-1].startswith("twin: internal error: RuntimeError")


def test_a_usage_error_is_one_line_with_exit_2(capsys):
    code, err = _run(["run", "--no-such-option"], capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("twin: error:")


def test_the_executable_ends_without_teardown_but_with_status_output_and_atexit(tmp_path):
    """``python -m twin.cli`` (the ``twin`` executable's entry, :func:`twin.cli.console`) keeps the
    exit status, the JSON it printed and the atexit handlers while skipping the module teardown."""
    import json
    import subprocess
    import sys

    code = ("import atexit, sys; atexit.register(lambda p=sys.argv[1]: open(p, 'w').write('ran')); "
            "sys.argv = ['twin'] + sys.argv[2:]; from twin.cli import console; console()")
    marker = tmp_path / "atexit.txt"
    ok = subprocess.run([sys.executable, "-c", code, str(marker), "paper", "--json", "-"],
                        capture_output=True, text=True)
    assert ok.returncode == 0 and json.loads(ok.stdout)["items"] and marker.read_text() == "ran"
    bad = subprocess.run([sys.executable, "-m", "twin.cli", "compare", str(tmp_path / "none.yaml"), "x.csv"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "none.yaml" in bad.stderr


@pytest.mark.parametrize("argv", [["compare", "--help"], ["--debug", "paper", "--help"], ["fleet-simulate", "--help"]])
def test_one_command_is_built_with_the_same_help_as_in_the_whole_app(argv, capsys):
    """``twin CMD`` builds only CMD (the others' parameters are not read from their signatures);
    its help is the one the whole app prints, and ``twin --help`` still lists every command."""
    from twin.cli import app_for
    from twin.cli.common import app

    name = next(a for a in argv if not a.startswith("-"))
    slim = app_for(argv)
    assert slim is not app and [c.callback for c in slim.registered_commands] == \
        [c.callback for c in app.registered_commands if c.callback.__name__.replace("_", "-") == name]
    texts = []
    for chosen in (slim, app):
        with pytest.raises(SystemExit) as exc:
            chosen(args=argv, prog_name="twin")
        texts.append((exc.value.code, capsys.readouterr().out))
    assert texts[0] == texts[1] and texts[0][0] == 0 and f"Usage: twin {name}" in texts[0][1]
    assert app_for(["--help"]) is app and app_for(["no-such-command"]) is app
    code, err = _run(["no-such-command"], capsys)
    assert code == 2 and "No such command" in err
