"""Issue 66 round 45: the step-started pull of the user-built tension family, its stress wave measured.

A specimen of ``benchmarks/user_tension.py`` (built through the scene, held by a ``fixed_region``, pulled by one
``[[impulse]] mode = "set"`` box) at rest, pulled from t = 0 at ``v`` (``start = "step"``) or with the box's ``ramp``
key. Each frame (``tf.FRAME_DT``) the fill's x layers' nominal stress ``sigma = sum P_xx V / h / A_layer`` (Pa;
``user_tension.record``) is kept at:

- ``clamp``: the first free layer past the clamp's face (the ``fixed_region``'s ``hi``), and ``clamp2`` the next;
- ``mid``: the layer nearest the middle of the free length; ``gauge``: the median over the gauge's layers (the
  family's peak measure); ``pulled``: the last layer before the pulled box's face;

against the one-dimensional elastic bar (:func:`wave_1d`: ``rho A u_tt = (E A u_x)_x`` between the faces, ``u = 0``
at the clamp's face, ``u = v t`` (or the ramp's) at the pulled face; exact for the bars at its Courant number 1).
``c = sqrt(E / rho)`` (31.6 m/s): with nu = 0 the bar, plane-strain and dilatational wave speeds are all
``sqrt(E / rho)``, so the front's amplitude is ``rho c v`` however the section is confined. The figures
(:func:`wave_figures`): the front's arrival at the clamp's edge (the incident front, ``sigma = rho c v / 2``
crossed, and the reflected, ``1.5 rho c v``) against ``(L - s) / c`` and ``(L + s) / c``; its plateaus (mid layer
between the front and its reflection, against ``rho c v``; clamp edge after the reflection, against ``2 rho c v``);
the first layer to damage (where a point reached ``f_t`` first) and the 1D bar's first place at ``f_t``; the
clamp edge's and the gauge's stress over the 1D bar's at the same x, up to the first damage.

Run (one engine a process): ``python benchmarks/studies/step_wave.py --engine taichi_mpm --only bar_L0.7_a0.30
--n-grid 48 --speed 1 --start step`` (``--speed`` a comma list of factors on ``tf.PULL``, ``--ramp`` the ramp's
seconds for ``--start ramp``, ``--stop K`` to end K frames after the first damage); cases go to
``benchmarks/results/step_wave.json`` and ``step_wave.md``. ``--profile F`` prints :func:`edge_profile` after F frames
of the ramped pull instead (``results/step_wave_profile.md``).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tension_family as tf   # noqa: E402
import user_tension as ut     # noqa: E402

RESULTS = Path(__file__).resolve().parents[1] / "results"
C = float(np.sqrt(tf.E / tf.RHO))


def wave_1d(sp: tf.Specimen, clamp: float, pulled: float, v: float, ramp: float, times: np.ndarray,
            xq: np.ndarray, cells: int = 2000) -> np.ndarray:
    """The 1D elastic bar's stress (Pa) (len(times), len(xq)) between ``clamp`` and ``pulled`` (m): ``rho A u_tt =
    (E A u_x)_x``, ``A = sp.area``, ``u(clamp) = 0``, ``u(pulled) = v min(t / ramp, 1) t``-integrated (a step when
    ``ramp`` is 0), from rest; staggered leapfrog at Courant number 1 (exact for a uniform bar)."""
    h = (pulled - clamp) / cells
    dt = h / C
    xn = clamp + h * np.arange(cells + 1)
    xm = 0.5 * (xn[1:] + xn[:-1])
    a_m = sp.area(xm)
    a_n = np.concatenate([[a_m[0]], 0.5 * (a_m[1:] + a_m[:-1]), [a_m[-1]]])
    u = np.zeros(cells + 1)
    vel = np.zeros(cells + 1)
    out = np.zeros((len(times), len(xq)))
    t, k = 0.0, 0
    while k < len(times):
        fac = 1.0 if ramp <= 0 else min((t + 0.5 * dt) / ramp, 1.0)
        sig = tf.E * np.diff(u) / h
        f = np.diff(a_m * sig) / h
        vel[1:-1] += dt * f / (tf.RHO * a_n[1:-1])
        vel[0], vel[-1] = 0.0, v * fac
        u += dt * vel
        t += dt
        while k < len(times) and t >= times[k]:
            out[k] = np.interp(xq, xm, tf.E * np.diff(u) / h)
            k += 1
    return out


def until_damage(e, st, layer, nl: int, h: float, n_frames: int, stop: int) -> dict:
    """:func:`user_tension.record`, a frame at a time, ended ``stop`` frames after a point first has damage."""
    parts, left = [], -1
    for _ in range(n_frames):
        parts.append(ut.record(e, st, layer, nl, h, 1))
        left = stop if left < 0 and bool(np.any(parts[-1]["d"] > 1e-6)) else left - 1 if left > 0 else left
        if left == 0:
            break
    rec = {k: np.concatenate([p[k] for p in parts]) for k in ("force", "pos", "dmean", "thru", "opened")}
    rec.update({k: parts[-1][k] for k in ("vol", "d", "xs", "free")})
    return rec


def run(sp: tf.Specimen, n_grid: int, engine: str, start: str, speed: float, ramp: float, stop: int = 0,
        frames: int = 0) -> dict:
    """One case: the layer histories and :func:`wave_figures`. ``speed`` a factor on ``tf.PULL``; ``ramp`` the set
    box's ramp (s) when ``start == "ramp"``; ``stop``: end ``stop`` frames after the first damage (0: run
    :func:`user_tension.record`'s frames, the break and its opening); ``frames``: run that many frames alone."""
    from gasp_core.seam.build import build_engine
    pull0, ramp0 = tf.PULL, ut.RAMP_S
    tf.PULL, ut.RAMP_S = pull0 * speed, ramp
    try:
        ps, mesh = ut.prepare(sp, n_grid, engine, pull=start)
        st = ps.setup
        fill = ut.fill_figures(ps, mesh, sp)
        h, layer, lx = fill["h"], fill["layer"], fill["lx"]
        clamp, pulled = ut.faces(sp, n_grid)
        x_g = np.array([clamp, pulled])
        t_peak = (tf.FT / tf.E) * sp.gauge_w ** 2 * float(np.diff(np.interp(x_g, *ut._compliance(sp)))[0]) / tf.PULL
        t_peak += ramp / 2 if start == "ramp" else 0.0
        n_frames = frames or int(np.ceil((t_peak + 1.5 * 2 * tf.GF / tf.FT / tf.PULL) / tf.FRAME_DT))
        e = build_engine(ps.info, st)
        t0 = time.time()
        try:
            rec = ut.record(e, st, layer, len(lx), h, n_frames) if not stop else until_damage(
                e, st, layer, len(lx), h, n_frames, stop)
        finally:
            e.close()
        fig = ut.figures(sp, rec, lx, h, st.dx, clamp, pulled)
        v = tf.PULL
    finally:
        tf.PULL, ut.RAMP_S = pull0, ramp0
    r = {"specimen": sp.name, "engine": engine, "n_grid": n_grid, "start": start, "speed": speed, "v": v,
         "ramp": ramp if start == "ramp" else 0.0, "seconds": round(time.time() - t0, 1),
         **{k: fig[k] for k in ("peak", "crack_x", "where", "clamp_face", "pulled_face", "work", "damaged_layers")}}
    r.update(wave_figures(sp, rec, lx, h, st.dx, clamp, pulled, v, r["ramp"]))
    return r


def _layers(sp, lx, dx, clamp, pulled) -> dict:
    free = np.flatnonzero((lx > clamp) & (lx < pulled))
    g_lo, g_hi = (clamp + 1.5 * dx, pulled - 1.5 * dx) if sp.gauge_l == 0.0 else sp.gauge(dx)
    return {"clamp": free[0], "clamp2": free[1], "pulled": free[-1],
            "mid": free[np.argmin(np.abs(lx[free] - 0.5 * (clamp + pulled)))],
            "gl": np.flatnonzero((lx > g_lo) & (lx < g_hi)), "free": free}


def wave_figures(sp, rec, lx, h, dx, clamp, pulled, v, ramp) -> dict:
    """The wave's figures from :func:`user_tension.record`'s ``rec`` (see the module's docstring); stresses in Pa,
    times in s, ``s0 = rho c v``."""
    L, s0 = pulled - clamp, tf.RHO * C * v
    ly = _layers(sp, lx, dx, clamp, pulled)
    area = rec["vol"] / h
    sig = rec["force"] / np.where(area > 0, area, 1.0)
    nf = len(sig)
    times = tf.FRAME_DT * (np.arange(nf) + 1)
    named = {k: sig[:, ly[k]] for k in ("clamp", "clamp2", "mid", "pulled")}
    named["gauge"] = np.median(rec["force"][:, ly["gl"]], axis=1) / float(sp.gauge_w ** 2)
    xq = lx[[ly["clamp"], ly["clamp2"], ly["mid"], ly["pulled"]]]
    th = wave_1d(sp, clamp, pulled, v, ramp, times, np.concatenate([xq, lx[ly["gl"]]]))
    theory = dict(zip(("clamp", "clamp2", "mid", "pulled"), th[:, :4].T))
    theory["gauge"] = np.median(th[:, 4:], axis=1)
    dm = rec["dmean"][:, ly["free"]]
    hit = dm > 1e-6
    first = int(np.argmax(hit.any(axis=1))) if hit.any() else nf - 1
    lay0 = ly["free"][int(np.argmax(hit[first]))] if hit.any() else -1
    th_free = wave_1d(sp, clamp, pulled, v, ramp, times[:first + 1], lx[ly["free"]])
    reach = th_free >= tf.FT
    if reach.any():
        k1 = int(np.argmax(reach.any(axis=1)))
        x1, t1 = float(lx[ly["free"]][int(np.argmax(th_free[k1]))]), float(times[k1])
    else:
        x1, t1 = float(lx[ly["free"]][int(np.argmax(th_free[-1]))]), float("nan")
    s_cl = float(xq[0] - clamp)
    near = np.flatnonzero(np.abs(lx - clamp) < 3 * dx)
    onset = {f"{lx[k] - clamp:+.4f}": (int(np.argmax(rec["dmean"][:, k] > 1e-6)) if (rec["dmean"][:, k] > 1e-6).any()
                                       else -1) for k in near}

    def cross(a, level):
        return float(times[int(np.argmax(a >= level))]) if (a >= level).any() else float("nan")
    pl_mid = (times > 0.6 * L / C) & (times < 1.4 * L / C)
    pl_cl = (times > 1.2 * L / C) & (times < 2.8 * L / C)
    upto = slice(0, first + 1)
    return {
        "stop": "first damage" if not rec["thru"].any() else "break", "L": L, "c": C, "s0": s0,
        "s0_vs_ft": s0 / tf.FT, "clamp_layer_x": float(xq[0]), "clamp_layer_s": s_cl,
        "t_incident": cross(named["clamp"], 0.5 * s0), "t_incident_1d": (L - s_cl) / C,
        "t_reflected": cross(named["clamp"], 1.5 * s0), "t_reflected_1d": (L + s_cl) / C,
        "mid_plateau_vs_s0": float(np.median(named["mid"][pl_mid]) / s0) if pl_mid.any() else float("nan"),
        "clamp_plateau_vs_s0": float(np.median(named["clamp"][pl_cl]) / s0) if pl_cl.any() else float("nan"),
        "first_damage_t": float(times[first]), "first_damage_x": float(lx[lay0]) if lay0 >= 0 else float("nan"),
        "first_damage_s": float(lx[lay0] - clamp) if lay0 >= 0 else float("nan"),
        "onset_frame_by_s": onset, "first_1d_t": t1, "first_1d_s": x1 - clamp,
        **{f"{k}_at_damage_vs_ft": float(named[k][first] / tf.FT) for k in named},
        **{f"{k}_1d_at_damage_vs_ft": float(theory[k][first] / tf.FT) for k in theory},
        **{f"{k}_max_vs_ft": float(named[k][upto].max() / tf.FT) for k in named},
        **{f"{k}_1d_max_vs_ft": float(theory[k][upto].max() / tf.FT) for k in theory},
        "clamp_over_gauge_max": float(np.max(named["clamp"][upto] - named["gauge"][upto]) / tf.FT),
        "clamp_over_gauge_1d_max": float(np.max(theory["clamp"][upto] - theory["gauge"][upto]) / tf.FT),
        "history": {k: [round(float(a)) for a in named[k]] for k in named},
        "history_1d": {k: [round(float(a)) for a in theory[k]] for k in theory},
    }


def edge_profile(sp: tf.Specimen, n_grid: int, engine: str, frames: int, ramp: float = 0.1) -> dict:
    """The layers' mean ``P_xx`` over the gauge's median (each layer's rest x from the clamp's face, in cells; the
    median of the ratio over the last third of ``frames`` frames of the ramped pull, ``ramp`` s), the layers within 4
    cells of either face, and the gauge's median (over ``f_t``) at the last frame."""
    from gasp_core.seam.build import build_engine
    ramp0 = ut.RAMP_S
    ut.RAMP_S = ramp
    try:
        ps, mesh = ut.prepare(sp, n_grid, engine, pull="ramp")
    finally:
        ut.RAMP_S = ramp0
    st = ps.setup
    fill = ut.fill_figures(ps, mesh, sp)
    h, layer, lx = fill["h"], fill["layer"], fill["lx"]
    clamp, pulled = ut.faces(sp, n_grid)
    e = build_engine(ps.info, st)
    try:
        rec = ut.record(e, st, layer, len(lx), h, frames)
    finally:
        e.close()
    ly = _layers(sp, lx, st.dx, clamp, pulled)
    sig = rec["force"][-frames // 3:] / (rec["vol"] / h)
    gs = np.median(sig[:, ly["gl"]], axis=1)
    g, sig = float(gs[-1]), np.median(sig / gs[:, None], axis=0) * float(gs[-1])
    near = np.flatnonzero((np.abs(lx - clamp) < 4 * st.dx) | (np.abs(lx - pulled) < 4 * st.dx))
    return {"specimen": sp.name, "engine": engine, "n_grid": n_grid, "frames": frames, "gauge_vs_ft": g / tf.FT,
            "layers": [[round(float((lx[k] - clamp) / st.dx), 2), round(float(sig[k] / g), 4)] for k in near]}


def _key(r: dict) -> tuple:
    return r["specimen"], r["engine"], r["n_grid"], r["start"], r["speed"], r["ramp"]


def table(rows: list[dict]) -> str:
    """The Markdown table of the cases (stresses over f_t; ``1d``: the 1D elastic bar's)."""
    out = ["| specimen | engine | n_grid | start | v (m/s) | rho c v / f_t | front at clamp edge: incident / reflected "
           "(ms; 1D) | mid plateau / rho c v | clamp plateau / rho c v | first damage: s from clamp (m), t (s) | "
           "1D first at f_t: s, t | at first damage: clamp edge / gauge (1D) | max clamp - gauge (1D) | peak / f_t "
           "| breaks (x, where) |", "|" + "---|" * 14]
    for r in sorted(rows, key=_key):
        out.append(
            f"| {r['specimen']} | {r['engine']} | {r['n_grid']} | {r['start']}"
            f"{' ' + format(r['ramp'], 'g') + ' s' if r['ramp'] else ''} | {r['v']:g} | {r['s0_vs_ft']:.3f} | "
            f"{1e3 * r['t_incident']:.1f} / {1e3 * r['t_reflected']:.1f} ({1e3 * r['t_incident_1d']:.1f} / "
            f"{1e3 * r['t_reflected_1d']:.1f}) | {r['mid_plateau_vs_s0']:.2f} | {r['clamp_plateau_vs_s0']:.2f} | "
            f"{r['first_damage_s']:.3f}, {r['first_damage_t']:.4f} | {r['first_1d_s']:.3f}, {r['first_1d_t']:.4f} | "
            f"{r['clamp_at_damage_vs_ft']:.3f} / {r['gauge_at_damage_vs_ft']:.3f} ({r['clamp_1d_at_damage_vs_ft']:.3f}"
            f" / {r['gauge_1d_at_damage_vs_ft']:.3f}) | {r['clamp_over_gauge_max']:.3f} "
            f"({r['clamp_over_gauge_1d_max']:.3f}) | {r['peak'] / tf.FT:.3f} | "
            + (f"{r['crack_x']:.3f}, {r['where']} |" if r.get("stop") == "break" else "(run to first damage) |"))
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--only", default="bar_L0.7_a0.30")
    ap.add_argument("--n-grid", default="48", help="comma list")
    ap.add_argument("--speed", default="1", help="comma list of factors on tf.PULL")
    ap.add_argument("--start", default="step", help="step or ramp")
    ap.add_argument("--ramp", type=float, default=0.0, help="the ramp (s) for --start ramp")
    ap.add_argument("--stop", type=int, default=0, help="end this many frames after the first damage (0: the break)")
    ap.add_argument("--profile", type=int, default=0, help="print edge_profile after this many frames, and stop")
    a = ap.parse_args()
    tf.name_check(a.engine)
    if a.profile:
        for name in a.only.split(","):
            for n in (int(g) for g in a.n_grid.split(",")):
                sp = next(s for s in ut.USER if s.name == name)
                print(json.dumps(edge_profile(sp, n, a.engine, a.profile, a.ramp or ut.RAMP_S)), flush=True)
        return
    path = RESULTS / "step_wave.json"
    rows = json.loads(path.read_text())["cases"] if path.exists() else []
    for name in a.only.split(","):
        sp = next(s for s in ut.USER if s.name == name)
        for n in (int(g) for g in a.n_grid.split(",")):
            for sp_f in (float(s) for s in a.speed.split(",")):
                r = run(sp, n, a.engine, a.start, sp_f, a.ramp if a.start == "ramp" else 0.0, a.stop)
                print(json.dumps({k: v for k, v in r.items() if not k.startswith("history")}), flush=True)
                rows = [q for q in rows if _key(q) != _key(r)] + [r]
                path.write_text(json.dumps({"cases": rows}, separators=(",", ":")))
    (RESULTS / "step_wave.md").write_text(
        "# The step-started pull's stress wave (issue 66, round 45)\n\n`python benchmarks/studies/step_wave.py` "
        f"(its docstring says what each column is). E {tf.E:g} Pa, nu 0, rho {tf.RHO:g}, c = sqrt(E / rho) = "
        f"{C:.2f} m/s, f_t {tf.FT:g} Pa, f64. Stresses over f_t unless said; (1D): the 1D elastic bar's.\n\n"
        + table(rows))


if __name__ == "__main__":
    main()
