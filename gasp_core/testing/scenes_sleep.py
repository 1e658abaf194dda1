"""Conformance scene of sleep per body (issue 39, item 1; :mod:`gasp_core.seam.body_sleep`): a sleeping body wakes
when a second body lands on it, and moves as it would have awake.

``ball_wakes_ball``: two soft balls (the ball of ``scenes_contact``: ``R`` = 5 cm, jelly E 2e4 Pa, nu 0.3, rho 300,
points at dx / 2, with a Kelvin-Voigt viscosity of ``ETA`` = 2 Pa s so that it settles within about 20 frames) on a
ground with friction 0.5. Ball A is set down with its lowest points dx / 4 above the ground (as ``scenes_rest``'s
slab) and settles; ball B starts ``GAP_B`` = 10 cm above A's top, thrown straight up at the speed that brings it
back onto A at ``T_LAND`` = 0.39 s (projectile motion, ``v0 = g T / 2 - GAP_B / T``): about 20 frames after A has
fallen asleep (frames of 1/120 s). The scene is run twice, with sleep and without; the checks:

- ``slept_first``: A slept at least ``MIN_ASLEEP`` = 10 frames before it woke (``RunStats.bodies``), and it did not
  wake before B came down past the height of its apex (a spurious wake is not a wake by B);
- ``woke_in_time``: when A woke, no point of B was within ``3 dx`` of a point of A (their grid stencils, 3 nodes
  wide, shared no node yet: B had not touched A);
- ``impact_depth``: A's centroid's deepest descent after it fell asleep (B's impact), over the awake run's, within
  ``[0.95, 1.05]``;
- ``impact_path``: A's centroid, frame by frame after it fell asleep, within ``PATH_TOL`` = 0.1 dx of the awake run's;
- ``no_pass_through``: B's lowest point stays above A's highest point less ``SKIN`` = 0.5 dx in every frame.

A watch that never wakes fails all five: B falls through the frozen A; an engine that ignores the wake all but the
first (``tests/test_body_sleep.py``).
The domain is 32 cells of the default 10 cm object's dx (0.6 m), the ground 3 cells above its bottom.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.runner import RunStats, run_engine
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import Check, check, GRAVITY, sphere_points
from gasp_core.testing.kit import Requires, Scene
from gasp_core.testing.scenes_contact import R
from gasp_core.testing.scenes_rest import DX, GROUND_H

N_GRID = 32
SIDE = N_GRID * DX
LO = np.array([-SIDE / 2, -SIDE / 2, GROUND_H - 3 * DX])
FRAME_DT = 1.0 / 120.0
#: Viscosity of the balls, Pa s (docs/dissipation.md): damps A's ringing so that it rests within ~20 frames.
ETA = 2.0
BALL = Material("jelly", E=2e4, nu=0.3, rho=300.0, viscosity=ETA)
GAP_B = 0.10
T_LAND = 0.39
N_FRAMES = 70
MIN_ASLEEP = 10
PATH_TOL = 0.1
DEPTH_BAND = (0.95, 1.05)
SKIN = 0.5


def build(info: EngineInfo | None = None, spacing: float = DX / 2) -> SimSetup:
    """The two balls (body 0: A, body 1: B) on the ground, B thrown up (see the module docstring); points
    ``spacing`` m apart (a finer spacing: more points, for ``benchmarks/bench_body_sleep.py``)."""
    c = np.array([0.3 * DX, 0.2 * DX, 0.0])
    xa, va = sphere_points(c, R, spacing)
    xa[:, 2] += GROUND_H + DX / 4 - xa[:, 2].min()
    xb = xa.copy()
    xb[:, 2] += xa[:, 2].max() + GAP_B - xb[:, 2].min()
    body = np.r_[np.zeros(len(xa)), np.ones(len(xb))].astype(np.int32)
    v = np.zeros((2 * len(xa), 3))
    v[body == 1, 2] = GRAVITY * T_LAND / 2 - GAP_B / T_LAND
    return SimSetup(x=np.concatenate([xa, xb]), v=v, p_vol=np.full(2 * len(xa), va), body_id=body,
                    materials=[BALL, BALL], gravity=np.array([0.0, 0.0, -GRAVITY]), domain_lo=LO, domain_hi=LO + SIDE,
                    n_grid=N_GRID, boundaries=[Boundary("ground", height=GROUND_H, friction=0.5)], frame_dt=FRAME_DT)


def frames(info: EngineInfo, setup: SimSetup, sleep: bool, n: int = N_FRAMES) -> tuple[np.ndarray, RunStats]:
    """Positions of frames 0..n, shape (n + 1, n_points, 3), m, and the run's statistics."""
    stats = RunStats()
    xs = [setup.x.copy()] + [np.array(r.x) for r in run_engine(info, setup, n, stats, sleep=sleep)]
    return np.stack(xs), stats


def ball_checks(setup: SimSetup, awake: np.ndarray, asleep: np.ndarray, stats: RunStats) -> list[Check]:
    """The five checks of the module docstring from the two runs' frames and the sleeping run's statistics."""
    a, b = setup.body_id == 0, setup.body_id == 1
    rec = stats.bodies[0] if stats.bodies else {"slept_after_frames": [], "woke_before_frames": []}
    slept, woke = rec["slept_after_frames"], rec["woke_before_frames"]
    ks = slept[0] if slept else 0   # 0: never slept (the windows below then span the whole run)
    kw = next((f for f in woke if f > ks), None) if slept else None
    apex = int(np.argmax(awake[:, b, 2].mean(axis=1)))
    n_asleep = ((len(asleep) - 1 if kw is None else kw - 1) - ks) if slept else 0
    out = [Check("slept_first", bool(n_asleep >= MIN_ASLEEP and kw is not None and kw > apex),
                 f"frames A slept = {n_asleep} (after frame {ks}, woke before frame {kw}; B's apex at frame {apex}; "
                 f"at least {MIN_ASLEEP}, and woken after the apex)",
                 {"value": float(n_asleep), "lo": float(MIN_ASLEEP), "hi": float(len(asleep)), "ks": ks,
                  "kw": -1 if kw is None else kw, "apex": apex})]
    xa, xb = asleep[-1 if kw is None else kw - 1][a], asleep[-1 if kw is None else kw - 1][b]
    dist = float(np.sqrt(((xa[:, None, :] - xb[None, :, :]) ** 2).sum(axis=2)).min()) / DX
    out.append(check("woke_in_time", 3.0 - dist if kw is not None else float("inf"), 0.0,
                     "3 dx less the least distance from B to A when A woke (inf: never woken), dx", distance=dist))
    # what sleep changed: every frame after A fell asleep
    ca_sleep, ca_awake = (x[ks + 1:, a, 2].mean(axis=1) - x[0, a, 2].mean() for x in (asleep, awake))
    depth = float(-ca_sleep.min()) / max(float(-ca_awake.min()), 1e-12)
    lo, hi = DEPTH_BAND
    out.append(Check("impact_depth", bool(lo <= depth <= hi), f"A's deepest centroid descent after it slept over "
                     f"the awake run's = {depth:.4f} (awake {-ca_awake.min() / DX:.3f} dx; band [{lo}, {hi}])",
                     {"value": depth, "lo": lo, "hi": hi}))
    path = float(np.linalg.norm(asleep[ks + 1:, a].mean(axis=1) - awake[ks + 1:, a].mean(axis=1), axis=1).max()) / DX
    out.append(check("impact_path", path, PATH_TOL, "A's centroid after it slept, farthest from the awake run's, dx"))
    gap = float((asleep[:, b, 2].min(axis=1) - asleep[:, a, 2].max(axis=1)).min()) / DX
    out.append(check("no_pass_through", -gap, SKIN, "minus the least height of B's lowest point over A's top, dx",
                     gap_awake=float((awake[:, b, 2].min(axis=1) - awake[:, a, 2].max(axis=1)).min()) / DX))
    return out


def run(info: EngineInfo) -> list[Check]:
    """Both runs of ``ball_wakes_ball`` and :func:`ball_checks`."""
    setup = build(info)
    awake, _ = frames(info, setup, sleep=False)
    asleep, stats = frames(info, setup, sleep=True)
    return ball_checks(setup, awake, asleep, stats)


SCENES_SLEEP: list[Scene] = [
    Scene("ball_wakes_ball", "a soft ball asleep on the ground wakes when a second ball lands on it and moves as it "
          f"would awake (depth within {DEPTH_BAND}, path within {PATH_TOL} dx; B never more than {SKIN} dx into A)",
          Requires(frozenset({"jelly"}), frozenset({"ground"}), frozenset({"sleep", "viscosity"})), run=run),
]
