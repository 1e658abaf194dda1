"""Engine discovery: entry points, duplicates, typos in hook names, GASP_LOAD_PLUGINS, capability checks."""
import os
import textwrap

import pluggy
import pytest

from gasp_core.seam import plugins
from gasp_core.errors import EngineError
from gasp_core.seam.engine import Capabilities, EngineInfo, PointEngine, StatefulEngine


@pytest.fixture
def fresh_pm(monkeypatch):
    plugins.get_plugin_manager.cache_clear()
    yield
    plugins.get_plugin_manager.cache_clear()


def make_dist(tmp_path, dist: str, module: str, entry: str, body: str):
    """A hand-written installed distribution (dist-info with entry_points.txt) on sys.path."""
    (tmp_path / f"{module}.py").write_text(textwrap.dedent(body))
    info = tmp_path / f"{dist.replace('-', '_')}-9.9.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 9.9\n")
    (info / "entry_points.txt").write_text(f"[gasp]\n{entry} = {module}\n")


PLUGIN = """
from gasp_core.seam.engine import Capabilities, EngineInfo
from gasp_core.seam.plugins import hookimpl

@hookimpl
def gasp_engines():
    return [EngineInfo(name="{name}", factory=lambda setup: None,
                       capabilities=Capabilities(materials=frozenset({{"jelly"}}), boundaries=frozenset()))]
"""


def test_entry_point_plugin_is_discovered(tmp_path, monkeypatch, fresh_pm):
    make_dist(tmp_path, "gasp-dummy-a", "gasp_dummy_a", "dummy_a", PLUGIN.format(name="dummy_a"))
    monkeypatch.syspath_prepend(str(tmp_path))
    found = plugins.engines()
    assert "dummy_a" in found
    assert found["dummy_a"].distribution == "gasp-dummy-a" and found["dummy_a"].version == "9.9"


def test_duplicate_engine_names_both_distributions(tmp_path, monkeypatch, fresh_pm):
    make_dist(tmp_path, "gasp-dup-one", "gasp_dup_one", "dup_one", PLUGIN.format(name="twin"))
    make_dist(tmp_path, "gasp-dup-two", "gasp_dup_two", "dup_two", PLUGIN.format(name="twin"))
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(EngineError, match="twin") as e:
        plugins.engines()
    assert "gasp-dup-one" in str(e.value) and "gasp-dup-two" in str(e.value)


def test_misspelled_hook_fails_loudly(tmp_path, monkeypatch, fresh_pm):
    body = "from gasp_core.seam.plugins import hookimpl\n@hookimpl\ndef gasp_engine():\n    return []\n"
    make_dist(tmp_path, "gasp-typo", "gasp_typo", "typo", body)
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(pluggy.PluginValidationError, match="gasp_engine"):
        plugins.get_plugin_manager()


def test_env_var_narrows_plugins(tmp_path, monkeypatch, fresh_pm):
    make_dist(tmp_path, "gasp-dummy-b", "gasp_dummy_b", "dummy_b", PLUGIN.format(name="dummy_b"))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("GASP_LOAD_PLUGINS", "dummy_b")
    assert list(plugins.engines()) == ["dummy_b"]
    plugins.get_plugin_manager.cache_clear()
    monkeypatch.setenv("GASP_LOAD_PLUGINS", "")
    assert plugins.engines() == {}


def test_unknown_and_unavailable_engines(fresh_pm):
    pm = pluggy.PluginManager("gasp")
    pm.add_hookspecs(plugins.HookSpec)

    class P:
        @plugins.hookimpl
        def gasp_engines(self):
            return [EngineInfo(name="absent", factory=lambda s: None,
                               capabilities=Capabilities(frozenset(), frozenset()),
                               available=lambda: "package foo is not installed")]
    pm.register(P(), name="p")
    with pytest.raises(EngineError, match="installed engines: \\['absent'\\]"):
        plugins.get_engine("nope", pm)
    with pytest.raises(EngineError, match="foo is not installed"):
        plugins.get_engine("absent", pm)


def test_a_clone_plugin_not_installed_names_its_install_line(fresh_pm):
    """An engine of this clone's plugins/ folder that is not registered: the error gives its pip line."""
    from pathlib import Path
    pm = pluggy.PluginManager("gasp")
    pm.add_hookspecs(plugins.HookSpec)
    folder = Path(plugins.__file__).resolve().parents[2] / "plugins" / "warp_mpm"
    if not (folder / "pyproject.toml").is_file():
        pytest.skip("not a clone with plugins/warp_mpm")
    with pytest.raises(EngineError) as e:
        plugins.get_engine("warp_mpm", pm)
    line = str(e.value)
    assert "\n" not in line and "unknown engine 'warp_mpm'" in line
    assert line.endswith("python -m pip install -e " + os.path.relpath(folder))
    with pytest.raises(EngineError) as e:   # a name with no folder: no install line
        plugins.get_engine("bullet_sph", pm)
    assert "pip install" not in str(e.value)


def test_every_hook_is_documented():
    for name in dir(plugins.HookSpec):
        if name.startswith("gasp_"):
            doc = getattr(plugins.HookSpec, name).__doc__
            assert doc and "Returns" in doc, name


def test_installed_engines_implement_the_protocol():
    """Every installed, available engine builds from a tiny real setup and follows PointEngine."""
    import numpy as np
    from gasp_core.seam.setup import Material, SimSetup
    from gasp_core.seam.build import build_engine
    g = np.stack(np.meshgrid(*[np.linspace(0.4, 0.6, 4)] * 3, indexing="ij"), -1).reshape(-1, 3)
    for name, info in plugins.engines().items():
        if info.unavailable_reason():
            continue
        setup = SimSetup(x=g, v=0.0, p_vol=(0.2 / 4) ** 3, body_id=0, materials=[Material()],
                         gravity=[0, 0, -9.81], domain_lo=[0, 0, 0], domain_hi=[1, 1, 1], n_grid=16,
                         frame_dt=1 / 60)
        eng = build_engine(info, setup)  # options checked and completed by the core, as in a run
        try:
            assert isinstance(eng, PointEngine), name
            assert "state" not in info.capabilities.features or isinstance(eng, StatefulEngine), name
            eng.step_frame()
            x = np.asarray(eng.positions())
            assert x.shape == g.shape and np.all(np.isfinite(x)), name
            assert x[:, 2].mean() < g[:, 2].mean(), f"{name}: nothing fell under gravity"
            assert {"device", "precision", "n_points"} <= set(eng.stats()), name
        finally:
            eng.close()


SOUP_ONLY = """
from gasp_core.seam import SoupWriterInfo, hookimpl

@hookimpl
def gasp_soup_writers():
    return [SoupWriterInfo(name="xyz_points", write=lambda outdir, soups: [], description="test: vertices as text")]
"""


def test_soup_writer_only_plugin_is_found_listed_and_switched_off(tmp_path, monkeypatch, capsys, fresh_pm):
    """A plugin that registers nothing but a soup writer goes through the one registry like an engine."""
    import json
    from gasp_core.cli.main import main
    make_dist(tmp_path, "gasp-soup-only", "gasp_soup_only", "soup_only", SOUP_ONLY)
    monkeypatch.syspath_prepend(str(tmp_path))
    found = plugins.soup_writers()
    assert found["xyz_points"].distribution == "gasp-soup-only" and found["xyz_points"].version == "9.9"
    assert main(["plugins"]) == 0
    out = capsys.readouterr().out
    assert "soup writers:\n" in out and "    xyz_points  (gasp-soup-only 9.9)  test: vertices as text" in out
    assert main(["plugins", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert listed["soup_writers"]["xyz_points"]["distribution"] == "gasp-soup-only"

    plugins.get_plugin_manager.cache_clear()
    monkeypatch.setenv("GASP_LOAD_PLUGINS", "soup_only")   # only it: no engine, its writer
    assert plugins.engines() == {} and list(plugins.soup_writers()) == ["xyz_points"]
    for off in ("", "some_other_plugin"):                   # switched off
        plugins.get_plugin_manager.cache_clear()
        monkeypatch.setenv("GASP_LOAD_PLUGINS", off)
        assert "xyz_points" not in plugins.soup_writers()
        assert main(["plugins"]) == 0
        assert "xyz_points" not in capsys.readouterr().out


def _tiny_setup(**kw):
    import numpy as np
    from gasp_core.seam.setup import Material, SimSetup
    g = np.stack(np.meshgrid(*[np.linspace(0.4, 0.6, 3)] * 3, indexing="ij"), -1).reshape(-1, 3)
    return SimSetup(**{"x": g, "v": 0.0, "p_vol": 1e-3, "body_id": 0, "materials": [Material()],
                       "gravity": [0, 0, -9.81], "domain_lo": [0, 0, 0], "domain_hi": [1, 1, 1], "n_grid": 16,
                       "frame_dt": 1 / 60, **kw})


class _Still:
    """A minimal PointEngine: nothing moves."""

    def __init__(self, setup):
        self.x = setup.x

    def step_frame(self):
        pass

    def positions(self):
        return self.x

    def velocities(self):
        return 0 * self.x

    def stats(self):
        return {"device": "cpu", "precision": "f64", "n_points": len(self.x), "mass": 0.0, "centre_of_mass": [0] * 3}

    def close(self):
        pass


class _StillWithState(_Still):
    def get_state(self):
        return {"x": self.x.copy()}

    def set_state(self, state):
        self.x = state["x"]


def test_engine_limits_are_data_checked_by_the_core():
    """EngineInfo.limits: the core refuses a value outside them before the factory, with one text."""
    from gasp_core.errors import SceneError
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.engine import Capabilities, EngineInfo
    from gasp_core.seam.limits import Limit
    from gasp_core.seam.setup import Boundary, Material
    built = []
    info = EngineInfo(name="limited", factory=lambda s: built.append(s) or _Still(s),
                      capabilities=Capabilities(frozenset({"jelly", "sand"}), frozenset({"ground"})),
                      limits={"nu": Limit(lo=0.0, why="no auxetics"), "sand.friction_angle": Limit(0, 90, True, True),
                              "ground.friction": Limit(hi=1.0), "n_grid": Limit(lo=8)})
    for setup, text in [
        (_tiny_setup(materials=[Material(nu=-0.2)]),
         "engine 'limited': material 'jelly': nu=-0.2; this engine takes nu >= 0 (no auxetics)"),
        (_tiny_setup(materials=[Material("sand", friction_angle=0.0)]),
         "engine 'limited': material 'sand': friction_angle=0.0; this engine takes friction_angle in (0, 90)"),
        (_tiny_setup(boundaries=[Boundary("ground", friction=2.0)]),
         "engine 'limited': boundary 'ground': friction=2.0; this engine takes friction <= 1"),
        (_tiny_setup(n_grid=6), "engine 'limited': n_grid=6; this engine takes n_grid >= 8"),
    ]:
        with pytest.raises(SceneError) as e:
            build_engine(info, setup)
        assert str(e.value) == text
    assert built == []
    build_engine(info, _tiny_setup(materials=[Material("sand", nu=0.0, friction_angle=30.0)])).close()
    assert len(built) == 1
    for bad in ("poisson", "rigid.friction", "ground.nu", "walls.n_grid"):
        with pytest.raises(ValueError, match="limit"):
            EngineInfo(name="x", factory=_Still, capabilities=Capabilities(frozenset(), frozenset()),
                       limits={bad: Limit(lo=0.0)})


def test_state_feature_means_a_stateful_engine():
    """An engine declaring the feature 'state' must be a StatefulEngine (get_state, set_state)."""
    from gasp_core.errors import EngineBug
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.engine import Capabilities, EngineInfo, PointEngine, StatefulEngine
    from gasp_core.seam.runner import check_state
    from gasp_core.seam.runner import run_engine
    caps = Capabilities(frozenset({"jelly"}), frozenset(), features=frozenset({"state"}))
    with pytest.raises(EngineBug, match="declares the feature 'state'"):
        build_engine(EngineInfo(name="forgetful", factory=_Still, capabilities=caps), _tiny_setup())
    eng = build_engine(EngineInfo(name="stateful", factory=_StillWithState, capabilities=caps), _tiny_setup())
    assert isinstance(eng, StatefulEngine) and isinstance(eng, PointEngine)
    assert not isinstance(_Still(_tiny_setup()), StatefulEngine)
    check_state(eng.positions(), _tiny_setup(), 1)
    # resuming asks for the feature, before anything is built
    plain = EngineInfo(name="plain", factory=_Still, capabilities=Capabilities(frozenset({"jelly"}), frozenset()))
    with pytest.raises(EngineError, match="feature 'state'"):
        next(run_engine(plain, _tiny_setup(), 3, start_frame=1, state={}))
    s = _tiny_setup()
    rec = next(run_engine(EngineInfo(name="stateful", factory=_StillWithState, capabilities=caps), s, 2,
                          start_frame=1, state={"x": s.x + 0.01}))
    assert rec.frame == 2 and abs(rec.x - s.x - 0.01).max() < 1e-12 and rec.get_state()["x"].shape == s.x.shape


def test_the_core_never_imports_the_plugin_facades():
    """gasp_core.seam and gasp_core.mpm re-export the contract for plugins; core modules import every
    name from the module that defines it, so that importing the contract cannot close a loop."""
    import ast
    import pathlib
    import gasp_core
    root = pathlib.Path(gasp_core.__file__).parent
    facades = {"gasp_core.seam", "gasp_core.mpm"}
    bad = []
    for p in root.rglob("*.py"):
        if p.name == "__init__.py" and p.parent.name in ("seam", "mpm"):
            continue
        for n in ast.walk(ast.parse(p.read_text())):
            if (isinstance(n, ast.ImportFrom) and n.module in facades
                    or isinstance(n, ast.Import) and any(a.name in facades for a in n.names)):
                bad.append(f"{p.relative_to(root)}:{n.lineno}")
    assert bad == []


def test_an_engine_is_registered_by_a_declarative_record():
    """Issue 51: ``engine_hook`` makes the hook from records; a factory named ``"module:attr"`` is imported at its
    first call, and ``requires`` gives the availability (the first missing module, the install line)."""
    from fractions import Fraction
    from gasp_core.seam import Capabilities, EngineInfo, engine_hook
    from gasp_core.seam.engine import LazyFactory
    caps = Capabilities(materials=frozenset({"jelly"}), boundaries=frozenset({"ground"}))
    info = EngineInfo(name="rec", factory="fractions:Fraction", capabilities=caps,
                      requires=("json", "gasp_no_such_module_51"), install="gasp-rec")
    assert isinstance(info.factory, LazyFactory) and info.factory(3) == Fraction(3)
    why = info.unavailable_reason()
    assert why is not None and "'gasp_no_such_module_51'" in why and "gasp-rec" in why
    assert EngineInfo(name="rec", factory="fractions:Fraction", capabilities=caps,
                      requires=("json",)).unavailable_reason() is None
    assert EngineInfo(name="rec", factory=Fraction, capabilities=caps, requires=("gasp_no_such_module_51",),
                      available=lambda: None).unavailable_reason() is None     # an own check wins
    hook = engine_hook(info)
    assert hook() == [info] and hasattr(hook, "gasp_impl")                        # pluggy's marker
    # the shipped MPM engines are records too
    from gasp_core.seam.plugins import engines
    found = engines()
    assert all(isinstance(found[n].factory, LazyFactory) for n in ("taichi_mpm", "warp_mpm") if n in found)
