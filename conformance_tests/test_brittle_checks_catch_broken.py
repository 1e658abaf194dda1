"""The brittle conformance scenes (``gasp_core/testing/scenes_fracture.py``) must catch broken engines (issue 52
item 4): one that never damages, one that heals, one that damages in compression, one whose ``G_f`` is not
regularised, and one with the crack band ``dx + p_vol^(1/3)`` (1.5 cells: the band before round 31's, 31 % short on a
crack in free material).

Each broken engine wraps a real installed engine with the material (warp_mpm first): its factory builds the real
engine from a spoiled setup, or it spoils the engine's state between frames. The scene that must catch it is run on
it and the named check must fail; the real engine passes the same scenes in ``test_conformance.py``.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gasp_core.seam.plugins import engines as installed_engines
from gasp_core.seam.setup import Material
from gasp_core.testing import evaluate_scene, record, scene_by_name
from gasp_core.testing.scenes_fracture import N_GRID
from gasp_core.mpm.materials import brittle_damage, softening_stress

PREFERRED = ("warp_mpm", "taichi_mpm")
#: Broken kind -> (the scene that must catch it, the check that must fail there).
CATCHES = {
    "never_damages": ("brittle_bar_strength", "tensile_strength"),
    "heals": ("brittle_bar_strength", "never_heals"),
    "damages_in_compression": ("brittle_below_strength", "compression_no_damage"),
    "loses_energy_below_strength": ("brittle_below_strength", "energy_as_elastic"),
    "not_regularised": ("brittle_fracture_energy", "regularised"),
    "band_of_before": ("brittle_fracture_energy", "fracture_energy"),
}
#: The share of each point's velocity ``loses_energy_below_strength`` takes after each frame.
LOSS = 0.0005
#: The scenes of the slow tier (brittle_fracture_energy runs the bar at n_grid 32 and 64).
SLOW = {"not_regularised", "band_of_before"}


def _real():
    for name in PREFERRED:
        info = installed_engines().get(name)
        if info is not None and info.unavailable_reason() is None:
            return info
    return None


def _spoil_materials(setup, change):
    mats = [change(m, float(h)) if m.name == "brittle" else m for m, h in zip(setup.materials, setup.crack_band)]
    return setup.replace(materials=mats)


class _StateBroken:
    """A real engine whose damage is spoiled between frames: ``heals`` forgets it before each frame (the damage is
    recomputed from the current stress only); ``damages_in_compression`` raises it after each frame to the damage
    of the largest absolute principal stress (so compression damages); ``loses_energy_below_strength`` takes
    :data:`LOSS` of every point's velocity after each frame (a model that does not return the elastic energy it
    stored: 0.1 % of the kinetic energy a frame), on brittle bodies only (the scene's elastic twin runs on the
    same engine, as it should: what it checks is the brittle model against the elastic one)."""

    def __init__(self, inner, setup, kind: str):
        self.inner, self.setup, self.kind = inner, setup, kind
        m = setup.materials[0]
        self.ft, self.sf = m.tensile_strength, softening_stress(m, float(setup.crack_band[0]))
        self.mu, self.lam = m.mu, m.lam

    def step_frame(self):
        if self.kind == "heals":
            st = self.inner.get_state()
            st["Jp"] = np.zeros_like(st["Jp"])
            self.inner.set_state(st)
        self.inner.step_frame()
        if self.kind == "loses_energy_below_strength" and self.setup.materials[0].name == "brittle":
            st = self.inner.get_state()
            st["v"] = (np.asarray(st["v"]) * (1 - LOSS)).astype(st["v"].dtype)
            self.inner.set_state(st)
        if self.kind == "damages_in_compression":
            st = self.inner.get_state()
            sig = np.linalg.svd(np.asarray(st["F"], np.float64), compute_uv=False)
            eps = np.log(np.clip(sig, 1e-6, None))
            s = 2 * self.mu * eps + self.lam * eps.sum(axis=1, keepdims=True)
            d = brittle_damage(np.abs(s).max(axis=1), self.ft, self.sf)
            st["Jp"] = np.maximum(np.asarray(st["Jp"]), d).astype(st["Jp"].dtype)
            self.inner.set_state(st)

    def __getattr__(self, name):       # positions, velocities, damage, stats, get_state, set_state, close
        return getattr(self.inner, name)


def broken_engine(info, kind: str):
    """An EngineInfo named ``broken_<kind>`` whose factory wraps ``info.factory``."""
    h0 = 1.0 / N_GRID                    # the bar's band at n_grid 32 (the cell)

    def factory(setup):
        if kind == "never_damages":      # the brittle body run as Hencky elasticity that never yields
            return info.factory(_spoil_materials(setup, lambda m, h: Material(
                "metal", E=m.E, nu=m.nu, rho=m.rho, yield_stress=1e30)))
        if kind == "not_regularised":    # the softening stress of n_grid 32's band whatever n_grid
            return info.factory(_spoil_materials(setup, lambda m, h: dataclasses.replace(
                m, fracture_energy=m.fracture_energy * h / h0)))
        if kind == "band_of_before":     # the band dx + p_vol^(1/3) (points at dx / 2), before round 31
            return info.factory(_spoil_materials(setup, lambda m, h: dataclasses.replace(
                m, fracture_energy=m.fracture_energy * h / (h + setup.dx / 2))))
        return _StateBroken(info.factory(setup), setup, kind)

    return dataclasses.replace(info, name=f"broken_{kind}", factory=factory, known_failures={})


@pytest.mark.parametrize("kind", [pytest.param(k, marks=[pytest.mark.slow] if k in SLOW else []) for k in CATCHES])
def test_a_brittle_check_catches_a_broken_engine(kind, request):
    info = _real()
    if info is None:
        pytest.skip("no installed engine with the material 'brittle' (warp_mpm, taichi_mpm)")
    scene, check_name = CATCHES[kind]
    result = evaluate_scene(broken_engine(info, kind), scene_by_name(scene), known_failures={})
    record(request.node, result)
    failed = [c.name for c in result.checks if not c.passed]
    assert result.status == "fail" and check_name in failed, (result.status, result.message)
