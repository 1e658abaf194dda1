"""warp_mpm compiles once per install (issue 54 item 7; ``plugins/warp_mpm/gasp_warp_mpm/warmup.py``).

Every Warp kernel of the plugin is built by a ``build_*(Ft)`` function, a closure over the scalar type alone, so
:func:`all_kernels` finds them all and :func:`compile_all` compiles them on the first run; a later scene, whatever its
sizes and features, then compiles nothing (``benchmarks/bench_second_scene.py`` counts the modules each run adds to
Warp's cache: 0 after the first). The checks here: no kernel outside such a builder (shown to catch one defined
elsewhere), every kernel an engine launches among those :func:`all_kernels` returns, and the marker's rules.
"""
from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

wp = pytest.importorskip("warp")
warmup = pytest.importorskip("gasp_warp_mpm.warmup")

from gasp_core.seam.build import build_engine  # noqa: E402
from gasp_core.seam.plugins import engines  # noqa: E402
from gasp_core.seam.setup import Material  # noqa: E402
from gasp_core.testing.helpers import box_points, make_setup  # noqa: E402

PLUGIN = Path(warmup.__file__).parent


def kernels_outside_builders(source: str) -> list[str]:
    """Names of the ``@wp.kernel`` functions in ``source`` whose nearest enclosing function is not a module-level
    ``build_*`` function of one argument (the scalar type), in source order."""
    tree = ast.parse(source)
    builders = {id(f) for f in tree.body if isinstance(f, ast.FunctionDef) and f.name.startswith("build_")
                and len(f.args.args) == 1}
    found = []

    def visit(node, enclosing):
        for ch in ast.iter_child_nodes(node):
            if isinstance(ch, ast.FunctionDef):
                if any("kernel" in ast.unparse(d) for d in ch.decorator_list) and id(enclosing) not in builders:
                    found.append((ch.lineno, ch.name))
                visit(ch, ch)
            else:
                visit(ch, enclosing)

    visit(tree, tree)
    return [name for _, name in sorted(found)]


def test_every_kernel_of_the_plugin_is_built_by_a_builder_of_the_scalar_type():
    files = sorted(PLUGIN.glob("*.py"))
    assert len(files) >= 15
    outside = {f.name: kernels_outside_builders(f.read_text()) for f in files}
    assert not any(outside.values()), outside
    n = sum(f.read_text().count("@wp.kernel") for f in files)
    assert n >= 30   # the check saw the plugin's kernels


def test_the_check_catches_a_kernel_defined_outside_a_builder():
    broken = ("import warp as wp\n@wp.kernel\ndef loose(a: wp.array(dtype=float)):\n    pass\n"
              "class Engine:\n    def build(self):\n        @wp.kernel\n        def inner(a: wp.array(dtype=float)):\n"
              "            pass\n"
              "def build_two(Ft, n):\n    @wp.kernel\n    def sized(a: wp.array(dtype=float)):\n        pass\n"
              "def build_ok(Ft):\n    @wp.kernel\n    def fine(a: wp.array(dtype=float)):\n        pass\n")
    assert kernels_outside_builders(broken) == ["loose", "inner", "sized"]


def test_all_kernels_covers_every_kernel_the_engine_launches():
    everything = {k.module.name for k in warmup.all_kernels(wp.float32)}
    assert len(everything) >= 30
    x, p_vol = box_points((0.4, 0.4, 0.1), (0.6, 0.6, 0.3), 1.0 / 32)
    s = make_setup(x, p_vol, Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0), n_grid=16,
                   options={"precision": "f32"})
    eng = build_engine(engines()["warp_mpm"], s)
    try:
        launched = {cmd.kernel.module.name for cmd in eng._launches + list(eng._pre)}
        assert launched and launched <= everything, launched - everything
    finally:
        eng.close()


def test_the_marker_makes_later_runs_skip_and_names_what_it_compiled(tmp_path, monkeypatch):
    wp.init()
    monkeypatch.setattr(wp.config, "kernel_cache_dir", str(tmp_path))
    loaded = []
    monkeypatch.setattr(wp, "force_load", lambda device, modules: loaded.append(modules))
    marker = warmup.marker_path(wp.float32, "cpu")
    assert marker.parent == tmp_path and not marker.exists()
    assert warmup.compile_all(wp.float32, "cpu") is True
    assert len(loaded) == 1 and len(loaded[0]) == len({k.module.name for k in warmup.all_kernels(wp.float32)})
    assert marker.exists() and not list(tmp_path.glob("*.tmp"))
    assert warmup.compile_all(wp.float32, "cpu") is False and len(loaded) == 1
    # another scalar type is another set of modules: its own marker
    assert warmup.marker_path(wp.float64, "cpu") != marker


def test_the_marker_changes_with_the_plugins_source(tmp_path, monkeypatch):
    wp.init()
    monkeypatch.setattr(wp.config, "kernel_cache_dir", str(tmp_path))
    before = warmup.marker_path(wp.float32, "cpu")
    copy = tmp_path / "pkg"
    copy.mkdir()
    for f in PLUGIN.glob("*.py"):
        (copy / f.name).write_text(f.read_text())
    monkeypatch.setattr(warmup, "__file__", str(copy / "warmup.py"))
    assert warmup.marker_path(wp.float32, "cpu") == before
    (copy / "grid.py").write_text((copy / "grid.py").read_text() + "\n# edited\n")
    assert warmup.marker_path(wp.float32, "cpu") != before


@pytest.mark.slow
@pytest.mark.parametrize("scalar", ["float32", "float64"])
def test_every_kernel_compiles_in_both_precisions(tmp_path, scalar):
    # a fresh process and cache folder: every module compiled, not loaded (about 25 s each). Round 25 found the f64
    # passive G2P failing to compile (Warp 1.19 retyped an unrolled loop's index cast to float64); no scene built it.
    code = ("import warp as wp; wp.config.quiet = True; wp.init(); from gasp_warp_mpm import warmup; "
            f"Ft = wp.{scalar}; n = len({{k.module.name for k in warmup.all_kernels(Ft)}}); "
            "print(warmup.compile_all(Ft, 'cpu'), n)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600,
                         env={**os.environ, "WARP_CACHE_PATH": str(tmp_path)})
    assert out.returncode == 0, out.stderr[-2000:]
    compiled, n = out.stdout.split()[-2:]
    assert compiled == "True" and int(n) >= 30
    folders = [p for p in tmp_path.rglob("*") if p.is_dir() and p.name.startswith("wp_")]
    assert len(folders) == int(n), (len(folders), n)
