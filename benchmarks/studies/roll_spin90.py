"""Round 90 (issue 67 item 2 on a turning ``[[collider]]``, ``docs/rigid.md`` "Round 90: round bodies on moving
colliders"): a rigid ball set at rest on a collider that turns (``[[collider]] angular_velocity``), against closed
forms and the rigid-body equations; ``roll_belt90.py`` holds the colliders that slide.

**The turntable** (balls only). A square plate 1.0 x 1.0 x 0.1 m turns at ``OMEGA`` 3 rad/s about the vertical
(``[[collider]] angular_velocity``); the ball starts at rest ``R0`` 0.1 m off its axis. Once it rolls, its centre
circles the axis at ``k Omega / (1 + k)`` (2/7 of the table's for a solid sphere) at the radius it started at (Ehrlich
& Tuszynski 1995, Am. J. Phys. 63, 351). Figures: the rate fitted over ``TURN_T`` s and the mean radius. The family:
R 0.05 and 0.1 m, n_grid 32 and 48, mu 0.05 and 0.5.

**The drum** (balls only). A ball set at rest at the bottom of a drum of radius 0.25 m turning at 5 rad/s about its
horizontal axis: the friction's slip spins it up and throws it up the wall, then it rolls as the bowl's pendulum (the
wall's speed drops out). Its first swing (peak, half period) against the rigid-body equations (:func:`drum_reference`)
with the wall's speed at the contact, ``Omega R_drum``; at the centre's radius the peak is 20 % (R 5 cm) to 40 % (R
10 cm) lower, so this case tells the two apart. The family: R 0.05 and 0.1 m, n_grid 32 and 48, mu 0.5 and 1.

Each figure within ``test_rolling.TOL`` (5 %, two-sided) of its closed form or reference.
``python benchmarks/studies/roll_spin90.py --engine warp_mpm --parts turntable --out
benchmarks/results/roll_spin90_turntable_warp.json`` (refused if the file exists), and ``--parts drum``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from roll_belt90 import _CORNERS, _FACES, BOX, FPS, GRIDS, MUS, RADII, RF, closed_form, problem, rl  # noqa: E402


def as_class(col, cls):
    """``col`` itself, or a copy of it as the :class:`Collider` subclass ``cls`` (the broken variants)."""
    import dataclasses
    return col if cls is None else cls(**{f.name: getattr(col, f.name) for f in dataclasses.fields(col)})


# --------------------------------------------------------------------------- the turntable
#: The turntable's spin (rad/s, about z), the ball's start off its axis (m), the run (s), its top's world centre (m).
OMEGA, R0, TURN_T = 3.0, 0.1, 1.0
AXIS = np.array([0.3, 0.3, 0.15])


def turntable_collider(mu: float, n_grid: int, spin: tuple = (0.0, 0.0, OMEGA), cls=None):
    """A square plate 1.0 x 1.0 x 0.1 m turning at ``spin`` (rad/s) about the vertical through ``AXIS`` (its top
    face's centre; ``[[collider]] angular_velocity``), friction ``mu``. ``cls``: a :class:`Collider` subclass (the
    broken variants)."""
    from gasp_core.colliders.model import Motion
    from gasp_core.colliders.sdf import SDF_SPACING, collider_from_triangles
    tri = (np.array([0.0, 0.0, -0.05]) + _CORNERS * np.array([0.5, 0.5, 0.05]))[_FACES]
    col = collider_from_triangles(tri, SDF_SPACING * BOX / n_grid, name="turntable", friction=mu, position=AXIS,
                                  motion=Motion(angular_velocity=spin))
    return as_class(col, cls)


def turntable_figures(c: np.ndarray, k: float, t_from: float) -> dict:
    """The ball's orbit about the axis from its per-frame centres ``c``: ``rate`` (rad/s, the slope of its angle
    about the axis fitted from ``t_from`` s), ``r`` (m, its mean distance from the axis over those frames) and the
    closed form's (Ehrlich & Tuszynski 1995, Am. J. Phys. 63, 351: a rolling ball's centre circles the axis at
    ``k Omega / (1 + k)``, 2/7 of the table's for a solid sphere, at the radius it started at)."""
    t = np.arange(len(c)) / FPS
    d = c[:, :2] - AXIS[:2]
    ang = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    sel = t >= t_from
    return {"rate": float(np.polyfit(t[sel], ang[sel], 1)[0]), "r": float(np.linalg.norm(d[sel], axis=1).mean()),
            "rate_want": k * OMEGA / (1.0 + k), "r_want": R0}


def turntable(engine: str, radius: float, n_grid: int, mu: float, friction: float | None = None, cls=None,
              output=None) -> dict:
    """A rigid ball (``roll_family88.ball``) set at rest ``R0`` off the axis of the turntable of friction ``mu``;
    :func:`turntable_figures` from twice the slip's end on, with ``problem`` (None within ``test_rolling.TOL``,
    two-sided, on the rate and the radius). ``friction``, ``output``: the broken variants (:func:`measure`'s); ``cls``
    (:func:`turntable_collider`'s) another."""
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    x, vol, _ = RF.body("ball", radius, n_grid, "fibonacci")
    k = RF.inertia_share(x, vol, radius)
    x = x - (vol[:, None] * x).sum(0) / vol.sum() + AXIS + np.array([R0, 0.0, radius])
    st = make_setup(x, vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                    hi=np.full(3, BOX), n_grid=n_grid, frame_dt=1.0 / FPS)
    st.colliders = [turntable_collider(mu if friction is None else friction, n_grid, cls=cls)]
    t0 = time.time()
    c = rl.trace(engine, st, TURN_T)[0]
    c = c if output is None else output(c)
    fig = turntable_figures(c, k, 2.0 * closed_form(k, mu, OMEGA * R0)["t_star"])
    return {"engine": engine, "R": radius, "n_grid": n_grid, "mu": mu, "k": k, **fig,
            "problem": turntable_problem(fig), "wall_s": time.time() - t0}


def turntable_problem(fig: dict) -> str | None:
    """None when the orbit's rate and radius are within ``test_rolling.TOL`` of the closed form (two-sided)."""
    return problem({key: fig[key + "_want"] for key in ("rate", "r")}, fig, ("rate", "r"))


# --------------------------------------------------------------------------- the drum
#: The drum: its radius (m), its axis (along y) through the box's centre, its spin (rad/s, about +y), the ball's
#: radius (m), the run (s). The drum's bottom moves along -x at ``DRUM_OMEGA DRUM_R``.
DRUM_R, DRUM_OMEGA, DRUM_BALL, DRUM_T = 0.25, 5.0, 0.05, 1.2
DRUM_C = np.array([BOX / 2, BOX / 2, BOX / 2])
DRUM_GRID, DRUM_MU = 32, 0.5
#: The drum's family: the ball's radius (m), n_grid, mu.
DRUM_RADII, DRUM_GRIDS, DRUM_MUS = (0.05, 0.1), (32, 48), (0.5, 1.0)


def drum_collider(mu: float, n_grid: int = DRUM_GRID, spin: float = DRUM_OMEGA, cls=None):
    """The inside of a cylinder of radius ``DRUM_R`` about the y axis through ``DRUM_C`` (signed distance ``DRUM_R -
    sqrt(x^2 + z^2)``, exact), sampled at ``SDF_SPACING`` of the cell over the box, turning at ``spin`` rad/s about
    +y (``[[collider]] angular_velocity``), friction ``mu``."""
    from gasp_core.colliders.model import Motion
    from gasp_core.colliders.sdf import SDF_PAD, SDF_SPACING, _finish
    h = SDF_SPACING * BOX / n_grid
    n = int(round(BOX / h)) + 2 * SDF_PAD + 1
    origin = np.full(3, -BOX / 2 - SDF_PAD * h)
    g = origin + h * np.stack(np.meshgrid(*(np.arange(n),) * 3, indexing="ij"), axis=-1)
    phi = DRUM_R - np.hypot(g[..., 0], g[..., 2])
    col = _finish("drum", phi, origin, h, friction=mu, position=DRUM_C,
                  motion=Motion(angular_velocity=(0.0, spin, 0.0)))
    return as_class(col, cls)


def drum_reference(k: float, mu: float, surface_speed: float, t: np.ndarray,
                   radius: float = DRUM_BALL) -> np.ndarray:
    """The ball's angle (rad, positive where the drum's bottom moves: -x) at the times ``t`` (s), from the rigid-body
    equations of a ball of ``k`` set at rest at the bottom of a drum whose wall moves at ``surface_speed`` (m/s):
    its centre on the circle ``L = DRUM_R - radius``, ``m L th'' = -m g sin th + F``, ``I w' = -F r``, the wall
    pushing ``N = m (g cos th + L th'^2)``; while the contact slips (``u = L th' - w r - surface_speed != 0``)
    ``F = -mu N sign(u)``, once it rolls ``u = 0`` held (the bowl's pendulum, ``(1 + k) L th'' = -g sin th``: the
    wall's speed drops out). scipy's ``solve_ivp`` (RK45, rtol 1e-10) with the roll's start as an event."""
    from scipy.integrate import solve_ivp
    L, r, g = DRUM_R - radius, radius, rl.G

    def slip(_, y):
        th, om, w = y
        u = L * om - w * r - surface_speed
        F = -mu * (g * np.cos(th) + L * om * om) * np.sign(u)
        return [om, (-g * np.sin(th) + F) / L, -F / (k * r)]

    def rolls(_, y):
        return L * y[1] - y[2] * r - surface_speed
    rolls.terminal = True
    first = solve_ivp(slip, (0.0, float(t[-1])), [0.0, 0.0, 0.0], events=rolls, rtol=1e-10, atol=1e-12,
                      dense_output=True)
    t_roll = float(first.t[-1])
    out = np.empty(len(t))
    early = t <= t_roll
    out[early] = first.sol(t[early])[0]
    if (~early).any():
        th0, om0, _ = first.y[:, -1]
        roll = solve_ivp(lambda _, y: [y[1], -g * np.sin(y[0]) / ((1.0 + k) * L)], (t_roll, float(t[-1])),
                         [th0, om0], rtol=1e-10, atol=1e-12, dense_output=True)
        out[~early] = roll.sol(t[~early])[0]
    return out


def drum_swing(th: np.ndarray, t: np.ndarray) -> dict:
    """``peak`` (rad: the first maximum of ``th``) and ``half`` (s: from it to the next minimum), by parabolas through
    each extreme frame and its two neighbours."""
    def extreme(i):
        a, b, c = th[i - 1], th[i], th[i + 1]
        d = a - 2.0 * b + c
        x = 0.5 * (a - c) / d if d != 0.0 else 0.0
        return t[i] + x * (t[1] - t[0]), b - 0.25 * (a - c) * x
    i1 = next(i for i in range(1, len(th) - 1) if th[i] >= th[i - 1] and th[i] > th[i + 1])
    i2 = next(i for i in range(i1 + 1, len(th) - 1) if th[i] <= th[i - 1] and th[i] < th[i + 1])
    (t1, p1), (t2, _) = extreme(i1), extreme(i2)
    return {"peak": p1, "half": t2 - t1}


def drum(engine: str, mu: float = DRUM_MU, n_grid: int = DRUM_GRID, radius: float = DRUM_BALL,
         friction: float | None = None, cls=None) -> dict:
    """A rigid ball of ``radius`` (``roll_family88.ball``) set at rest at the bottom of the turning drum of friction
    ``mu``: its swing (:func:`drum_swing`) against :func:`drum_reference`'s with the wall's speed taken at the contact
    (``Omega R_drum``), with ``problem`` (None within ``test_rolling.TOL``, two-sided, on the first peak and the half
    period), and the swing the reference gives with the speed at the centre's radius (``Omega (R_drum - r)``,
    ``peak_centre``: the rule this case tells apart). ``friction``, ``cls``: the broken variants."""
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    x, vol, _ = RF.body("ball", radius, n_grid, "fibonacci")
    k = RF.inertia_share(x, vol, radius)
    x = x - (vol[:, None] * x).sum(0) / vol.sum() + DRUM_C - np.array([0.0, 0.0, DRUM_R - radius])
    st = make_setup(x, vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                    hi=np.full(3, BOX), n_grid=n_grid, frame_dt=1.0 / FPS)
    st.colliders = [drum_collider(mu if friction is None else friction, n_grid, cls=cls)]
    t0 = time.time()
    c = rl.trace(engine, st, DRUM_T)[0]
    t = np.arange(len(c)) / FPS
    th = np.arctan2(-(c[:, 0] - DRUM_C[0]), -(c[:, 2] - DRUM_C[2]))
    try:
        fig = drum_swing(th, t)
    except StopIteration:   # no swing: the ball stays at the bottom
        fig = {"peak": float(th.max()), "half": 0.0}
    want = drum_swing(drum_reference(k, mu, DRUM_OMEGA * DRUM_R, t, radius), t)
    centre = drum_swing(drum_reference(k, mu, DRUM_OMEGA * (DRUM_R - radius), t, radius), t)
    return {"engine": engine, "R": radius, "mu": mu, "n_grid": n_grid, "k": k, **fig, "peak_want": want["peak"],
            "half_want": want["half"], "peak_centre": centre["peak"], "problem": drum_problem(fig, want),
            "wall_s": time.time() - t0}


def drum_problem(fig: dict, want: dict) -> str | None:
    """None when the first peak and the half period are within ``test_rolling.TOL`` of ``want`` (two-sided)."""
    return problem(want, fig, ("peak", "half"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--parts", default="turntable,drum", help="turntable, drum or both (comma-separated)")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = RF.new_out(ap, a.out)
    rows = []
    for radius in RADII if "turntable" in a.parts else ():
        for n_grid in GRIDS:
            for mu in MUS:
                rows.append(turntable(a.engine, radius, n_grid, mu))
                r = rows[-1]
                print(f"{a.engine} turntable R {radius} n_grid {n_grid} mu {mu}: rate {r['rate']:.4f} against "
                      f"{r['rate_want']:.4f}, r {r['r']:.4f}; {r['problem'] or 'ok'}", flush=True)
    for radius in DRUM_RADII if "drum" in a.parts else ():
        for n_grid in DRUM_GRIDS:
            for mu in DRUM_MUS:
                rows.append(drum(a.engine, mu, n_grid, radius))
                r = rows[-1]
                print(f"{a.engine} drum R {radius} n_grid {n_grid} mu {mu}: peak {r['peak']:.4f} rad against "
                      f"{r['peak_want']:.4f} ({100 * (r['peak'] / r['peak_want'] - 1):+.2f} %; the centre's rule "
                      f"{r['peak_centre']:.4f}), half period {r['half']:.4f} s against {r['half_want']:.4f}; "
                      f"{r['problem'] or 'ok'}", flush=True)
    RF.write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
