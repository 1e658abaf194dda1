"""The oblique tension family built the way a user builds it (issue 66 item 2, round 36; ``benchmarks/user_oblique.py``,
docs/fracture.md "Oblique specimens built through the scene (round 36)"): ``user_tension``'s closed meshes turned by
the object's ``rotation`` in a scene TOML, the ``default`` level's world-aligned fill, a ``fixed_region`` and a ramped
set ``[[impulse]]`` over x half-spaces with their faces on nodes.

Default tier (no engine): the scene puts the specimen where ``tension_oblique.build`` puts its hand-built one (its
middle at the domain's centre within 1 mm, its axial extent the specimen's length within a fill spacing, its section
the flat dog-bone's with the width along z), fills it with its mass within 2 %, and writes the held faces on nodes
and the pull along the axis. The catch: the mesh turned about z alone (``rotation = [0, 0, angle]``, the width left
along y) fails the section's extents.

Slow (both engines): the must-show (``tests/test_user_tension.py``'s, along the axis) on both dog-bones at 30 and 45
deg, n_grid N and 2N; every case misses it (peaks 0.920-0.956 f_t, as the hand-built lattice's 0.922-0.955; at 45
deg the break outside the gauge): strict xfails with their figures (``KNOWN``). Round 44: the same at 45 deg with the
pull's set box ``constrain = "along"`` (a grip free across its pull, docs/fracture.md "Round 44"): the 2:1 meets it
at both grids; the 1.5:1 misses the work (a strict xfail, ``KNOWN_ALONG``). Its catch is ``KNOWN``'s 45 deg rows:
the same scene with the set box imposing every component. The work to separate at 30 deg on that grip (docs/fracture.md
"The work to separate at 30 deg"): the crack runs along the fill's x planes, and read there the work over the damage's
account is the aligned 2:1's within 2.5 % (the catch: read on the axial layers it is +20 % off); on the aligned 2:1
the x planes read the axial layers' work.
"""
from __future__ import annotations

import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import tension_family as tf   # noqa: E402
import tension_oblique as to  # noqa: E402
import user_oblique as uo     # noqa: E402

from test_user_tension import GRID_TOL, MASS_TOL, N, _names, case_failures   # noqa: E402

BONES = [uo.SPECIMENS["dogbone_2to1"], uo.SPECIMENS["dogbone_1.5to1"]]
ANGLES = ["30", "45"]


def placement_failures(sp, angle: str, ps, mesh) -> list[str]:
    """Where the scene put ``sp`` at ``angle`` against where ``tension_oblique.build`` puts it: the fill's centroid
    at the domain's centre within 1 mm, its points' axial extent ``[0, L]`` and their section's half extents (across
    the turning plane, along z) within one fill spacing ``h`` of the specimen's, its mass within ``MASS_TOL``."""
    st = ps.setup
    x0, pv = np.asarray(st.x, np.float64), np.asarray(st.p_vol, np.float64)
    h = st.dx / ps.scene.domain.particles_per_cell ** (1 / 3)
    local = (x0[pv > 0] - to.CENTRE) @ to.axis_frame(angle)
    geo = uo.geometry(ps, mesh, sp, angle)
    bad = []
    if not geo["fill"]["centre_offset_mm"] <= 1.0:
        bad.append(f"centroid {geo['fill']['centre_offset_mm']:.2f} mm off the centre")
    ext = np.concatenate([[local[:, 0].min() + sp.length / 2, local[:, 0].max() - sp.length / 2],
                          np.abs(local[:, 1:]).max(axis=0) - uo.section_half(sp)])
    if not np.all(np.abs(ext) <= h):
        bad.append(f"extents off by {np.round(ext, 4).tolist()} m (h {h:.4f})")
    if not abs(geo["fill"]["mass_vs_mesh"]) <= MASS_TOL:
        bad.append(f"fill mass {100 * geo['fill']['mass_vs_mesh']:+.2f} %")
    return bad


@pytest.mark.parametrize("angle", ANGLES)
def test_the_scene_puts_the_turned_dog_bone_where_the_hand_built_one_is(angle):
    """The 2:1 dog-bone at n_grid N: measured centroid 0.3 / 0.06 mm off, mass +0.46 / +0.09 % at 30 / 45 deg."""
    sp = BONES[0]
    ps, mesh = uo.prepare(sp, N, _names()[0] if _names() else "taichi_mpm", angle)
    assert placement_failures(sp, angle, ps, mesh) == []


def test_the_scene_holds_on_nodes_and_pulls_along_the_axis(tmp_path):
    """The scene's ``fixed_region`` is the half-space ``x <= c`` and its one set box ``x >= c'`` at ``PULL a`` with
    ``ramp = RAMP_S``, both faces on nodes (within half a cell of the section's corners at ``HOLD``)."""
    from gasp_core.scene.extras import read_extras
    sp, dx = BONES[0], tf.SIZE / N
    for angle in ANGLES:
        text = uo.scene_toml(sp, N, "warp_mpm", "m.ply", angle)
        doc = tomllib.loads(text)
        (imp,) = read_extras(doc, tmp_path / "s.toml", [])["impulses"]
        held = np.array([doc["boundary"][0]["hi"][0], imp.lo[0]])
        assert np.allclose(held / dx, np.round(held / dx), atol=1e-9) and held[0] < to.CENTRE[0] < held[1], held
        assert doc["object"][0]["rotation"] == [90.0, 0.0, float(angle)] and imp.mode == "set"
        assert np.allclose(imp.velocity_change, tf.PULL * to.axis_frame(angle)[:, 0]) and imp.ramp == uo.ut.RAMP_S
        uo.FACES = "corners"
        try:
            corners = uo.faces(sp, angle, dx)
        finally:
            uo.FACES = "nearest"
        assert np.all(np.abs(held - corners) <= dx / 2 + 1e-12), (held, corners)


def test_the_placement_check_catches_the_width_left_along_y(monkeypatch):
    """The catch: the mesh turned about z alone (``rotation = [0, 0, 30]``): the flat dog-bone's width stays along y
    and its thickness along z, so the section's extents in the turned frame are off by 0.075 m."""
    sp, angle = BONES[0], "30"
    scene = uo.scene_toml
    monkeypatch.setattr(uo, "scene_toml",
                        lambda *a, **k: scene(*a, **k).replace("rotation = [90.0,", "rotation = [0.0,"))
    ps, mesh = uo.prepare(sp, N, _names()[0] if _names() else "taichi_mpm", angle)
    bad = placement_failures(sp, angle, ps, mesh)
    assert any("extents" in b for b in bad), bad


def failures(r: dict) -> list[str]:
    """What the must-show finds wrong with one case of :func:`user_oblique.run_case` (along the axis)."""
    tag = f"{r['specimen']} at {r['angle']} deg, {r['engine']} n_grid {r['n_grid']}"
    return case_failures(r, tag, f"s = {r['crack_s']:.3f} m ({r['where']}; gauge {r['gauge']})")


def family_failures(sp, angle: str, name: str) -> list[str]:
    """Every line of the must-show on ``sp`` at ``angle`` built through the scene at n_grid N and 2N, and the work
    within ``GRID_TOL`` between them."""
    r1, r2 = (uo.run_case(sp, n, name, angle) for n in (N, 2 * N))
    bad = failures(r1) + failures(r2)
    if not abs(r2["work"] / r1["work"] - 1) <= GRID_TOL:
        bad.append(f"{sp.name} at {angle} deg: work {r1['work']:.2f} J/m^2 at n_grid {N}, {r2['work']:.2f} at {2 * N}")
    return bad


#: the cases that miss the must-show, with the measured figures (both engines alike to every printed digit;
#: benchmarks/results/user_oblique.md): every one; the hand-built lattice's peaks (tension_oblique) are 0.922-0.955
KNOWN: dict = {
    ("dogbone_2to1", "30"): "peak 0.953 / 0.945 f_t at n_grid 24 / 48 (-4.7 / -5.5 %), in the gauge; work to separate "
                            "25.11 J/m^2 (+26 %, on the x planes) at 24, 21.93 at 48 (round 44's rerun)",
    ("dogbone_2to1", "45"): "peak 0.922 / 0.937 f_t; breaks at axial 0.561 m (held edge, the gauge 0.361-0.539) at 24 "
                            "and 0.311 (grip, its section +2.3 %) at 48 (round 53's rerun)",
    ("dogbone_1.5to1", "30"): "peak 0.956 / 0.948 f_t (-4.4 / -5.2 %), in the gauge; work 23.20 J/m^2 at 24, 30.15 "
                              "(+51 %, no layer broken through, axial or x) at 48 (round 44's rerun)",
    ("dogbone_1.5to1", "45"): "peak 0.920 / 0.936 f_t; breaks at axial 0.606 m (held edge; 0.583 and 0.606 both at "
                              "d = 1, round 45's crack_layer names the later) at 24; at 48 the held edge at 0.278 m "
                              "the most damaged, not broken through (work 22.53 J/m^2; round 40's image gradient by "
                              "mass: rounds 37-39 broke through at the pulled grip's held edge; round 53's rerun)",
}


@pytest.mark.slow
@pytest.mark.parametrize("sp, angle, name", [
    pytest.param(sp, ang, n, id=f"{n}-{ang}-{sp.name}",
                 marks=[pytest.mark.xfail(strict=True, reason=KNOWN[sp.name, ang])] if (sp.name, ang) in KNOWN else [])
    for sp in BONES for ang in ANGLES for n in _names()])
def test_each_oblique_dog_bone_built_through_the_scene_carries_f_t_breaks_in_its_gauge_and_takes_G_f(sp, angle, name):
    bad = family_failures(sp, angle, name)
    assert bad == [], bad


#: round 44, the pull's set box ``constrain = "along"``: the cases that miss the must-show, with the measured figures
#: (benchmarks/results/user_oblique.md; docs/fracture.md "Round 44")
KNOWN_ALONG: dict = {
    "dogbone_1.5to1": "peak 0.978 / 0.976 f_t at n_grid 24 / 48, in the gauge at both; work to separate 24.64 J/m^2 "
                      "(+23.2 %) at 24, 21.42 (+7.1 %) at 48 (-13.1 % between): the work at N misses, as on round 40's "
                      "free grips (24.05, +20.3 %): round 34's band across a 45 deg crack",
}


def along_failures(sp, angle: str, name: str) -> list[str]:
    """:func:`family_failures` with the pull's set box ``constrain = "along"`` (``user_oblique.CONSTRAIN``)."""
    uo.CONSTRAIN = "along"
    try:
        return family_failures(sp, angle, name)
    finally:
        uo.CONSTRAIN = "all"


@pytest.mark.slow
@pytest.mark.parametrize("sp, name", [
    pytest.param(sp, n, id=f"{n}-45-{sp.name}",
                 marks=[pytest.mark.xfail(strict=True, reason=KNOWN_ALONG[sp.name])] if sp.name in KNOWN_ALONG else [])
    for sp in BONES for n in _names()])
def test_each_oblique_dog_bone_on_a_grip_free_across_its_pull_carries_f_t_and_breaks_in_its_gauge(sp, name):
    bad = along_failures(sp, "45", name)
    assert bad == [], bad


#: the work to separate over the damage's own account over its zone, at 30 deg against the aligned dog-bone's (round
#: 44): the aligned 2:1 through the scene reads 20.56 against 18.67 J/m^2 (1.102: the snap-back's share, not traced;
#: 21.00 and 1.125 before round 45's crack_layer named the later of two layers at d = 1, round 53's rerun); the 30 deg
#: 2:1 on the x planes 24.51 against 22.18 (1.105, +0.3 % of the aligned ratio; -1.8 % in round 44); on the axial
#: layers, the measure before, 29.94 (1.35, +22.5 %). Two-sided, and a 5 % bias fails it.
BIAS_TOL = 0.025


def along_case(sp, angle: str, n: int, name: str) -> dict:
    """:func:`user_oblique.run_case` with the pull's set box ``constrain = "along"``."""
    uo.CONSTRAIN = "along"
    try:
        return uo.run_case(sp, n, name, angle)
    finally:
        uo.CONSTRAIN = "all"


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_work_to_separate_at_30_deg_is_read_on_the_planes_the_crack_runs_along(name):
    """Round 44 (docs/fracture.md "The work to separate at 30 deg"): the 2:1 at 30 deg on a grip free across its pull,
    n_grid N. Its crack runs along the fill's x planes, across the axial layers, none of which breaks through; read on
    the x planes (``crack_layers``) its work over the damage's account is the aligned 2:1's within ``BIAS_TOL`` (the
    known answer: aligned, the x planes are normal to the axis and read the axial layers' work, within ``BIAS_TOL``).
    The catch: read on the axial layers (``work_axial``, the measure before) the ratio is +20 % off and fails."""
    ref = along_case(BONES[0], "0", N, name)
    assert ref["broken_through"] and ref["work_on"] == "axial" and ref["work_x"] is not None, ref
    assert abs(ref["work_x"] / ref["work"] - 1) <= BIAS_TOL, (ref["work_x"], ref["work"])
    bias = ref["work"] / ref["dissipated"]
    r = along_case(BONES[0], "30", N, name)
    assert not r["broken_through"] and r["work_on"] == "x planes", r
    assert abs(r["work"] / r["dissipated"] / bias - 1) <= BIAS_TOL, (r["work"], r["dissipated"], bias)
    assert abs(r["work_axial"] / r["dissipated"] / bias - 1) > BIAS_TOL, (r["work_axial"], r["dissipated"], bias)
