"""Helpers shared by the tests in this folder: real data paths and scene-file text.

Kept apart from ``conftest.py`` because several test folders have a ``conftest.py`` and only one
module can be imported under that name.
"""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DONUT = ROOT / "examples" / "data" / "donut_v3dg.ply"
GUITAR = ROOT / "examples" / "data" / "guitar.compressed.ply"


def scene_text(ply: Path, n_frames: int = 10, n_grid: int = 24, engine: str = "taichi_mpm",
               extra_top: str = "", ground: bool = True, position_z: float = 0.05,
               material: str = 'name = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 300.0',
               engine_options: str = "{ threads = 1 }", extra_object: str = "") -> str:
    """A donut-drop scene file's text, parametrised for tests."""
    boundary = '[[boundary]]\nkind = "ground"\nheight = 0.0\nfriction = 0.5\n' if ground else ""
    return f"""
frame_dt = 0.0333333
n_frames = {n_frames}
{extra_top}
[engine]
name = "{engine}"
options = {engine_options}

[domain]
n_grid = {n_grid}

{boundary}
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, {position_z}]
{extra_object}
[object.material]
{material}
"""
