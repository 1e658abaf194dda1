"""Issue 38's torque budget: where a bouncing ball's spin comes from, per contact model.

The issue's ball (600 flat Gaussians on a 5 cm sphere with their fill, ``benchmarks/contact_mustshow.py``; jelly
E 2e4 Pa, nu 0.3, rho 300; dropped 5 cm; n_grid 16; warp_mpm) on a frictionless ground, stepped one substep per
call (``frame_dt`` = the contact's substep) over its first bounce (0.19 s). Figures per contact model and ball
(Fibonacci, or its Gaussians' centres jittered +-3 mm):

- ``omega``: the body's angular velocity after the bounce (rad/s, ``|I^-1 L|`` about the mass centre);
- ``J``: the ground's normal impulse over the bounce (kg m/s, from the momentum balance ``dp_z + m g t``);
- ``lever``: ``|dL| / J`` (mm): how far off the mass centre the contact pushes on average; under 0.03 mm is what
  keeps the travel at friction 0.5 under the issue's 1 mm (a spin of about 0.05 rad/s per bounce);
- ``contact``: for the point contacts, the torque of the contact's own impulses about the mass centre
  (``sum_p (x_p - c) x j_p z``, recomputed from the engine's points with ``gasp_core.mpm.contact.plane_impulse``
  before each substep), as a lever (mm), and the share of ``dL`` it explains: the rest is the stress and the
  transfers (MLS-MPM's internal forces and APIC transfers conserve angular momentum, so it should be small).

Run: ``python benchmarks/studies/contact_torque.py [--contacts particle grid]``; the table goes to stdout and
``benchmarks/results/contact_torque.md``.
"""
from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import contact_mustshow as cm

STEPS = 180


def _frame(e) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (e.x.numpy().astype(np.float64), e.v.numpy().astype(np.float64), e.p_mass.numpy().astype(np.float64))


def _momenta(x: np.ndarray, v: np.ndarray, m: np.ndarray):
    c = (m[:, None] * x).sum(axis=0) / m.sum()
    vc = (m[:, None] * v).sum(axis=0) / m.sum()
    r = x - c
    L = (m[:, None] * np.cross(r, v - vc)).sum(axis=0)
    inertia = (m[:, None, None] * ((r * r).sum(axis=1)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :])).sum(0)
    return c, vc, L, inertia


def budget(contact: str, jitter: float) -> dict:
    """One row: the ball's first bounce on a frictionless ground under ``contact``."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    from gasp_core.mpm.contact import plane_impulse
    d = Path(tempfile.mkdtemp())
    ply = cm.ball(d / "ball.ply", jitter)
    text = cm.scene(ply, "warp_mpm", contact).replace("friction = 0.5", "friction = 0.0")
    (d / "probe.toml").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dt = build_engine(*_prepared(d / "probe.toml")).dt   # the substep the contact asks for
        (d / "s.toml").write_text(text.replace("frame_dt = 0.0333333", f"frame_dt = {dt!r}")
                                  .replace("n_frames = 40", f"n_frames = {STEPS}"))
        info, setup = _prepared(d / "s.toml")
        e = build_engine(info, setup)
    assert e.n_substeps == 1, e.n_substeps
    g = float(setup.gravity[2])
    x, v, m = _frame(e)
    _, vc0, L0, _ = _momenta(x, v, m)
    point = contact != "grid"
    lc = np.zeros(3)
    for _ in range(STEPS):
        if point:
            x, v, m = _frame(e)
            c = (m[:, None] * x).sum(axis=0) / m.sum()
            jn, _ = plane_impulse(x[:, 2], v[:, 2], e.p_contact.numpy().astype(np.float64), 0.0, 0.0, e.dt)
            lc += np.cross(x - c, np.column_stack([0 * jn, 0 * jn, jn])).sum(axis=0)
        e.step_frame()
    x, v, m = _frame(e)
    _, vc1, L1, inertia = _momenta(x, v, m)
    e.close()
    dL = L1 - L0
    J = m.sum() * ((vc1[2] - vc0[2]) - g * STEPS * dt)
    row = {"omega": float(np.linalg.norm(np.linalg.solve(inertia, L1))), "J": float(J),
           "lever_mm": 1e3 * float(np.linalg.norm(dL[:2])) / J}
    if point:
        row["contact_lever_mm"] = 1e3 * float(np.linalg.norm(lc[:2])) / J
        row["explained"] = float(lc[:2] @ dL[:2] / max(dL[:2] @ dL[:2], 1e-300))
    return row


def _prepared(path: Path):
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    ps = prepare_scene(load_scene(path))
    return ps.info, ps.setup


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--contacts", nargs="+", default=["particle", "grid"])
    a = ap.parse_args()
    rows = ["| contact | ball | omega after the bounce (rad/s) | J (kg m/s) | lever of dL (mm) | "
            "contact impulses' lever (mm) | share of dL they explain |", "|---|---|---|---|---|---|---|"]
    t0 = time.perf_counter()
    for contact in a.contacts:
        for jitter in (0.0, cm.JITTER):
            r = budget(contact, jitter)
            rows.append(f"| {contact} | {'jittered' if jitter else 'Fibonacci'} | {r['omega']:.3f} | {r['J']:.3f} | "
                        f"{r['lever_mm']:.3f} | {r.get('contact_lever_mm', float('nan')):.3f} | "
                        f"{r.get('explained', float('nan')):.2f} |")
            print(rows[-1], flush=True)
    text = "\n".join(rows)
    res = Path(__file__).resolve().parents[1] / "results"
    res.mkdir(exist_ok=True)
    (res / "contact_torque.md").write_text(
        f"`python benchmarks/studies/contact_torque.py --contacts {' '.join(a.contacts)}` (warp_mpm, n_grid 16, friction 0, "
        f"{STEPS} substeps from the release, {time.perf_counter() - t0:.0f} s wall)\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
