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
