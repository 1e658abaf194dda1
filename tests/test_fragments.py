"""Stiff brittle bodies break into fragments (issue 66 item 5; gasp_core/run/fragments.py,
gasp_core/mpm/fracture_table.py; docs/fracture.md "Stiff brittle bodies: fragments").

No engine here: the handbook table and its scene key, Grady's size law over a family of speeds and fracture
energies, the break test's two thresholds, the Voronoi split of a ring (a hollow body whose cells hold two walls)
and the cut between fragments. Each check is two-sided and a broken variant is shown to fail it.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.scene.tables import read_material
from gasp_core.seam.setup import Material
from gasp_core.run import fragments as fr
from gasp_core.mpm.fracture_table import BRITTLE_SUBSTANCES, SUBSTANCE_KEYS


def porcelain() -> Material:
    s = BRITTLE_SUBSTANCES["porcelain"]
    return Material(name="brittle", E=s.E, nu=s.nu, rho=s.rho, tensile_strength=s.tensile_strength,
                    fracture_energy=s.fracture_energy, model="rigid")


def test_table_rows_are_physical_and_sourced():
    """Every row: E, rho, f_t, G_f in broad physical ranges and a source; Hillerborg's characteristic length
    ``l_ch = E G_f / f_t^2`` sorts them as the literature does: concrete 150-500 mm (Bazant & Planas 1998: about
    200-400), the glass and the porcelain below 5 mm (brittle at a cup's scale), wood and granite in between."""
    assert set(BRITTLE_SUBSTANCES) >= {"porcelain", "soda_lime_glass", "granite", "concrete", "wood_across_grain"}
    for name, s in BRITTLE_SUBSTANCES.items():
        assert 5e8 <= s.E <= 1e11 and 300 <= s.rho <= 3000, name
        assert 1e6 <= s.tensile_strength <= 1e8 and 1.0 <= s.fracture_energy <= 500.0, name
        assert len(s.source) > 40, name
    l_ch = {k: s.E * s.fracture_energy / s.tensile_strength ** 2 for k, s in BRITTLE_SUBSTANCES.items()}
    assert 0.15 <= l_ch["concrete"] <= 0.5
    assert l_ch["soda_lime_glass"] < 0.005 and l_ch["porcelain"] < 0.005
    assert 0.005 < l_ch["wood_across_grain"] < 0.15 and 0.005 < l_ch["granite"] < 0.15
    glass = BRITTLE_SUBSTANCES["soda_lime_glass"]
    assert glass.fracture_energy == pytest.approx((0.75e6) ** 2 / glass.E, rel=0.01)   # K_Ic 0.75, as its source


def test_substance_key_fills_the_material(tmp_path):
    """``substance`` fills the keys the table gives and the scene does not; the scene's own win; another material
    or an unknown name is refused by name."""
    m = read_material({"name": "brittle", "substance": "porcelain"}, "object.material", tmp_path / "s.toml")
    row = BRITTLE_SUBSTANCES["porcelain"]
    assert [getattr(m, k) for k in SUBSTANCE_KEYS] == [getattr(row, k) for k in SUBSTANCE_KEYS]
    assert m.restitution == 0.9 and m.model == "auto"   # the glass figure its E and rho fall in (restitution table)
    m2 = read_material({"name": "brittle", "substance": "porcelain", "E": 6.0e10}, "object.material",
                       tmp_path / "s.toml")
    assert m2.E == 6.0e10 and m2.rho == row.rho
    with pytest.raises(SceneError, match="substance"):
        read_material({"name": "jelly", "substance": "porcelain"}, "object.material", tmp_path / "s.toml")
    with pytest.raises(SceneError, match="porcelain"):
        read_material({"name": "brittle", "substance": "china"}, "object.material", tmp_path / "s.toml")


def test_stiff_brittle_skips_the_crack_band_check():
    """Porcelain at its handbook f_t and G_f is below the crack band's snap-back limit at a 5 mm grid (93 J/m^2):
    on the rigid route it is accepted; forced elastic it is refused as before."""
    m = porcelain()
    m.check_band(0.008)
    with pytest.raises(SceneError, match="snap-back"):
        replace(m, model="elastic").check_band(0.008)


def test_grady_size_follows_its_law():
    """``s = (24 G_f / (rho epsdot^2))^(1/3)``: over a family of strain rates and fracture energies the size scales
    as ``epsdot^(-2/3)`` and ``G_f^(1/3)`` (fitted exponents within 1e-9), and equals the toughness form
    ``(sqrt(24) K_Ic / (rho c epsdot))^(2/3)`` with ``K_Ic = sqrt(E G_f)``. A size law with the exponent 1/2
    instead is caught."""
    rates = np.array([10.0, 30.0, 100.0, 300.0, 1000.0])
    sizes = np.array([fr.grady_size(2400.0, 20.0, r) for r in rates])
    slope = np.polyfit(np.log(rates), np.log(sizes), 1)[0]
    assert slope == pytest.approx(-2.0 / 3.0, abs=1e-9)
    energies = np.array([1.0, 10.0, 100.0])
    s_g = np.array([fr.grady_size(2400.0, g, 50.0) for g in energies])
    assert np.polyfit(np.log(energies), np.log(s_g), 1)[0] == pytest.approx(1.0 / 3.0, abs=1e-9)
    E, rho, G = 7e10, 2400.0, 20.6
    k_ic, c = math.sqrt(E * G), math.sqrt(E / rho)
    assert fr.grady_size(rho, G, 57.0) == pytest.approx((math.sqrt(24) * k_ic / (rho * c * 57.0)) ** (2 / 3), rel=1e-12)
    assert fr.grady_size(rho, G, 0.0) == math.inf
    broken = np.array([(24 * 20.0 / (2400.0 * r * r)) ** 0.5 for r in rates])
    assert abs(np.polyfit(np.log(rates), np.log(broken), 1)[0] + 2 / 3) > 0.1


def test_break_check_thresholds():
    """The cup (0.54 kg, 226 cm^3, 8 cm across): at 4.43 m/s the plane-wave stress 57 MPa is over porcelain's
    40 MPa and it breaks into a few fragments of about 4 cm; at 2.5 m/s (32 MPa) it does not; at 20 m/s it breaks
    finer (more fragments, smaller); every count's cracks are paid by the energy; a body whose approach energy
    cannot pay two fragments' crack does not break whatever its stress."""
    m = porcelain()
    c = math.sqrt(m.E / m.rho)
    one = fr.break_check(m, 0.54, 2.26e-4, 0.08, 4.43)
    assert one["breaks"] and one["stress"] == pytest.approx(m.rho * c * 4.43)
    assert 2 <= one["count"] <= 8 and 0.03 < one["size"] < 0.05
    assert not fr.break_check(m, 0.54, 2.26e-4, 0.08, 2.5)["breaks"]
    fast = fr.break_check(m, 0.54, 2.26e-4, 0.08, 20.0)
    assert fast["breaks"] and fast["count"] > one["count"] and fast["size"] < one["size"]
    for rec in (one, fast):
        assert 0.0 < rec["crack_energy"] <= rec["energy"]
    tough = replace(m, fracture_energy=5e4)   # a crack costs more than the cup's 5.3 J
    assert not fr.break_check(tough, 0.54, 2.26e-4, 0.08, 4.43)["breaks"]


def ring(n_theta: int = 72, n_r: int = 3, n_z: int = 6, r0: float = 0.03, h: float = 0.004) -> np.ndarray:
    """Points of a ring (a cup's wall without its base), spacing about ``h``; m."""
    pts = [((r0 + i * h) * math.cos(t), (r0 + i * h) * math.sin(t), k * h)
           for i in range(n_r) for k in range(n_z) for t in np.linspace(0, 2 * math.pi, n_theta, endpoint=False)]
    return np.array(pts)


def test_split_ring_into_connected_fragments():
    """A ring split into 4 cells: every fragment is one connected part (its points' rest links, 1.5 spacings, join
    it), fragments are numbered largest first, every point has one, passive points take their nearest material
    point's; cells drawn near the impact are smaller. A split that skips the connected parts (a cell's two walls
    one fragment) is caught by the connectivity check."""
    x = ring()
    material = np.ones(len(x), bool)
    material[::10] = False
    spacing = 0.0027
    impact = np.array([0.035, 0.0, 0.0])
    frag = fr.split_body(x, material, spacing, impact, 4, 0.02, seed=3)
    assert frag.min() == 0 and frag.max() >= 3
    counts = np.bincount(frag[material])
    assert np.all(np.diff(counts) <= 0)

    def connected(lab):
        from scipy.sparse.csgraph import connected_components
        from scipy.spatial import cKDTree
        from scipy.sparse import coo_matrix
        idx = np.flatnonzero(material)
        ok = True
        for f in np.unique(lab[idx]):
            p = idx[lab[idx] == f]
            pairs = cKDTree(x[p]).query_pairs(1.5 * spacing, output_type="ndarray")
            g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(p), len(p)))
            ok &= connected_components(g, directed=False)[0] == 1
        return ok
    assert connected(frag)
    # the broken variant: a plain Voronoi split whose cells each hold two opposite arcs of the ring (two seeds on
    # the axis: each cell is a pair of opposite quadrants)
    bad = ((x[:, 0] > 0) ^ (x[:, 1] > 0)).astype(np.int64)
    assert not connected(bad)


def test_cut_damage_separates_the_fragments():
    """The cut marks exactly the material points with a rest neighbour in another fragment (both sides); with it the
    pieces' labelling (gasp_core.run.pieces) finds as many pieces as fragments once they have come apart (fragment f moved
    2f cm along x, past the 5 mm gap), without it one; in place, unmoved, one (pieces are the parts
    that have come apart, issue 66 item 4)."""
    from gasp_core.run.pieces import PieceTracker
    x = ring()
    material = np.ones(len(x), bool)
    frag = fr.split_body(x, material, 0.0027, np.array([0.035, 0.0, 0.0]), 4, 0.02, seed=3)
    d = fr.cut_damage(x, frag, material, 0.0027)
    assert 0 < d.sum() < 0.5 * len(x)
    vol = np.full(len(x), 0.0027 ** 3)
    apart = x.copy()
    for f in range(frag.max() + 1):
        apart[frag == f] += [0.02 * f, 0.0, 0.0]
    def pieces(at, damage):
        return PieceTracker(x, np.zeros(len(x), int), vol * 2400.0, vol, gap=0.005).row(at, damage)[0]["pieces"]
    assert pieces(apart, d) == frag.max() + 1
    assert pieces(apart, None) == 1 and pieces(x, d) == 1


def test_ground_hit_is_free_fall():
    """A body 2 cm over the ground at 20 m/s down meets it within a 1/30 s frame at ``sqrt(v^2 + 2 g h)``; at rest
    1 m up it does not within the frame (it takes 0.45 s), and does within 0.5 s at 4.43 m/s; one moving up and away
    from a ground below it at 20 m/s does not (the root lies past the frame)."""
    from gasp_core.run.fragment_run import ground_hit
    assert ground_hit(0.02, -20.0, 9.81, 1 / 30) == pytest.approx(math.sqrt(400 + 2 * 9.81 * 0.02))
    assert ground_hit(1.0, 0.0, 9.81, 1 / 30) is None
    assert ground_hit(1.0, 0.0, 9.81, 0.5) == pytest.approx(4.43, abs=0.01)
    assert ground_hit(0.02, 20.0, 9.81, 1 / 30) is None
    assert ground_hit(-0.01, -5.0, 9.81, 1 / 30) is None


def test_split_bodies_makes_the_pieces_the_fragments():
    """Told the fragments (``PieceTracker.split_bodies``, what a run's tracker is told at the break), the pieces are
    exactly the fragments without any damage, every point in its own fragment's piece (a mass-weighted match of 1);
    an untold tracker sees the ring whole (one piece)."""
    from gasp_core.run.pieces import PieceTracker
    x = ring()
    material = np.ones(len(x), bool)
    material[::10] = False
    frag = fr.split_body(x, material, 0.0027, np.array([0.035, 0.0, 0.0]), 4, 0.02, seed=3)
    vol = np.where(material, 0.0027 ** 3, 0.0)
    tracker = PieceTracker(x, np.zeros(len(x), int), vol * 2400.0, vol, gap=0.005)
    assert tracker.row(x, None)[0]["pieces"] == 1
    tracker.split_bodies(frag)
    lab = tracker.labels(x, None)
    assert len(np.unique(lab)) == frag.max() + 1
    pairs = np.unique(np.stack([lab, frag], 1), axis=0)
    assert len(pairs) == frag.max() + 1   # one fragment per piece and one piece per fragment
