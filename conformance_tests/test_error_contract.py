"""The error contract through ``gasp simulate``: an engine that raises outside the contract is a bug
in the engine, reported in one line (no traceback) with exit status 4, and nothing is written.

The buggy engine is a hand-written installed distribution (``*.dist-info/entry_points.txt`` on
``sys.path``, as ``tests/test_plugins.py`` does), loaded alone through ``GASP_LOAD_PLUGINS``; the
scene is ``examples/donut_jelly.toml``'s real donut (city-super/V3DG, MIT).
"""
from __future__ import annotations

import re

import textwrap
from pathlib import Path

import pytest

from gasp_core.cli import main as cli
from gasp_core.seam import plugins

ROOT = Path(__file__).resolve().parents[1]
DONUT = ROOT / "examples" / "data" / "donut_v3dg.ply"

PLUGIN = '''
import numpy as np
from gasp_core.seam.engine import Capabilities, EngineInfo
from gasp_core.seam.plugins import hookimpl

WHERE = "{where}"

class Engine:
    def __init__(self, setup):
        if WHERE == "build":
            raise ValueError("could not broadcast input array from shape (3,) into shape (2,)")
        self.x = setup.x.copy()
    def step_frame(self):
        raise ZeroDivisionError("float division by zero")
    def positions(self):
        return self.x
    def velocities(self):
        return np.zeros_like(self.x)
    def stats(self):
        return {{}}
    def close(self):
        pass

@hookimpl
def gasp_engines():
    return [EngineInfo(name="buggy", factory=Engine,
                       capabilities=Capabilities(materials=frozenset({{"jelly"}}), boundaries=frozenset({{"ground"}})))]
'''


@pytest.fixture
def buggy_engine(tmp_path, monkeypatch):
    """Install the buggy engine (failing at ``where``) for this test only."""
    def install(where: str):
        module = f"gasp_buggy_{where}"  # one module per case: a module imported once stays in sys.modules
        (tmp_path / f"{module}.py").write_text(textwrap.dedent(PLUGIN.format(where=where)))
        info = tmp_path / "gasp_buggy-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: gasp-buggy\nVersion: 0.1\n")
        (info / "entry_points.txt").write_text(f"[gasp]\nbuggy = {module}\n")
        monkeypatch.syspath_prepend(str(tmp_path))
        monkeypatch.setenv("GASP_LOAD_PLUGINS", "buggy")
        plugins.get_plugin_manager.cache_clear()
    yield install
    plugins.get_plugin_manager.cache_clear()


def _scene(tmp_path: Path) -> Path:
    text = (ROOT / "examples" / "donut_jelly.toml").read_text()
    text = text.replace('name = "taichi_mpm"', 'name = "buggy"').replace("data/donut_v3dg.ply", DONUT.as_posix())
    text = text.replace("n_grid = 64", "n_grid = 40")   # 8 cells across the donut: no resolution warning
    # the buggy engine declares no features: drop the donut's physical damping (feature 'viscosity')
    text = re.sub(r"^viscosity = .*\n(?:[ \t]+#.*\n)*", "", text, flags=re.M)
    path = tmp_path / "donut_buggy.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("where", ["build", "frame"])
def test_engine_bug_exits_4_with_one_line(where, buggy_engine, tmp_path, capsys):
    buggy_engine(where)
    out = tmp_path / "out"
    rc = cli.main(["simulate", str(_scene(tmp_path)), "-o", str(out), "--frames", "1", "-q"])
    err = capsys.readouterr().err.strip()
    assert rc == 4, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    expected = "ValueError" if where == "build" else "ZeroDivisionError"
    assert err.startswith("gasp: error: engine 'buggy' (gasp-buggy)") and expected in err, err
    assert "bug in the engine" in err and (where == "build" or "frame 1" in err), err
    saved = err.split("traceback saved to ")[-1].rstrip(")").strip()
    assert Path(saved).is_file() and expected in Path(saved).read_text(), err  # the full traceback is kept
    Path(saved).unlink()
    assert not out.exists(), "a failed run left output behind"
