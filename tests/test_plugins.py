"""Engine discovery: entry points, duplicates, typos in hook names, GASP_LOAD_PLUGINS, capability checks."""
import textwrap

import pluggy
import pytest

from gasp_core.seam import plugins
from gasp_core.errors import EngineError
from gasp_core.seam.engine import Capabilities, EngineInfo, PointEngine


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
            eng.step_frame()
            x = np.asarray(eng.positions())
            assert x.shape == g.shape and np.all(np.isfinite(x)), name
            assert x[:, 2].mean() < g[:, 2].mean(), f"{name}: nothing fell under gravity"
            assert {"device", "precision", "n_points"} <= set(eng.stats()), name
        finally:
            eng.close()
