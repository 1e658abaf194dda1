"""Bad-input corpus: every case is one ``gasp: error:`` line, exit status 2, and nothing written.

Each case builds its bad file(s) from the real donut (every 16th Gaussian) or the real guitar, runs
the CLI in-process (``gasp_core.cli.main.main``) and checks:

* exit status 2;
* stderr is exactly one line, starting ``gasp: error:``, naming what is wrong (the needles);
* no traceback, no RuntimeWarning (numpy chatter) raised while failing;
* no file or folder appears (no output folder, no partial folder, no PLY with NaN).

A few cases also run as a subprocess (the console entry point, real stderr).
"""
from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import GUITAR, scene_text, needs_package
from plyfile import PlyData, PlyElement

from gasp_core.cli.main import main
from gasp_core.scene.spec import load_scene


@pytest.fixture(scope="module")
def donut_vertex(donut_small):
    return PlyData.read(str(donut_small))["vertex"].data


def write_vertex(path: Path, data: np.ndarray) -> Path:
    PlyData([PlyElement.describe(data, "vertex")], byte_order="<").write(str(path))
    return path


def edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def snapshot(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


# ------------------------------------------------------------------------------------ the corpus
# Each builder gets (folder, donut_small PLY path, donut vertex array) and returns the argv.
CASES: dict[str, tuple] = {}


def case(name: str, *needles: str):
    def register(fn):
        CASES[name] = (fn, needles)
        return fn
    return register


def simulate(d: Path, text: str) -> list[str]:
    scene = d / "scene.toml"
    scene.write_text(text)
    return ["simulate", str(scene), "-o", str(d / "out"), "-q"]


def with_ply(d: Path, data: np.ndarray, name: str = "bad.ply", **kw) -> list[str]:
    return simulate(d, scene_text(write_vertex(d / name, data), **kw))


# --- issue 11: tracebacks before


@case("scene-is-directory", "is a directory")
def _(d, ply, v):
    (d / "scene.toml").mkdir()
    return ["simulate", str(d / "scene.toml"), "-o", str(d / "out"), "-q"]


@case("scene-not-utf8", "UTF-8", "scene.toml")
def _(d, ply, v):
    (d / "scene.toml").write_bytes(scene_text(ply).encode("utf-16"))
    return ["simulate", str(d / "scene.toml"), "-o", str(d / "out"), "-q"]


@case("file-is-integer", "file = 5", "string")
def _(d, ply, v):
    return simulate(d, edit(scene_text(ply), f'file = "{ply}"', "file = 5"))


@case("material-name-is-list", "material.name", "['jelly']", "one of")
def _(d, ply, v):
    return simulate(d, scene_text(ply, material='name = ["jelly"]'))


@case("material-key-unused", "material 'jelly' does not use ['yield_stress']", "metal",
      "['E', 'friction', 'model', 'name', 'nu', 'restitution', 'rho', 'viscosity']")
def _(d, ply, v):   # issue 33: a key the chosen material ignores was accepted silently
    return simulate(d, scene_text(ply, material='name = "jelly"\nyield_stress = 5e3'))


@case("boundary-kind-is-list", "kind", "['ground']", "one of")
def _(d, ply, v):
    return simulate(d, edit(scene_text(ply), 'kind = "ground"', 'kind = ["ground"]'))


@case("engine-is-integer", "engine = 5", "engine name")
def _(d, ply, v):
    text = edit(scene_text(ply), '[engine]\nname = "taichi_mpm"\noptions = { threads = 1 }', "")
    return simulate(d, "engine = 5\n" + text)


@case("boundary-is-list-of-integers", "boundary = [1, 2]", "array of tables")
def _(d, ply, v):
    return simulate(d, "boundary = [1, 2]\n" + scene_text(ply, ground=False))


@case("options-is-string", "engine.options", "'threads=1'", "table")
def _(d, ply, v):
    return simulate(d, scene_text(ply, engine_options='"threads=1"'))


@case("n-grid-is-string", "domain.n_grid", "'abc'", "integer")
def _(d, ply, v):
    return simulate(d, edit(scene_text(ply), "n_grid = 24", 'n_grid = "abc"'))


@case("ply-with-zero-gaussians", "empty.ply", "0 Gaussians")
def _(d, ply, v):
    return with_ply(d, v[:0], "empty.ply")


@case("info-list-property", "list.ply", "'x'", "list")
def _(d, ply, v):
    names = [n for n in v.dtype.names if n != "x"]
    lines = ["ply", "format ascii 1.0", "element vertex 2", "property list uchar float x",
             *[f"property float {n}" for n in names], "end_header"]
    for r in v[:2]:
        lines.append("2 0.1 0.2 " + " ".join(f"{float(r[n]):.6g}" for n in names))
    (d / "list.ply").write_text("\n".join(lines) + "\n")
    return ["info", str(d / "list.ply")]


@case("core-fraction-string", "core_fraction", "'half'", "(0, 1]")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_object='core_fraction = "half"'))


@case("core-fraction-above-one", "core_fraction", "1.5", "(0, 1]")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_object="core_fraction = 1.5"))


# --- issue 11: wrong or silent before


@case("fixed-region-lo-above-hi", "fixed_region", "'hi' must exceed 'lo'")
def _(d, ply, v):
    b = '[[boundary]]\nkind = "fixed_region"\nlo = [0.1, 0.1, 0.1]\nhi = [-0.1, -0.1, 0.0]\n'
    return simulate(d, edit(scene_text(ply), "[[object]]", b + "\n[[object]]"))


@case("n-grid-is-float", "domain.n_grid", "24.9", "integer")
def _(d, ply, v):
    return simulate(d, scene_text(ply, n_grid=24.9))


@case("particles-per-cell-is-float", "particles_per_cell", "8.5", "integer")
def _(d, ply, v):
    return simulate(d, edit(scene_text(ply), "n_grid = 24", "n_grid = 24\nparticles_per_cell = 8.5"))


@case("engine-is-unknown-name", "no_such_engine", "installed engines")
def _(d, ply, v):
    text = edit(scene_text(ply), '[engine]\nname = "taichi_mpm"\noptions = { threads = 1 }', "")
    return simulate(d, 'engine = "no_such_engine"\n' + text)


@case("frames-zero", "--frames", "'0'", "positive integer")
def _(d, ply, v):
    return simulate(d, scene_text(ply)) + ["--frames", "0"]


@case("frames-negative", "--frames", "'-1'", "positive integer")
def _(d, ply, v):
    return simulate(d, scene_text(ply)) + ["--frames=-1"]


@case("compare-frames-zero", "--frames", "positive integer")
def _(d, ply, v):
    return ["compare", str(simulate(d, scene_text(ply))[1]), "-o", str(d / "out"), "--frames", "0"]


@case("scale-1e30", "scale", "1e+30", "[1e-06, 1e+06]")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_object="scale = 1e30"))


@case("position-1e30", "position", "1e+30", "1e+06 m")
def _(d, ply, v):
    return simulate(d, edit(scene_text(ply), "position = [0.0, 0.0, 0.05]", "position = [1e30, 0.0, 0.05]"))


@case("velocity-1e30", "velocity", "1e+30", "m/s")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_object="velocity = [0.0, 0.0, -1e30]"))


@case("gravity-1e30", "gravity", "1e+30", "m/s^2")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_top="gravity = [0.0, 0.0, -1e30]"))


@case("ply-positions-1e28", "far.ply", "'x'", "1e+18")
def _(d, ply, v):
    w = v.copy()
    w["x"] = w["x"] * np.float32(1e28)
    return with_ply(d, w, "far.ply")


@case("ply-positions-beyond-world", "far.ply", "1e+06 m", "scale")
def _(d, ply, v):
    w = v.copy()
    w["x"] = w["x"] * np.float32(1e8)  # finite in float32, but 1e7 m across once placed
    return with_ply(d, w, "far.ply")


@case("ply-log-scale-100", "big.ply", "'scale_1'", "at vertex 7")
def _(d, ply, v):
    w = v.copy()
    w["scale_1"][7] = 100.0  # exp(100) = 2.7e43: beyond float32
    return with_ply(d, w, "big.ply")


@case("compressed-chunk-bounds-1e38", "far.compressed.ply", "'max_x'", "chunk 0")
def _(d, ply, v):
    src = PlyData.read(str(GUITAR))
    chunk = src["chunk"].data.copy()
    chunk["max_x"][0] = 1e38
    out = d / "far.compressed.ply"
    PlyData([PlyElement.describe(chunk, "chunk"), PlyElement.describe(src["vertex"].data, "vertex")],
            byte_order="<").write(str(out))
    return simulate(d, scene_text(out))


@case("nan-opacity", "nan.ply", "'opacity'", "nan", "vertex 5")
def _(d, ply, v):
    w = v.copy()
    w["opacity"][5] = np.nan
    return with_ply(d, w, "nan.ply")


@case("inf-f-dc", "inf.ply", "'f_dc_1'", "inf", "vertex 9")
def _(d, ply, v):
    w = v.copy()
    w["f_dc_1"][9] = np.inf
    return with_ply(d, w, "inf.ply")


@case("info-on-directory", "is a directory")
def _(d, ply, v):
    (d / "folder.ply").mkdir()
    return ["info", str(d / "folder.ply")]


@case("scene-file-is-directory", "file", "is a directory")
def _(d, ply, v):
    (d / "sub").mkdir()
    return simulate(d, edit(scene_text(ply), f'file = "{ply}"', 'file = "sub"'))


# --- found while building the corpus: silently coerced or tracebacks before


@case("fill-is-string", "fill", "'false'", "true or false")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_object='fill = "false"'))  # bool("false") was True


@case("recentre-is-string", "recentre", "'no'", "true or false")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_object='recentre = "no"'))


@case("gravity-has-boolean", "gravity", "True", "3 finite numbers")
def _(d, ply, v):
    return simulate(d, scene_text(ply, extra_top="gravity = [0.0, 0.0, true]"))


@case("object-is-single-table", "object", "array of tables")
def _(d, ply, v):
    return simulate(d, edit(scene_text(ply), "[[object]]", "[object]").replace("[object.material]",
                                                                               "[object.material]"))


@case("domain-is-array", "domain", "table")
def _(d, ply, v):
    text = edit(scene_text(ply), "[domain]\nn_grid = 24", "")
    return simulate(d, "domain = [24]\n" + text)


@case("output-is-integer", "output", "string")
def _(d, ply, v):
    scene = d / "scene.toml"
    scene.write_text("output = 5\n" + scene_text(ply))
    return ["simulate", str(scene), "-q"]


@case("padding-1e30", "domain.padding", "1e+30")
def _(d, ply, v):
    return simulate(d, edit(scene_text(ply), "n_grid = 24", "n_grid = 24\npadding = 1e30"))


@case("height-on-walls", "height", "walls")
def _(d, ply, v):
    return simulate(d, scene_text(ply, ground=False) + '\n[[boundary]]\nkind = "walls"\nheight = 0.3\n')


@case("packed-position-float", "packed_position", "uint32")
def _(d, ply, v):
    src = PlyData.read(str(GUITAR))
    vert = src["vertex"].data
    dt = [(n, "<f4" if n == "packed_position" else vert.dtype[n]) for n in vert.dtype.names]
    w = np.empty(len(vert), dtype=dt)
    for n in vert.dtype.names:
        w[n] = vert[n]
    w["packed_position"][0] = np.nan
    out = d / "floatpacked.ply"
    PlyData([PlyElement.describe(src["chunk"].data, "chunk"), PlyElement.describe(w, "vertex")],
            byte_order="<").write(str(out))
    return ["info", str(out)]


@case("frames-not-a-number", "--frames", "'ten'")
def _(d, ply, v):
    return simulate(d, scene_text(ply)) + ["--frames", "ten"]


# --- issue 21: tracebacks, misleading messages and silent runs before


@case("scale-1e-6", "object 'bad'", "less than 1 grid cell(s)", "scale")
def _(d, ply, v):
    return with_ply(d, v, extra_object="scale = 1e-6")            # was IndexError in the fill


@case("domain-1e6-n-grid-16", "less than 1 grid cell(s)", "dx = 1.25e+05 m", "n_grid")
def _(d, ply, v):
    box = "n_grid = 16\nlo = [-1e6, -1e6, -1e6]\nhi = [1e6, 1e6, 1e6]"
    return simulate(d, edit(scene_text(ply), "n_grid = 24", box))


@case("rho-1e300-in-f32", "rho = 1e+300", "precision 'f32'", "1.8e+19", "f64")
def _(d, ply, v):
    # n_grid 40: the donut spans 8 cells across its thickness, so no resolution warning joins the error line
    return simulate(d, scene_text(ply, n_grid=40, material='name = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 1e300'))


@case("output-below-a-device", "/dev/full", "is not a folder")
def _(d, ply, v):
    return simulate(d, scene_text(ply))[:3] + ["/dev/full/x", "-q"]


@case("output-below-a-file", "in.ply", "is not a folder")
def _(d, ply, v):
    inp = write_vertex(d / "in.ply", v)
    return simulate(d, scene_text(inp))[:3] + [str(inp / "out"), "-q"]


@case("object-is-a-fifo", "fifo.ply", "not a regular file")
def _(d, ply, v):
    os.mkfifo(d / "fifo.ply")
    return simulate(d, scene_text(d / "fifo.ply"))                 # was "no such file"


@case("object-is-dev-zero", "/dev/zero", "not a regular file")
def _(d, ply, v):
    return simulate(d, scene_text(Path("/dev/zero")))


@case("scene-is-a-fifo", "scene.toml", "not a regular file")
def _(d, ply, v):
    os.mkfifo(d / "scene.toml")                                    # reading it hung
    return ["simulate", str(d / "scene.toml"), "-o", str(d / "out"), "-q"]


@case("n-frames-1e9", "1,000,000,000 frames", "beyond the bound of 24 h", "--yes")
def _(d, ply, v):
    needs_package("gasp_warp_mpm")
    return simulate(d, scene_text(ply, n_frames=1_000_000_000, n_grid=40, engine="warp_mpm", engine_options="{ }"))


@case("compare-unknown-engine", "'nope'", "not an installed engine", "warp_mpm")
def _(d, ply, v):
    needs_package("distributed")
    return ["compare", simulate(d, scene_text(ply))[1], "--engines", "warp_mpm,nope", "-o", str(d / "cmp")]


# --- issue 34: tracebacks before


@case("object-is-a-symlink-loop", "loop.ply", "symlink loop")
def _(d, ply, v):
    (d / "loop.ply").symlink_to("loop.ply")                        # was RuntimeError from Path.resolve
    return simulate(d, scene_text(d / "loop.ply"))


@case("inline-table-500-deep", "scene.toml", "nested too deep")
def _(d, ply, v):
    deep = "x = " + "{a = " * 500 + "1" + "}" * 500 + "\n"       # was RecursionError in tomllib
    return simulate(d, deep + scene_text(ply))


@case("object-below-the-ground", "object 'bad'", "below the ground at height 0", "raise the object's position")
def _(d, ply, v):
    return with_ply(d, v, position_z=-0.5, n_grid=40)              # was "enlarge [domain]" (n_grid 40: no resolution warning)


@case("ground-above-the-object", "object 'bad'", "below the ground at height 0.5", "lower the ground's height")
def _(d, ply, v):
    return simulate(d, edit(scene_text(write_vertex(d / "bad.ply", v), n_grid=40), "height = 0.0", "height = 0.5"))


@case("object-below-an-explicit-domain-above-the-ground", "object 'bad'", "outside [domain] lo/hi",
      "enlarge [domain] lo/hi")
def _(d, ply, v):
    # issue 41: was "start below the ground at height 0 m (lowest at z = ...)", though every point is above the ground
    text = edit(scene_text(write_vertex(d / "bad.ply", v), n_grid=40), "n_grid = 40",
                "n_grid = 40\nlo = [-0.15, -0.15, 0.1]\nhi = [0.15, 0.15, 0.4]")
    return simulate(d, text)


@case("passive-every-past-the-surface", "passive_every=128", "[1, 16]")
def _(d, ply, v):
    # issue 41: accepted up to the substep limit, and the Gaussians drifted 940 mm from a body that moved 52 mm
    return simulate(d, scene_text(write_vertex(d / "bad.ply", v), n_grid=40,
                                  engine_options="{ threads = 1, passive_every = 128 }"))


@case("info-on-a-mesh-points-to-mesh-mode", "box.obj", "a triangle mesh (.obj)", "mesh = \"box.obj\"")
def _(d, ply, v):
    # issue 42: "unknown file format (first bytes b'# ht')", with no word of mesh mode
    (d / "box.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    return ["info", str(d / "box.obj")]


@case("splats-10m-on-a-20cm-object", "every Gaussian's centre is above it", "on an object 0.208 m across",
      "file's scales")
def _(d, ply, v):
    w = v.copy()
    w["scale_1"], w["scale_2"] = np.log(10.0), np.log(10.0)        # was "enlarge [domain]"
    return with_ply(d, w)


@case("info-size-1e400m", "--size", "1e400m", "1e6 m")
def _(d, ply, v):
    return ["info", str(write_vertex(d / "in.ply", v)), "--size", "1e400m"]   # blamed "scale = inf"


@case("info-one-zero-size-splat", "one.ply", "1 Gaussian(s) span 0 units")
def _(d, ply, v):
    w = v[:1].copy()
    for n in ("scale_0", "scale_1", "scale_2"):
        w[n] = -np.inf                                              # was "fill spacing h must be > 0"
    return ["info", str(write_vertex(d / "one.ply", w))]


def run_case(tmp_path: Path, argv: list[str], capsys) -> tuple[int, str, list]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            code = main(argv)
        except SystemExit as e:  # argparse
            code = e.code
    _, err = capsys.readouterr()
    return code, err, [w for w in caught if issubclass(w.category, RuntimeWarning)]


@pytest.mark.parametrize("name", list(CASES))
def test_bad_input_is_one_clean_error(name, tmp_path, capsys, donut_small, donut_vertex):
    build, needles = CASES[name]
    argv = build(tmp_path, donut_small, donut_vertex)
    before = snapshot(tmp_path)
    code, err, runtime_warnings = run_case(tmp_path, argv, capsys)
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("gasp: error:"), err
    assert "Traceback" not in err
    for n in needles:
        assert n in lines[0], (n, lines[0])
    assert not runtime_warnings, [str(w.message) for w in runtime_warnings]
    assert snapshot(tmp_path) == before  # no output folder, no partial folder, no NaN frame


def test_corpus_size():
    """The README's reliability section quotes this count."""
    assert len(CASES) >= 52


# ------------------------------------------------------------------- through the real entry point


@pytest.mark.parametrize("name", ["scene-not-utf8", "frames-zero", "nan-opacity", "material-key-unused"])
def test_bad_input_as_subprocess(name, tmp_path, donut_small, donut_vertex):
    build, needles = CASES[name]
    argv = build(tmp_path, donut_small, donut_vertex)
    before = snapshot(tmp_path)
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", *argv],
                       capture_output=True, text=True, timeout=600)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1 and lines[0].startswith("gasp: error:"), p.stderr
    assert all(n in lines[0] for n in needles), lines[0]
    assert snapshot(tmp_path) == before


# ------------------------------------------------------------------- accepted, and said plainly


def test_engine_name_shorthand(tmp_path, donut_small):
    """``engine = "name"`` (the README table's wording) is ``[engine] name = "name"``."""
    text = edit(scene_text(donut_small), '[engine]\nname = "taichi_mpm"\noptions = { threads = 1 }', "")
    (tmp_path / "s.toml").write_text('engine = "warp_mpm"\n' + text)
    s = load_scene(tmp_path / "s.toml")
    assert s.engine.name == "warp_mpm" and s.engine.options == {}


def test_info_states_the_up_axis_as_a_guess(capsys):
    """The guitar is -Y up (playcanvas examples); the donut +Z up: both guessed, said to be guesses."""
    for path, up in ((GUITAR, "-y"), (GUITAR.parent / "donut_v3dg.ply", "+z")):
        assert main(["info", str(path)]) == 0
        out = capsys.readouterr().out
        assert f"up_axis_guess: {up}" in out and "up_axis_confidence" in out and "guess" in out
