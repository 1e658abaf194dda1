"""The step-started pull's stress wave in the user-built bar (issue 66 round 45; ``benchmarks/studies/step_wave.py``,
docs/fracture.md "Round 45: the step-started pull").

The bar L0.7 a0.15 of ``benchmarks/user_tension.py`` (built through the scene, a ``fixed_region`` clamp, one set box)
at rest, pulled from t = 0 at ``v``. The elastic bar's answer (nu 0, so ``c = sqrt(E / rho)`` whatever the section's
confinement): a front of ``rho c v`` runs from the pulled face to the clamp, which reflects it with its sign, so the
clamp's edge carries ``2 rho c v`` after it. Each crossing adds ``rho c v``: the stress in the bar is a whole number
``n`` of ``rho c v``, and level ``n`` is born at the clamp (``n`` even) or at the pulled face (``n`` odd) at ``(n - 1)
L / c`` (``L`` the free length), then crosses the bar in ``L / c``. So a step first reaches ``f_t`` with the level
``n* = ceil(f_t / (rho c v))``, in the half of the bar where it is born, within ``L / c`` of its birth.

- the front: the mid layer's plateau is ``rho c v`` and the clamp edge's after the reflection ``2 rho c v``, each
  within 5 % (two-sided); both engines, n_grid 24 (measured: 1.022 and 2.016). Catches: the material's ``rho`` 1.21
  times the model's in the scene (impedance +10 %: the plateaus +12 %), and the clamp left out (a free end reflects
  with the other sign: the clamp edge's plateau 0).
- where a step first damages: at ``v = 2.0`` and ``2.4 PULL`` (``n*`` 8 and 7: the clamp's half, the pulled face's
  half) the first damaged layer is in the half ``n*`` predicts and its frame within ``[(n* - 1) L / c, n* L / c]``.
  Catch: the scene's ``rho`` 1.21 times (``n*`` 6 at 2.4: the clamp's half, a round trip earlier).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "benchmarks" / "studies"))
import step_wave as sw        # noqa: E402
import tension_family as tf   # noqa: E402
import user_tension as ut     # noqa: E402

from gasp_core.seam.plugins import engines   # noqa: E402

TOL = 0.05
BAR, N = ut.USER[0], 24
FRONT_FRAMES = 95           # 2.97 L / c: the clamp edge's plateau ends at 3 L / c


def _names():
    return [n for n, i in engines().items() if i.unavailable_reason() is None and n in ("taichi_mpm", "warp_mpm")]


def heavy(mp) -> None:
    """The scene's material 1.21 times as dense as the model (``tf.RHO``) says: ``c`` -9 %, ``rho c`` +10 %."""
    mp.setattr(ut, "MATERIAL_ROWS", ut.MATERIAL_ROWS.replace(f"rho = {tf.RHO}", f"rho = {1.21 * tf.RHO}"))


def unclamped(mp) -> None:
    """The scene without its ``fixed_region``: the clamp's end free."""
    head = ut.scene_head
    mp.setattr(ut, "scene_head", lambda *a, **k: head(*a, **k).split("[[boundary]]")[0])


def front_failures(r: dict) -> list[str]:
    """The mid layer's plateau against ``rho c v`` and the clamp edge's against ``2 rho c v``, within ``TOL``."""
    bad = []
    if not abs(r["mid_plateau_vs_s0"] - 1) <= TOL:
        bad.append(f"mid plateau {r['mid_plateau_vs_s0']:.3f} rho c v")
    if not abs(r["clamp_plateau_vs_s0"] / 2 - 1) <= TOL:
        bad.append(f"clamp edge plateau {r['clamp_plateau_vs_s0']:.3f} rho c v, not 2")
    return bad


def front(name: str, spoil=None) -> dict:
    with pytest.MonkeyPatch.context() as mp:
        if spoil is not None:
            spoil(mp)
        return sw.run(BAR, N, name, "step", 1.0, 0.0, frames=FRONT_FRAMES)


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_pulls_front_is_rho_c_v_and_doubles_at_the_clamp(name):
    assert front_failures(front(name)) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_front_check_catches_a_heavier_bar_and_a_free_end(name):
    dense, free = front_failures(front(name, heavy)), front_failures(front(name, unclamped))
    assert len(dense) == 2 and any("clamp edge" in b for b in free), (dense, free)


def predicted(v: float, L: float) -> tuple[str, float, float]:
    """Where and when the step's first damage is due: ``n* = ceil(f_t / (rho c v))``, the half it is born in
    (``"clamp"`` for even, ``"pulled"`` for odd) and its passage's window ``[(n* - 1) L / c, n* L / c]`` (s)."""
    n = math.ceil(tf.FT / (tf.RHO * sw.C * v))
    return ("clamp" if n % 2 == 0 else "pulled"), (n - 1) * L / sw.C, n * L / sw.C


def where_failures(r: dict) -> list[str]:
    """The first damaged layer's half and time against :func:`predicted`."""
    half, t0, t1 = predicted(r["v"], r["L"])
    got = "clamp" if r["first_damage_s"] < r["L"] / 2 else "pulled"
    bad = [] if got == half else [f"first damage {r['first_damage_s']:.3f} m from the clamp: the {got} half, "
                                  f"not the {half}'s"]
    if not t0 <= r["first_damage_t"] <= t1:
        bad.append(f"first damage at {r['first_damage_t']:.4f} s, not in [{t0:.4f}, {t1:.4f}]")
    return bad


def first_damage(name: str, speed: float, spoil=None) -> dict:
    with pytest.MonkeyPatch.context() as mp:
        if spoil is not None:
            spoil(mp)
        return sw.run(BAR, N, name, "step", speed, 0.0, stop=3)


@pytest.mark.slow
@pytest.mark.parametrize("speed", [2.0, 2.4])
@pytest.mark.parametrize("name", _names())
def test_a_step_first_damages_where_its_wave_first_reaches_f_t(name, speed):
    assert where_failures(first_damage(name, speed)) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_where_check_catches_a_heavier_bar(name):
    bad = where_failures(first_damage(name, 2.4, heavy))
    assert any("half" in b for b in bad) and any("not in" in b for b in bad), bad
