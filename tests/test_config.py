"""Engine settings as typed records (issue 51 item 2, :mod:`gasp_core.seam.config`): the options, the quality presets
and docs/engine_options.md all come from one declaration per engine."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import pytest

from gasp_core.cli.engines import MARKDOWN_HEAD
from gasp_core.errors import SceneError
from gasp_core.seam import Capabilities, EngineInfo, Option, Preset, option
from gasp_core.seam.config import config_options, options_markdown
from gasp_core.seam.options import check_options
from gasp_core.seam.plugins import engines
from gasp_core.mpm.options import GridConfig, MPMConfig

DOC = Path(__file__).resolve().parents[1] / "docs" / "engine_options.md"


@dataclass(frozen=True)
class _Config:
    cfl: float = option(0.4, "Courant number", lo=0.0, hi=1.0, lo_open=True)
    threads: int | None = option(None, "CPU threads", kind="int", lo=1)
    PRESETS: ClassVar = {"draft": Preset({"cfl": 0.8}, measured="here")}


def _info(**kw) -> EngineInfo:
    caps = Capabilities(materials=frozenset({"jelly"}), boundaries=frozenset())
    return EngineInfo("x", factory=lambda setup: None, capabilities=caps, **kw)


def test_a_config_class_declares_the_options_and_presets_of_its_engine():
    info = _info(config=_Config)
    assert info.options == (Option("cfl", 0.4, "Courant number", lo=0.0, hi=1.0, lo_open=True),
                            Option("threads", None, "CPU threads", kind="int", lo=1))
    assert dict(info.presets["draft"].options) == {"cfl": 0.8}
    resolved = check_options({"threads": 2}, info.options, "x")
    assert _Config(**resolved) == _Config(cfl=0.4, threads=2)       # the engine's typed view of the run's options
    with pytest.raises(SceneError, match=r"option cfl=1\.5; expected a number in \(0, 1\]"):
        check_options({"cfl": 1.5}, info.options, "x")


def test_a_config_field_that_is_not_an_option_is_refused():
    @dataclass(frozen=True)
    class Bad:
        cfl: float = 0.4
    with pytest.raises(TypeError, match=r"Bad\.cfl: not an option"):
        config_options(Bad)


def test_the_mpm_config_extends_the_grid_config_and_resolves_every_field():
    names = [o.name for o in config_options(MPMConfig)]
    assert names[:len(dataclasses.fields(GridConfig))] == [f.name for f in dataclasses.fields(GridConfig)]
    assert {"passive_every", "flip", "contact", "contact_balance"} <= set(names)
    for name in ("taichi_mpm", "warp_mpm"):
        info = engines().get(name)
        if info is None:
            continue
        resolved = check_options({}, info.options, name)
        config = info.config(**resolved)
        assert dataclasses.asdict(config) == resolved             # run.json's engine_options is the config, whole
        assert isinstance(config, MPMConfig) and config.cfl == 0.4


def test_docs_engine_options_is_generated_from_the_declarations():
    """Every installed engine's section of docs/engine_options.md is what its declaration generates today
    (regenerate with ``gasp engines --markdown > docs/engine_options.md``)."""
    text = DOC.read_text()
    assert text.startswith(MARKDOWN_HEAD)
    for name, info in engines().items():
        assert options_markdown(name, info.options, info.presets) in text, \
            f"docs/engine_options.md: the section of {name} is stale; run gasp engines --markdown"
