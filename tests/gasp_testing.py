"""Helpers shared by the tests in this folder: real data paths and scene-file text.

Kept apart from ``conftest.py`` because several test folders have a ``conftest.py`` and only one
module can be imported under that name.
"""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DONUT = ROOT / "examples" / "data" / "donut_v3dg.ply"
GUITAR = ROOT / "examples" / "data" / "guitar.compressed.ply"

#: The project's own example scenes (``examples/NAME.toml``), named one by one: the tests check these and only
#: these, so a scene a user saves in ``examples/`` (as the README suggests), half-written or not, is never
#: collected by the suite (issue 68). An example added to the project is added here.
BUNDLED_EXAMPLES = ("cup_drop", "donut_blender", "donut_jelly", "donut_mesh", "donut_on_guitar", "donut_shatter",
                    "donut_shatter_on_guitar", "donut_wind", "donut_wood", "guitar_flag_blender", "guitar_sand",
                    "kitchen_spinach", "kitchen_spinach_drop", "spot_mesh")


def bundled_examples(folder: Path | None = None) -> list[Path]:
    """The paths of :data:`BUNDLED_EXAMPLES` in ``folder`` (``examples/`` by default), sorted; whatever else lies
    there (a user's own scene) is left out."""
    folder = ROOT / "examples" if folder is None else Path(folder)
    return sorted(folder / f"{name}.toml" for name in BUNDLED_EXAMPLES)


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


#: Packages a plugin brings, by module: the plugin folder whose install line names them.
PLUGIN_OF = {"taichi": "taichi_mpm", "warp": "warp_mpm", "mujoco": "mujoco_flex", "newton": "newton",
             "genesis": "genesis", "bpy": "blender", "torch": "render_gsplat", "gsplat": "render_gsplat"}


def install_line(module: str) -> str:
    """The ``pip install`` line that brings ``module``: a core extra's (``gasp_core.errors.EXTRA_OF``), a plugin's
    (``gasp_warp_mpm``, or a package a plugin brings: ``warp``), else ``pip install <module>``."""
    from gasp_core.errors import EXTRA_OF, extra_hint
    from gasp_core.seam.plugins import install_hint
    top = module.split(".")[0]
    if top in EXTRA_OF:
        return extra_hint(EXTRA_OF[top])
    plugin = top[len("gasp_"):] if top.startswith("gasp_") else PLUGIN_OF.get(top)
    return (install_hint(plugin) if plugin else "") or f"python -m pip install {top}"


def needs_package(module: str):
    """``pytest.importorskip(module)``, the skip's reason naming the ``pip install`` line that brings it."""
    import pytest
    return pytest.importorskip(module, reason=f"{module} is not installed: {install_line(module)}")


def glb_nodes(path) -> dict:
    """``{node name: POSITION (k, 3) float32}`` of a GLB (pygltflib), for the export tests."""
    import numpy as np
    import pygltflib
    g = pygltflib.GLTF2().load(str(path))
    blob = g.binary_blob()
    out = {}
    for node in g.nodes:
        acc = g.accessors[g.meshes[node.mesh].primitives[0].attributes.POSITION]
        view = g.bufferViews[acc.bufferView]
        out[node.name] = np.frombuffer(blob, np.float32, acc.count * 3,
                                       view.byteOffset + (acc.byteOffset or 0)).reshape(-1, 3)
    return out


#: The brittle biscuit of the broken-run fixtures (tests/conftest.py ``broken_run``, tests/test_pieces_resume.py).
BRITTLE = 'name = "brittle"\nE = 2.0e5\nnu = 0.25\nrho = 300.0\ntensile_strength = 4.0e3\nfracture_energy = 5.0'


def biscuit_scene_text(ply, n_frames: int, speed: float) -> str:
    """A scene file's text: the brittle biscuit :data:`BRITTLE` (the PLY ``ply``) thrown down at ``speed`` m/s onto
    a ground in walls, warp_mpm on one thread, the grid contact, n_grid 32, ``n_frames`` frames of 1/30 s."""
    return f"""
frame_dt = 0.0333333
n_frames = {n_frames}
[engine]
name = "warp_mpm"
options = {{ threads = 1, contact = "grid" }}
[domain]
n_grid = 32
[[boundary]]
kind = "ground"
height = 0.0
friction = 0.5
[[boundary]]
kind = "walls"
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, 0.05]
velocity = [0.0, 0.0, {-speed}]
[object.material]
{BRITTLE}
"""


def set_pair_friction(monkeypatch, engine: str, mu) -> None:
    """Make grid engine ``engine``'s two-field contact take the pair friction ``mu(setup)`` (a callable of the setup,
    dimensionless) whatever the scene gives, the answer the tests read left as it is: a broken engine for the catches
    of the Coulomb checks (``field_friction`` in warp_mpm's fields module; taichi_mpm's copy of ``field_setup``:
    (bodies, mu, touch, rigid pair, flow touch))."""
    if engine == "warp_mpm":
        import gasp_warp_mpm.fields as wf
        monkeypatch.setattr(wf, "field_friction", mu)
    else:
        import gasp_taichi_mpm.engine as te
        real = te.field_setup
        monkeypatch.setattr(te, "field_setup", lambda view: (lambda f: (f[0], mu(view), *f[2:]))(real(view)))
