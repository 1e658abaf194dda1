"""taichi_mpm's GPU schedule compiles no ordered one-thread loop (issue 65, ``gasp_taichi_mpm.schedule``).

Every ``ti.loop_config(serialize=True)`` and ``ti.loop_config(block_dim=1)`` of taichi_mpm is in the CPU schedule's
module ``gasp_taichi_mpm/schedule/ordered.py`` (10 ``loop_config`` calls), and only the CPU schedule
launches or inlines it. On CUDA each such loop is a single GPU thread (the README donut took 7.7 s a frame on an
H100 before issue 65). ``schedule/ordered.py`` and ``schedule/__init__.py`` named this test before it existed
(round 77).

- By the source: no other module of the plugin calls ``loop_config`` with ``serialize=True`` or ``block_dim=1``
  (its syntax tree).
- By a spy on ``ti.loop_config``: scenes that reach each ordered kernel's topic (rigid bodies on the particle contact's
  planes, the contact's balance, a viscous body, a rigid body under sand on two fields, passive points) built with
  ``schedule = "gpu"`` (the GPU schedule, which runs on the CPU too) and stepped a frame compile no such loop; with
  ``schedule = "cpu"`` the same spy records them (the catch: the spy sees what it looks for). Slow tier (160 s);
  the source check is in the default tier.
"""
from __future__ import annotations

import ast
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "plugins" / "taichi_mpm" / "gasp_taichi_mpm"
ORDERED = PLUGIN / "schedule" / "ordered.py"

pytestmark = pytest.mark.skipif("taichi_mpm" not in engines() or engines()["taichi_mpm"].unavailable_reason()
                                is not None, reason="taichi_mpm is not installed")


def _ordered_calls(path: Path) -> list[int]:
    """Lines of ``path`` that call ``loop_config`` with ``serialize=True`` or ``block_dim=1``."""
    out = []
    for n in ast.walk(ast.parse(path.read_text())):
        if isinstance(n, ast.Call) and getattr(n.func, "attr", getattr(n.func, "id", None)) == "loop_config":
            for k in n.keywords:
                if isinstance(k.value, ast.Constant) and ((k.arg == "serialize" and k.value.value is True)
                                                          or (k.arg == "block_dim" and k.value.value == 1)):
                    out.append(n.lineno)
    return out


def test_only_the_cpu_schedules_module_holds_ordered_loops():
    elsewhere = {str(p.relative_to(PLUGIN)): lines for p in PLUGIN.rglob("*.py") if p != ORDERED
                 and (lines := _ordered_calls(p))}
    assert elsewhere == {}, elsewhere
    assert _ordered_calls(ORDERED)   # the check finds what it looks for: 10 such calls there


def _scenes():
    """Setups that reach the ordered kernels' topics (module notes)."""
    sys.path.insert(0, str(ROOT / "benchmarks" / "studies"))
    import finestep_paths
    out = []
    dx = 0.6 / 24
    x, v = box_points((0.1, 0.2, 0.05), (0.25, 0.35, 0.1), dx / 2)
    t = math.radians(30)
    g = (9.81 * math.sin(t), 0.0, -9.81 * math.cos(t))
    for mat in (Material("jelly", model="rigid", E=1e10, nu=0.3, rho=700.0),   # rigid_reduce, rigid_depth
                Material("jelly", model="elastic", E=1e5, nu=0.3, rho=1000.0, viscosity=5.0)):   # balance, viscosity
        s = make_setup(x, v, mat, gravity=g, lo=np.zeros(3), hi=np.full(3, 0.6), n_grid=24, frame_dt=1 / 60,
                       boundaries=[Boundary("ground", height=0.05, friction=0.6)], options={"contact": "particle"})
        out.append(s)
    out.append(finestep_paths.scene("sand_rigid")[0])   # a rigid box under sand, two fields
    return out


def _spied(schedule: str, monkeypatch) -> list[dict]:
    import taichi as ti
    seen = []
    real = ti.loop_config

    def spy(**kw):
        seen.append(kw)
        return real(**kw)
    monkeypatch.setattr(ti, "loop_config", spy)
    for s in _scenes():
        s.options = {**s.options, "schedule": schedule}
        e = build_engine(engines()["taichi_mpm"], s)
        try:
            e.step_frame()
        finally:
            e.close()
    return [kw for kw in seen if kw.get("serialize") is True or kw.get("block_dim") == 1]


@pytest.mark.slow   # about 80 s each: three scenes compiled on a schedule
def test_the_gpu_schedule_compiles_no_ordered_loop(monkeypatch):
    ordered = _spied("gpu", monkeypatch)
    assert ordered == [], ordered


@pytest.mark.slow
def test_the_spy_sees_the_cpu_schedules_ordered_loops(monkeypatch):
    assert _spied("cpu", monkeypatch)
