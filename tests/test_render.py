"""Off-screen rendering works headless: not blank, temperature-dependent, right frame count."""

import json
import numpy as np
import pytest

from schemas import check_schema
from conftest import run_cli

iio = pytest.importorskip("imageio.v3")


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    d = tmp_path_factory.mktemp("render")
    out = {}
    for t in (-20, 50):
        r = run_cli("render", "scenarios/paper_iis328dq.yaml", "--temperature", str(t), "--exaggeration", "2000",
                    "-o", str(d / f"comb_{t}.png"))
        assert r.returncode == 0, r.stderr
        out[t] = iio.imread(d / f"comb_{t}.png").astype(float)
    return out


def test_png_is_not_blank(images):
    for img in images.values():
        assert img.ndim == 3 and img.shape[0] > 100
        assert img.var() > 100  # a blank (uniform) image has variance 0


def test_two_temperatures_give_different_images(images):
    diff = np.abs(images[-20] - images[50])
    assert diff.mean() > 1.0  # mean absolute pixel difference on a 0-255 scale


def test_sweep_gif_has_requested_frames(tmp_path):
    r = run_cli("render", "scenarios/paper_iis328dq.yaml", "--sweep", "-20:50:35", "-o", str(tmp_path / "s.gif"),
                "--json", "-")
    assert r.returncode == 0, r.stderr
    check_schema(json.loads(r.stdout), "render")
    frames = iio.imread(tmp_path / "s.gif", index=None)
    assert frames.shape[0] == 3  # -20, 15, 50
    assert not np.array_equal(frames[0], frames[-1])


def test_bad_render_arguments_exit_2(tmp_path):
    r = run_cli("render", "scenarios/paper_iis328dq.yaml", "--sweep", "a:b", "-o", str(tmp_path / "s.gif"))
    assert r.returncode == 2 and "START:STOP:STEP" in r.stderr
    r = run_cli("render", "scenarios/paper_iis328dq.yaml", "--reading", "Q", "-o", str(tmp_path / "s.png"))
    assert r.returncode == 2 and "--reading" in r.stderr
