"""Issue 68: the hostile corpus's new cases that main got wrong, each as the user met it.

Engine options checked before the substep estimate uses them, brittle values beyond the working precision,
``gasp studio`` on the ``engine = "..."`` shorthand, a selection that holds every row, the studio's moving-piece
search on coincident Gaussians, corrupt or missing pieces sidecars, an unwritable Warp kernel cache, ``gasp info``
on a NaN camera, and the new user's ``--overwrite`` and dynamic-model findings. Every case takes seconds.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package, scene_text

from gasp_core.cli.main import main
from gasp_core.errors import SceneError

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "examples" / "data"


def one_error(err: str, code: int, expected: int = 2) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == expected and len(lines) == 1 and lines[0].startswith("gasp: error:"), (code, err)
    assert "Traceback" not in err
    return lines[0]


# ------------------------------------------------ 1. engine options checked before the substep estimate


@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
@pytest.mark.parametrize("option, expected", [
    ("cfl = 0", "option cfl=0"), ("dt = 0.0", "option dt=0.0"), ("n_substeps = 0", "option n_substeps=0"),
    ('max_substeps = "100"', "option max_substeps='100'"),
    ("dt = 1e-320", "exceeds max_substeps"), ("cfl = 1e-320", "exceeds max_substeps")])
def test_an_engine_option_out_of_range_is_one_line_naming_it(tmp_path, donut_small, capsys, engine, option,
                                                              expected):
    needs_package(f"gasp_{engine}")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine=engine,
                                engine_options=f"{{ {option} }}"))
    code = main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert expected in line and f"engine '{engine}'" in line
    assert not (tmp_path / "out").exists()
