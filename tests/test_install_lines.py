"""What is not installed is named with the line that installs it (issue 33, item 5): an optional extra's
package, a renderer plugin, an engine plugin with the extra it cannot run without."""
import sys

import pytest

from gasp_core.errors import EXTRA_OF, extra_hint, missing_module_message
from gasp_core.seam.plugins import install_hint
from gasp_testing import ROOT


def test_a_missing_extra_package_names_its_extra():
    line = missing_module_message(ModuleNotFoundError("No module named 'imageio'", name="imageio"), "'gasp render'")
    assert line == f"'gasp render' needs imageio, which is not installed; it comes with the render extra: " \
                   f"{extra_hint('render')}"
    assert extra_hint("render").startswith("python -m pip install -e ") and extra_hint("render").endswith('[render]"')
    # trimesh re-raises its import error without the module's name: read from the text, named as distributed
    wrapped = ModuleNotFoundError("import of PIL halted; None in sys.modules")
    assert "needs Pillow" in missing_module_message(wrapped, "x.obj", "mesh") and "[mesh]" in \
        missing_module_message(wrapped, "x.obj", "mesh")
    assert missing_module_message(ModuleNotFoundError("No module named 'numpyy'", name="numpyy"), "x") is None


def test_every_extra_named_exists_in_pyproject():
    import tomllib
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert set(EXTRA_OF.values()) <= set(extras)


def test_plugin_hints_carry_the_extra_they_need():
    if not (ROOT / "plugins" / "blender" / "pyproject.toml").is_file():
        pytest.skip("not a clone with plugins/")
    assert '-e "plugins/blender[engine]"' in install_hint("blender")             # bpy comes with [engine]
    assert install_hint("gsplat").endswith('plugins/render_gsplat[gpu]"')      # a renderer's folder
    assert install_hint("warp_mpm").endswith("plugins/warp_mpm")               # its dependencies are plain
    assert install_hint("no_such_engine") == ""


def test_unknown_renderer_names_its_plugin(monkeypatch):
    if not (ROOT / "plugins" / "render_gsplat" / "pyproject.toml").is_file():
        pytest.skip("not a clone with plugins/render_gsplat")
    import gasp_core.render.registry as registry
    monkeypatch.setattr(registry, "renderers", lambda: {})
    from gasp_core.errors import GaspError
    with pytest.raises(GaspError) as e:
        registry.get_renderer("gsplat")
    assert "\n" not in str(e.value) and str(e.value).endswith('pip install -e "plugins/render_gsplat[gpu]"')


def test_view_without_viser_is_one_line_with_the_view_extra(tmp_path, capsys, monkeypatch):
    """``gasp view`` with viser not installed (hidden): one error line naming the view extra, exit 2."""
    for name in [m for m in sys.modules if m == "viser" or m.startswith("viser.")] + ["viser"]:
        monkeypatch.setitem(sys.modules, name, None)
    from gasp_core.cli.main import main
    assert main(["view", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"gasp: error: 'gasp view' needs viser, which is not installed; it comes with the view extra: "
                   f"{extra_hint('view')}"]


HIDDEN = {"taichi", "warp", "mujoco", "newton", "bpy", "genesis", "torch", "gsplat"}


def test_install_lines_printed_agree_with_gasp_engines(monkeypatch, capsys):
    """Issue 42, item 5: with every engine's packages hidden, each engine's line in ``gasp engines``, the error
    when it is asked for, and the unknown-engine error once it is uninstalled all end with the one line
    :func:`install_hint` gives; ``gasp engines`` with no plugin loaded prints that line for each plugin of
    the clone."""
    import importlib.util

    from gasp_core.cli.main import main
    from gasp_core.errors import EngineError
    from gasp_core.seam.install import clone_engine_plugins
    from gasp_core.seam.plugins import engines, get_engine, unknown_engine_message
    if not clone_engine_plugins():
        pytest.skip("not a clone with plugins/")
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a, **k: None if name.split(".")[0] in HIDDEN
                        else real(name, *a, **k))
    found = engines()
    assert found, "no engine plugin installed"
    assert main(["engines"]) == 0
    heads = {ln.split()[0]: ln for ln in capsys.readouterr().out.splitlines() if ln and not ln.startswith(" ")}
    for name in found:
        line = install_hint(name)
        assert line.count("pip install") >= 1
        assert "NOT AVAILABLE: " in heads[name] and heads[name].endswith(line), heads[name]
        with pytest.raises(EngineError) as e:
            get_engine(name)
        assert str(e.value).endswith(line), str(e.value)
        assert unknown_engine_message(name, []).endswith(f"to install it: {line}")
    monkeypatch.setenv("GASP_LOAD_PLUGINS", "")
    from gasp_core.seam import plugins
    plugins.get_plugin_manager.cache_clear()
    try:
        assert main(["engines"]) == 0
        out = capsys.readouterr().out.splitlines()
    finally:
        plugins.get_plugin_manager.cache_clear()
    assert sorted(out[1:]) == sorted(f"{n}  NOT INSTALLED: {install_hint(n)}" for n in clone_engine_plugins())


def test_an_engine_that_pins_older_packages_says_so_before_it_installs():
    """bpy requires numpy<2: the blender line names that first and installs into a venv of its own, never into
    the environment it would downgrade (as .ci/blender_tier.sh does)."""
    if not (ROOT / "plugins" / "blender" / "pyproject.toml").is_file():
        pytest.skip("not a clone with plugins/")
    line = install_hint("blender")
    assert line.index("numpy<2") < line.index("pip install") and "downgrade" in line
    assert line.count("pip install") == line.count(".venv-blender/bin/python -m pip install") == 1
    assert line.endswith('-e "plugins/blender[engine]" (then run .venv-blender/bin/gasp)')
    assert "venv" not in install_hint("warp_mpm") and install_hint("genesis").startswith(
        "python -m pip install torch==")
