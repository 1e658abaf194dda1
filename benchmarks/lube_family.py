"""The quasi-2D sand column's runout over a family (issue 67 item 5): aspect ratios ``a`` 0.5, 1, 2 and 3, at two
grids, on the MPM engines, against Lube et al. (2005)'s fit ``(L_inf - L_i) / L_i = 1.2 a`` (``a < 2.3``),
``1.9 a^(2/3)`` above, and the final height ``H_inf / L_i = a`` (``a < 1.15``), ``a^(2/5)`` above.

The scene is the conformance scene ``sand_column_collapse`` (``gasp_core.testing.scenes_granular``: a column of
``L_i`` 0.15 m against the channel's end wall, 3-cell channel, sand whose layers flow at 32 deg, ground friction
tan 32 deg) at other ``a`` and ``n_grid``; the deposit is read as that scene
reads it (:func:`column_deposit`), after 0.7 s plus the time a taller column takes to fall
(``2.4 sqrt(2 H / g)``, Staron & Hinch 2005, rounded up to frames).

``--cone plane_strain`` runs the cone the scene used before round 33 (Mohr-Coulomb's plane-strain failure at 32 deg,
``sqrt(J2) / p = sin(32 deg)``; :data:`CONES`).

Run: ``python benchmarks/lube_family.py [--engines taichi_mpm,warp_mpm] [--grids 48,96] [--aspects 0.5,1,2,3]
[--device cuda] [--mu-i] [--cone flow|plane_strain] [--out PATH]``;
writes ``benchmarks/results/lube_family.json`` and ``.md`` (each run's figures; the signed errors; the CPU time).
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing import scenes_granular as sg
from gasp_core.testing.helpers import box_points, make_setup, wall_margin
from gasp_core.testing.kit import resolve_engine, run_trace

OUT = Path(__file__).resolve().parent / "results"
FRAME_DT = 0.02


#: The mu(I) sand of ``--mu-i`` (docs/contact.md "mu(I)"): grain diameter 0.5 mm (Lube et al.'s sands, 0.3-1.5 mm),
#: mu_2 = mu_s + 0.26 (Jop et al. 2006's glass beads: 0.38 to 0.64), mu_s the column's cone's sqrt(J2) / p.
MU_I_D, MU_I_DELTA = 5e-4, 0.26


#: The column's cone from its Coulomb angle ``sg.COLUMN_PHI``: ``plane_strain`` (Mohr-Coulomb's failure in plane strain,
#: ``sqrt(J2) / p = sin(phi)``) or ``flow`` (a layer flows at ``phi``, ``sqrt(J2) / p = tan(phi)``).
CONES = {"plane_strain": sg.plane_strain_dp_angle, "flow": sg.flow_dp_angle}


def mu_i_keys(cone: str = "flow") -> dict:
    """The material keys of the mu(I) sand (``MU_I_D``, ``MU_I_DELTA``) over the column's cone (``CONES``)."""
    s = math.sin(math.radians(CONES[cone](sg.COLUMN_PHI)))
    eta_s = 2.0 * math.sqrt(3.0) * s / (3.0 - s)
    return {"grain_diameter": MU_I_D, "friction_angle_2": sg.cone_angle(eta_s + MU_I_DELTA)}


def column_setup(info, a: float, n_grid: int, device: str = "cpu", mu_i: bool = False, cone: str = "flow"):
    """The conformance column (module notes) of aspect ``a`` on ``n_grid`` cells over the domain's 1 m length; the
    domain as tall as the column needs (at least the scene's 0.5 m); ``device`` the engine option (``"cuda"`` on a
    GPU, where the finer grids are affordable)."""
    lx, depth, L = sg.COLUMN_DOMAIN[0], sg.COLUMN_DEPTH, sg.COLUMN_L
    dx = lx / n_grid
    m, z0, H = wall_margin(info, dx), 3 * dx, a * L
    x, p_vol = box_points((m, m, z0), (m + L, m + depth, z0 + H), dx / 2)
    rate = mu_i_keys(cone) if mu_i else {}
    material = Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=CONES[cone](sg.COLUMN_PHI),
                        **rate)
    top = max(sg.COLUMN_DOMAIN[1], z0 + H + 4 * dx)
    return make_setup(x, p_vol, material, hi=(lx, 2 * m + depth, top), n_grid=n_grid, frame_dt=FRAME_DT,
                      boundaries=[Boundary("ground", height=z0, friction=math.tan(math.radians(sg.COLUMN_PHI))),
                                  Boundary("walls", friction=0.0)],
                      options={"threads": 2} if device == "cpu" else {"device": device})


#: The front at one physical thickness on every grid (:func:`front_at`), times ``L_i``: one point layer at n_grid 48.
FRONT_THICKNESS = 0.0694


def front_at(x: np.ndarray, x_wall: float, spacing: float, thickness: float) -> float:
    """Distance (m) from the wall to the far edge of the farthest column of width ``spacing`` whose deposit is at least
    ``thickness`` m thick (points per column over the channel's points per row, times ``spacing``). The scene's own
    front (:func:`column_deposit`) takes one point layer, which is half as thick on a grid twice as fine."""
    n_y = max(1, int(round(sg.COLUMN_DEPTH / spacing)))
    bins = np.floor((x[:, 0] - x_wall) / spacing).astype(int)
    counts = np.bincount(bins[bins >= 0])
    thick = np.nonzero(counts * spacing / n_y >= thickness)[0]
    return float((thick.max() + 1) * spacing) if len(thick) else 0.0


def column_end(info, a: float, n_grid: int, options: dict) -> tuple[float, float]:
    """The column of :func:`column_setup` with the engine ``options`` (replacing its own) run to its end time:
    ``(runout, height)`` over ``L_i`` from its last frame (``scenes_granular.column_deposit``), no trace kept."""
    from gasp_core.seam import build_engine
    s = column_setup(info, a, n_grid).replace(options=dict(options))
    e = build_engine(info, s)
    for _ in range(int(math.ceil((0.7 + 2.4 * math.sqrt(2 * a * sg.COLUMN_L / 9.81)) / FRAME_DT))):
        e.step_frame()
    L_inf, H_inf = sg.column_deposit(e.positions().astype(float), wall_margin(info, s.dx), 3 * s.dx, s.dx / 2)
    return (L_inf - sg.COLUMN_L) / sg.COLUMN_L, H_inf / sg.COLUMN_L


def run_case(engine: str, a: float, n_grid: int, device: str = "cpu", mu_i: bool = False,
             cone: str = "flow") -> dict:
    """One column: its runout and height against the fits (signed relative errors), its end speed and CPU time."""
    info = resolve_engine(engine)
    setup = column_setup(info, a, n_grid, device, mu_i, cone)
    t_end = 0.7 + 2.4 * math.sqrt(2 * a * sg.COLUMN_L / 9.81)
    frames = int(math.ceil(t_end / FRAME_DT))
    c0, w0 = time.process_time(), time.perf_counter()
    tr = run_trace(info, setup, frames)
    dx = setup.dx
    L_inf, H_inf = sg.column_deposit(tr.x[-1], wall_margin(info, dx), 3 * dx, dx / 2)
    runout, height = (L_inf - sg.COLUMN_L) / sg.COLUMN_L, H_inf / sg.COLUMN_L
    front = (front_at(tr.x[-1], wall_margin(info, dx), dx / 2, FRONT_THICKNESS * sg.COLUMN_L) - sg.COLUMN_L) / sg.COLUMN_L
    r_ref, h_ref = sg.lube_runout(a), sg.lube_height(a)
    return {"engine": engine, "a": a, "n_grid": n_grid, "cells_along_column": sg.COLUMN_L / dx, "frames": frames,
            "n_points": len(setup.x), "runout": runout, "runout_lube": r_ref, "runout_err": runout / r_ref - 1,
            "runout_fixed_thickness": front, "runout_fixed_err": front / r_ref - 1, "height": height, "height_lube": h_ref, "height_err": height / h_ref - 1,
            "end_speed": float(np.sqrt((tr.v[-1] ** 2).sum(axis=1)).max()), "cpu_s": time.process_time() - c0,
            "wall_s": time.perf_counter() - w0, "device": device, "mu_i": mu_i, "cone": cone}


def write_table(rows: list, out: Path, head: str = "") -> None:
    """Write ``rows`` (:func:`run_case`'s dicts) to ``out`` ``.json`` and ``.md`` (``head`` above the table)."""
    out.with_suffix(".json").write_text(json.dumps(rows, indent=1))
    lines = [head, ""] if head else []
    lines += ["| engine | device | cone | n_grid | cells along L_i | a | runout | Lube 2005 | error | runout at a fixed "
              "thickness | error | H_inf/L_i | Lube | error | end speed m/s | CPU s |", "|---" * 16 + "|"]
    lines += [f"| {r['engine']} | {r.get('device', 'cpu')} | {r.get('cone', 'plane_strain')}"
              f"{' mu(I)' if r.get('mu_i') else ''} | {r['n_grid']} | {r['cells_along_column']:.1f} | {r['a']:g} | "
              f"{r['runout']:.3f} | {r['runout_lube']:.3f} | {r['runout_err']:+.1%} | {r['runout_fixed_thickness']:.3f} | "
              f"{r['runout_fixed_err']:+.1%} | {r['height']:.3f} | {r['height_lube']:.3f} | "
              f"{r['height_err']:+.1%} | {r['end_speed']:.3f} | {r['cpu_s']:.0f} |" for r in rows]
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--grids", default="48,96")
    ap.add_argument("--aspects", default="0.5,1,2,3")
    ap.add_argument("--device", default="cpu", help="the engines' device option: cpu or cuda")
    ap.add_argument("--mu-i", action="store_true", help="the sand with the mu(I) rheology (MU_I_D, MU_I_DELTA)")
    ap.add_argument("--cone", default="flow", choices=sorted(CONES), help="the column's cone (CONES)")
    ap.add_argument("--out", default=str(OUT / "lube_family"))
    args = ap.parse_args()
    rows, out = [], Path(args.out)
    for engine in args.engines.split(","):
        for n in (int(g) for g in args.grids.split(",")):
            for a in (float(s) for s in args.aspects.split(",")):
                rows.append(run_case(engine, a, n, args.device, args.mu_i, args.cone))
                out.with_suffix(".json").write_text(json.dumps(rows, indent=1))   # each row kept as it comes
                r = rows[-1]
                print(f"{engine} n_grid {n} a {a:g}: runout {r['runout']:.3f} (Lube {r['runout_lube']:.3f}, "
                      f"{r['runout_err']:+.1%}; at {FRONT_THICKNESS:g} L_i thick {r['runout_fixed_thickness']:.3f}, "
                      f"{r['runout_fixed_err']:+.1%}), height {r['height']:.3f} ({r['height_lube']:.3f}, "
                      f"{r['height_err']:+.1%}), end speed {r['end_speed']:.3f} m/s, {r['wall_s']:.0f} s wall", flush=True)
    write_table(rows, out)
    print(out.with_suffix(".md").read_text())


if __name__ == "__main__":
    main()
