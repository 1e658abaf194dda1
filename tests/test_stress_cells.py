"""Cells seeded by the impact and the stress (``gasp_core.run.stress_cells``; issue 66 item 5; ``docs/fracture.md``
"Round 103: cells seeded by the impact and the stress").

Default tier: the probe's parts on bodies whose damage is set by hand as a landing leaves it (a crack through a bar,
a crushed end, dust, no damage) and the intersection with Grady's cells. Slow tier: the donut shatter example
(``examples/donut_shatter.toml``, the README donut landing on its edge) over landing speeds on both MPM engines: its
pieces of 5 % or more never decrease from 4.43 to 10 m/s (with Grady's cells alone they fall from 4 to 3 at 5.5 m/s:
the catch). A blow-up in the probe is reported at the run's frame.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gasp_core.run import grady_cells
from gasp_core.run.stress_cells import PART_SHARE, cells_of_parts, union, unbroken_parts
from gasp_core.testing.helpers import box_points

SPACING = 0.01


def bar():
    """A 0.2 x 0.04 x 0.04 m lattice bar at spacing 1 cm along x: points (n, 3), material, masses (1 kg each)."""
    x, _ = box_points((0.0, 0.0, 0.0), (0.2, 0.04, 0.04), SPACING)
    return x, np.ones(len(x), bool), np.ones(len(x))


def parts_of(x, mat, m, d, reach=0.02):
    return cells_of_parts(x, mat, m, *unbroken_parts(x, mat, m, d, SPACING), SPACING, reach)


def test_a_crack_through_a_bar_gives_its_two_halves():
    x, mat, m = bar()
    d = np.where(np.abs(x[:, 0] - 0.105) < 0.006, 1.0, 0.0)   # one layer broken through at x = 0.105 m
    part = parts_of(x, mat, m, d)
    assert part is not None and part.max() == 1
    left, right = x[:, 0] < 0.1, x[:, 0] > 0.11
    assert len(np.unique(part[left])) == 1 and len(np.unique(part[right])) == 1 and part[left][0] != part[right][0]
    # the crack's own layer joins the nearest half: every point has a part
    assert (part >= 0).all()


def test_a_crushed_end_is_a_part_of_its_own_and_a_band_joins_its_neighbour():
    x, mat, m = bar()
    d = np.where(x[:, 0] < 0.06, 1.0, 0.0)   # the first 6 cm crushed (30 % of the mass)
    part = parts_of(x, mat, m, d)
    assert part is not None and part.max() == 1
    assert len(np.unique(part[x[:, 0] < 0.03])) == 1 and part[0] != part[-1]
    # within the reach (2 cm) of the unbroken part, the broken points join it
    near = (x[:, 0] > 0.045) & (x[:, 0] < 0.06)
    assert (part[near] == part[-1]).all()
    # a band narrower than the reach is not a part: one part, None
    d = np.where(x[:, 0] < 0.015, 1.0, 0.0)
    assert parts_of(x, mat, m, d) is None


def test_dust_and_an_undamaged_body_give_no_parts():
    x, mat, m = bar()
    assert parts_of(x, mat, m, np.ones(len(x))) is None     # all broken: one crushed part
    assert parts_of(x, mat, m, np.zeros(len(x))) is None    # whole: one part


def test_parts_under_the_share_are_not_parts():
    x, _ = box_points((0.0, 0.0, 0.0), (0.3, 0.04, 0.04), SPACING)   # 30 layers
    mat, m = np.ones(len(x), bool), np.ones(len(x))
    d = np.where(np.abs(x[:, 0] - 0.015) < 0.006, 1.0, 0.0)   # the second layer broken: the end layer 3.3 % apart
    share = unbroken_parts(x, mat, m, d, SPACING)[1]
    assert sorted(np.round(share, 4)) == [0.0333, 0.9333]
    # within a band's reach of the bar, the end and its crack join the bar: one part
    assert parts_of(x, mat, m, d, reach=0.02) is None
    # with no reach the end and its crack (6.7 % together) are a part of their own
    part = parts_of(x, mat, m, d, reach=0.0)
    assert part is not None and np.bincount(part).min() == 32


def test_the_union_cuts_gradys_cells_by_the_parts():
    x, mat, _ = bar()
    grady = (x[:, 0] > 0.1).astype(int)
    parts = (x[:, 1] > 0.02).astype(int)
    cell = union(x, mat, SPACING, grady, parts)
    assert cell.max() == 3
    for a in (0, 1):
        for b in (0, 1):
            sel = (grady == a) & (parts == b)
            assert len(np.unique(cell[sel])) == 1


class _Diverging:
    """An engine that blows up at its second frame (the error contract's report, as the MPM engines raise it)."""

    def __init__(self, n: int):
        self.frame, self.n = 0, n

    def step_frame(self):
        from gasp_core.errors import EngineDivergence
        self.frame += 1
        if self.frame == 2:
            raise EngineDivergence("3 point(s) non-finite (first index 0)", self.frame, "time step too large")

    def damage(self):
        return np.zeros(self.n)

    def close(self):
        self.closed = True


def test_a_blow_up_in_the_probe_names_the_runs_frame_and_the_probe(monkeypatch):
    """Round 104: the probe's engine counts from 1 at the frame the run stands at; its blow-up is the run's frame
    plus its own, named as the probe's, and its engine is closed."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.run import stress_cells
    from gasp_core.seam import build
    from gasp_core.testing.scenes_pieces import ball_setup
    setup = ball_setup(4.0, 28)
    engine = _Diverging(len(setup.x))
    monkeypatch.setattr(build, "build_engine", lambda info, setup: engine)
    with pytest.raises(EngineDivergence) as err:
        stress_cells.probe(None, setup, 0.02, frame=5)
    assert err.value.frame == 7 and "landing's probe" in str(err.value), str(err.value)
    assert err.value.cause == "time step too large" and engine.closed
    assert str(err.value).startswith("frame 7: in the landing's probe")


SCENE = Path(__file__).resolve().parents[1] / "examples" / "donut_shatter.toml"
#: The donut shatter example's landing speeds, m/s: 4.43 (its own; Grady's fragments do not fit it twice, no cells),
#: 5.5, 7 and 10 (laid out in cells).
RING_SPEEDS = (4.43, 5.5, 7.0, 10.0)
#: Read at frame 6, once the count has stopped: at 10 m/s the largest piece parts at frame 5 (round 104: at frame 3 it
#: read 6 pieces of 5 % against 7 at 7 m/s; at frames 5-6, 7 and 7, warp_mpm, taichi_mpm 7).
FRAMES = 6


def ring_pieces(engine: str, speed: float, out: Path, n_grid: int = 64) -> tuple[int, list]:
    """The donut shatter example thrown at ``speed`` m/s on ``n_grid`` (its own: 64) with the cells on: its pieces
    of 5 % or more at frame :data:`FRAMES` and the run's ``fragments`` records."""
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    text = SCENE.read_text().replace(
        "velocity = [0.0, 0.0, -4.43]", f"velocity = [0.0, 0.0, {-speed}]")
    text = text.replace('file = "data/', f'file = "{SCENE.parent / "data"}/')
    text = text.replace("n_grid = 64 ", f"n_grid = {n_grid} ")
    path = out.with_suffix(".toml")
    path.write_text(text)
    simulate_scene(load_scene(path), out, n_frames=FRAMES, engine=engine, quiet=True)
    run = json.loads((out / "run.json").read_text())
    last, total = run["frames"][-1], run["frames"][0]["piece_mass"][0]
    return sum(p >= 0.05 * total for p in last["piece_mass"]), run.get("fragments", [])


def ring_failures(engine: str, tmp_path: Path, n_grid: int = 64) -> list[str]:
    counts, bad = [], []
    for v in RING_SPEEDS:
        n, frags = ring_pieces(engine, v, tmp_path / f"ring_{v}", n_grid)
        counts.append(n)
        if v > 4.43 and (not frags or frags[0]["seeded"] != "impact and stress"):
            bad.append(f"{v} m/s: not seeded by the stress ({frags})")
    if any(b < a for a, b in zip(counts, counts[1:])) or counts[0] < 3:
        bad.append(f"pieces of 5 % at {RING_SPEEDS} m/s: {counts}")
    return bad


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_the_rings_pieces_never_decrease_with_speed(engine, tmp_path):
    pytest.importorskip(f"gasp_{engine}")
    assert ring_failures(engine, tmp_path) == []


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="not met (round 104): on n_grid 48 the ring's pieces of 5 % at frame 6 are "
                   "4, 6, 5, 7 at 4.43, 5.5, 7, 10 m/s (warp_mpm): at 7 m/s one cell holds 40 % of the mass. The "
                   "count of one draw of the cells moves by 1-2 with the draw: at 5.5 / 7 m/s draws 0-3 give 6 / 5, "
                   "6 / 6, 5 / 6, 4 / 8 (docs/fracture.md \"Round 104\")")
def test_the_rings_pieces_never_decrease_with_speed_on_n_grid_48(tmp_path):
    pytest.importorskip("gasp_warp_mpm")
    assert ring_failures("warp_mpm", tmp_path, 48) == []


@pytest.mark.slow
def test_the_ring_check_catches_gradys_cells_alone(tmp_path, monkeypatch):
    """The catch: no probe (round 102's cells, seeded around the impact point alone): the ring's 4 quarters at 4.43 m/s
    fall to 3 pieces at 5.5 m/s (warp_mpm)."""
    pytest.importorskip("gasp_warp_mpm")
    monkeypatch.setattr(grady_cells, "probe", lambda info, setup, spacing: (None, {}))
    assert any(b.startswith("pieces of 5 %") for b in ring_failures("warp_mpm", tmp_path))


#: A lattice torus (R 0.1 m, tube 3.5 cm, the example's biscuit) on its edge, n_grid 64: the ring's neighbour built
#: apart from the scan (``gasp_core.testing.scenes_pieces.ring_setup``).
TORUS = "ring:0.1:0.035"


def torus_failures(engine: str, probed: bool = True) -> tuple[list, list]:
    """The torus at the family's speeds (1, 2, 4, 7, 10 m/s), laid out as a run lays it (``probed``: with the probe,
    else Grady's cells alone): its pieces of 5 % at frame 12 and what breaks the row (a decrease with speed)."""
    import warnings
    from gasp_core.run.grady_cells import laid
    from gasp_core.seam.plugins import engines
    from gasp_core.testing.scenes_pieces import SPEEDS, counted_run, shape_setup
    counts = []
    for v in SPEEDS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s, _ = laid(shape_setup(TORUS, v, 64), info=engines()[engine] if probed else None)
        counts.append(counted_run(engine, s, 12)["tracker_5"][-1])
    bad = [f"pieces of 5 % at 1-10 m/s: {counts}"] if any(b < a for a, b in zip(counts, counts[1:])) else []
    return counts, bad


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_a_torus_rings_pieces_never_decrease_with_speed(engine):
    """Measured (warp_mpm): 1, 3, 4, 6, 7 (cells laid from 7 m/s; Grady's alone 1, 3, 4, 3, 5)."""
    pytest.importorskip(f"gasp_{engine}")
    counts, bad = torus_failures(engine)
    assert bad == [] and counts[-1] >= 3, counts


@pytest.mark.slow
def test_the_torus_check_catches_gradys_cells_alone():
    pytest.importorskip("gasp_warp_mpm")
    assert torus_failures("warp_mpm", probed=False)[1] != []

