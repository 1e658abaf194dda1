"""Brittle drops with a known answer (issue 66, ``benchmarks/brittle_drop_family.py``, docs/fracture.md "The donut
shatter example"): a 12 x 12 x 5 cm box filled with the faces' shares, as a scene fills it, lands on a face at 4.43
m/s. The plane-wave impact stress ``rho c_p v`` (84 kPa for the donut shatter's biscuit) bounds the stress in it: at
``f_t = 2 rho c_p v`` no point is damaged (measured: largest damage 0 on both engines), at ``f_t = rho c_p v / 4``
it breaks through (measured: 23.1 % of the volume with ``d >= 0.9`` on both engines, largest damage 1). An engine that
never damages fails the second; one that damages at a tenth of ``f_t`` fails the first (both shown here). Slow tier
(about 10 s an engine).
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from gasp_core.mpm.materials import P_FT, material_table
from gasp_testing import needs_package

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import brittle_drop_family as fam  # noqa: E402

PLUGIN_MODULE = {"taichi_mpm": "gasp_taichi_mpm.engine", "warp_mpm": "gasp_warp_mpm.engine"}


def _box(engine: str, ratio: float) -> dict:
    needs_package(f"gasp_{engine}")
    setup = fam.filled_setup(fam.box_splats((-0.06, -0.06, 0.005), (0.06, 0.06, 0.055)), ratio)
    return fam.drop(engine, setup, 2)


def _spoil(monkeypatch, engine: str, scale: float) -> None:
    """The engine's material table with its tensile strength scaled by ``scale`` (a broken model)."""
    def spoiled(materials, band=None, cells=None):
        kinds, params = material_table(materials, band, cells)
        params[:, P_FT] *= scale
        return kinds, params
    monkeypatch.setattr(f"{PLUGIN_MODULE[engine]}.material_table", spoiled)


def failures(engine: str) -> list[str]:
    out = []
    strong, weak = _box(engine, 2.0), _box(engine, 0.25)
    if strong["d_max"] > 0:
        out.append(f"f_t 2 rho c_p v: damaged (largest d {strong['d_max']:.3g})")
    if weak["broken"] < 0.05:
        out.append(f"f_t rho c_p v / 4: {weak['broken']:.1%} of the volume broken through (at least 5 %)")
    return out


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_a_box_landing_breaks_below_the_impact_stress_and_not_above(engine):
    assert failures(engine) == []


@pytest.mark.slow
@pytest.mark.parametrize("scale", [1e30, 0.1])
def test_the_drop_check_catches_a_model_that_never_damages_or_damages_early(monkeypatch, scale):
    _spoil(monkeypatch, "taichi_mpm", scale)
    assert len(failures("taichi_mpm")) == 1
