"""Issue 11 cases that need an engine or a process: bounded work, the default domain, signals, quiet output."""
import json
import os
import subprocess
import sys
import time

import pytest
from gasp_testing import scene_text, needs_package

from gasp_core.cli.main import main

ENGINE = "warp_mpm"
needs_package("gasp_warp_mpm")


def gasp(*argv, cwd=None, timeout=600):
    return subprocess.run([sys.executable, "-m", "gasp_core.cli.main", *map(str, argv)], capture_output=True, text=True,
                          cwd=cwd, timeout=timeout)


def one_error_line(err: str) -> str:
    lines = [l for l in err.splitlines() if l.strip() and not l.startswith("gasp: warning:")]  # gasp's own advice
    assert len(lines) == 1 and lines[0].startswith("gasp: error:"), err
    return lines[0]


@pytest.mark.parametrize("material, top", [
    ('name = "jelly"\nE = 1.0e12\nnu = 0.3\nrho = 300.0\nmodel = "elastic"', ""),   # 6e5 substeps per frame
    # (with model = "auto", the default, it takes the rigid limit: docs/rigid.md)
    ('name = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 300.0', "frame_dt = 3600.0"),  # 9e6 substeps per frame (an hour,
    # the range's top: gasp_core.seam.setup.FRAME_DT_RANGE; 1e6 s, this case before round 99, is now refused as a value)
])
def test_work_a_bad_value_asks_for_is_refused_at_once(tmp_path, donut_small, capsys, material, top):
    text = scene_text(donut_small, n_frames=2, engine=ENGINE, engine_options="{ }", material=material)
    if top:
        text = text.replace("frame_dt = 0.0333333", top)
    scene = tmp_path / "s.toml"
    scene.write_text(text)
    t0 = time.perf_counter()
    code = main(["simulate", str(scene), "-o", str(tmp_path / "o"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "max_substeps" in one_error_line(err)
    assert not (tmp_path / "o").exists()
    assert time.perf_counter() - t0 < 300          # not a hang (the old code never finished frame 1)


def test_raising_max_substeps_is_the_documented_way_out(tmp_path, donut_small, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine=ENGINE, engine_options="{ max_substeps = 5 }"))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "o"), "-q"]) == 2
    assert "exceeds max_substeps = 5" in capsys.readouterr().err


def test_an_object_dropped_from_a_height_fits_the_default_domain(tmp_path, donut_small, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine=ENGINE, engine_options="{ }",
                                position_z=0.3))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "o"), "-q"]) == 0, capsys.readouterr().err
    run = json.loads((tmp_path / "o" / "run.json").read_text())
    assert run["domain"]["hi"][2] > 0.3 + 0.09             # top of the donut inside the box


# SIGTERM, SIGINT and SIGHUP: tests/test_stop.py (issue 21: they keep a resumable partial now).


@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_no_library_chatter_and_engines_json_parses(tmp_path, donut_small, engine):
    needs_package(f"gasp_{engine}")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine=engine, engine_options="{ }"))
    r = gasp("simulate", scene, "-o", tmp_path / "o", "-q")
    assert r.returncode == 0, r.stderr
    # no banner, no CUDA warning, no RuntimeWarning: only gasp's own one-line warnings (n_grid 16: resolution)
    assert all(l.startswith("gasp: warning: object 'donut_small'") for l in r.stderr.splitlines()), r.stderr
    assert r.stdout.count("\n") == 1 and r.stdout.startswith("wrote 2 frames (frame 0 = the input)")
    r = gasp("engines", "--json")
    assert engine in json.loads(r.stdout)                   # stdout is JSON and nothing else
    env = dict(os.environ, GASP_LOAD_PLUGINS="taichi_mpm")
    r = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "engines", "--json"], capture_output=True, text=True,
                       env=env)
    if "taichi_mpm" in r.stdout:
        assert "taichi_mpm" in json.loads(r.stdout)         # Taichi's banner used to precede the JSON
