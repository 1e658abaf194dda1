"""``gasp bench``'s ranking in the terms of the accuracy report: shape, events and renders in units of U.

For each engine the reference run (its finest setting) has a **twin**: the same model on the next coarser
grid swept (the settings equal but for ``n_grid`` and ``precision``). Every run is measured against the
reference with :func:`gasp_studies.trade.accuracy_report` (U = the twin's own figures) and the rule of
``docs/speed_accuracy.md``; the ranking orders the runs that meet every check by their end-to-end time. It
says "not ranked" only when U is larger than the differences it would rank: when no two runs' shape residuals
are more than 1 U apart. Renders: a fixed orbit of 4 views over the reference's box (bench runs keep
world-frame splats of every frame, so a capture's ``cameras.json`` and its placement are not at hand here).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from gasp_core.scene.spec import Scene

from .accuracy import Track
from .compare import ground_height
from .measure import cheapest_ranked
from .strips import StripRow, render_strips, strips_markdown
from .images import cameras_for, image_scores, render_frames
from .run import RunOutput
from .trade import accuracy_report, rule_checks


def output_track(out: RunOutput, frame_dt: float, ground_z: float | None, label: str) -> Track | None:
    """A :class:`Track` of a bench run whose every frame was kept (world-frame splats); None if it failed."""
    kf = out.keyframes
    if out.record.get("status") != "ok" or out.obj_start is None or not kf:
        return None
    frames = sorted(kf)
    if frames != list(range(len(frames))):
        return None
    means = np.stack([np.asarray(kf[f].means, np.float64) for f in frames])
    return Track(means, np.asarray(out.obj_start), [f"object{k}" for k in range(len(out.obj_start) - 1)],
                 frame_dt, ground_z, float(out.record.get("dx_m", np.nan)), label, kf.__getitem__)


def twin_index(settings: list[dict], ignore: tuple[str, ...] = ("n_grid", "precision")) -> int | None:
    """Index of the reference's twin among ``settings`` (reference first): the same model on the largest
    ``n_grid`` below the reference's; None without one."""
    ref = settings[0]
    if "n_grid" not in ref:
        return None
    model = {k: v for k, v in ref.items() if k not in ignore}
    best = None
    for i, s in enumerate(settings[1:], 1):
        if {k: v for k, v in s.items() if k not in ignore} == model and s.get("n_grid", 0) < ref["n_grid"]:
            if best is None or s["n_grid"] > settings[best]["n_grid"]:
                best = i
    return best


def rank_engine(rows: list[dict], tracks: list[Track | None], settings: list[dict], image_frames) -> dict:
    """Add the report's figures to one engine's ``rows`` (reference first) and return its ranking.

    Row keys added: ``shape_max`` (fraction of the size), ``shape_u``, ``rotation_max_deg``,
    ``psnr_db``, ``ssim``, ``rule_ok``, ``rule_misses``. Returns ``{"u": {...}, "twin": label, "ranked":
    [labels], "not_ranked": why or "", "rest": [(label, misses)]}``.
    """
    ref, ti = tracks[0], twin_index(settings)
    twin = tracks[ti] if ti is not None else None
    out = {"u": {}, "twin": rows[ti]["setting"] if ti is not None else None, "ranked": [], "not_ranked": "", "rest": []}
    if ref is None:
        out["not_ranked"] = "the reference run failed"
        return out
    frames = [f for f in image_frames if f > 0 and f < len(ref.means)]
    cams, views = cameras_for(ref, frames)
    ref_img = render_frames(ref, frames, cams)
    twin_sc = image_scores(ref_img, render_frames(twin, frames, cams)) if twin is not None else None
    out["views"] = views
    for r, tr in zip(rows[1:], tracks[1:]):
        if tr is None:
            r.update(rule_ok=False, rule_misses="run failed")
            continue
        sc = image_scores(ref_img, render_frames(tr, frames, cams))
        rep = accuracy_report(tr, ref, twin, images={"run": sc, "twin": twin_sc} if twin_sc else None)
        f = next(iter(rep["objects"].values()))
        checks = rule_checks(rep)
        r.update(shape_max=f["worst"]["shape"], shape_u=f.get("in_u", {}).get("shape", np.nan),
                 rotation_max_deg=f["worst"]["rotation_deg"], psnr_db=sc["psnr_db"], ssim=sc["ssim"],
                 rule_ok=all(c["ok"] for c in checks.values()),
                 rule_misses=", ".join(f"{k} {c['value']:.3g} > {c['limit']:.3g}" if k != "psnr_db" else
                                       f"PSNR {c['value']:.3g} < {c['limit']:.3g} dB"
                                       for k, c in checks.items() if not c["ok"]))
        if "u" in f:
            out["u"] = {"shape": f["u"]["shape"], "position": f["u"]["position"],
                        "psnr_db": twin_sc["psnr_db"] if twin_sc else np.nan}
    cand = [r for r in rows[1:] if np.isfinite(r.get("shape_u", np.nan))]
    if twin is None:
        out["not_ranked"] = "no twin (the reference's model on a coarser grid) was swept: U is unknown"
    elif len(cand) > 1 and np.ptp([r["shape_u"] for r in cand]) < 1.0:
        out["not_ranked"] = (f"U (shape {100 * out['u']['shape']:.2g} % of the size) is larger than the differences "
                             f"between the runs (their shape residuals span {np.ptp([r['shape_u'] for r in cand]):.2f} U)")
    ok = sorted([r for r in rows[1:] if r.get("rule_ok")], key=lambda r: r.get("end_to_end_s", np.inf))
    out["ranked"] = [] if out["not_ranked"] else [r["setting"] for r in ok]
    out["unranked"] = [r["setting"] for r in ok] if out["not_ranked"] else []
    out["rest"] = [(r["setting"], r.get("rule_misses", "")) for r in rows[1:] if not r.get("rule_ok")]
    return out


def ranking_lines(engine: str, rows: list[dict], rank: dict) -> list[str]:
    """Markdown lines of one engine's ranking (also what ``gasp bench`` prints at its end)."""
    u = rank.get("u") or {}
    head = (f"**{engine}**: reference `{rows[0]['setting']}`, twin `{rank.get('twin')}`; U = shape "
            f"{100 * u.get('shape', np.nan):.2g} %, position {100 * u.get('position', np.nan):.2g} % of the size, "
            f"twin's PSNR {u.get('psnr_db', np.nan):.1f} dB ({rank.get('views', 'no renders')})")
    lines = [head, ""]
    if rank["not_ranked"]:
        lines.append(f"- not ranked: {rank['not_ranked']}")
    by = {r["setting"]: r for r in rows}
    ref_s = rows[0].get("end_to_end_s", np.nan)
    for i, s in enumerate(rank["ranked"], 1):
        r = by[s]
        lines.append(f"- {i}. `{s}`: speed-up {ref_s / r['end_to_end_s']:.2f}x (end to end), shape {r['shape_u']:.2f} U, "
                     f"PSNR {r['psnr_db']:.1f} dB, SSIM {r['ssim']:.3f}")
    for s in rank.get("unranked", []):
        r = by[s]
        lines.append(f"- meets the rule, not ranked: `{s}` ({ref_s / r['end_to_end_s']:.2f}x, shape "
                     f"{r['shape_u']:.2f} U, PSNR {r['psnr_db']:.1f} dB, SSIM {r['ssim']:.3f})")
    for s, why in rank["rest"]:
        r = by[s]
        lines.append(f"- misses the rule: `{s}` ({ref_s / r.get('end_to_end_s', np.nan):.2f}x, shape "
                     f"{r.get('shape_u', np.nan):.2f} U, PSNR {r.get('psnr_db', np.nan):.1f} dB): {why}")
    return lines + [""]


def plot_u(outdir: Path, engine: str, rows: list[dict]) -> str | None:
    """``pareto_u_<engine>.png``: end-to-end time against the shape residual in U (1.5 U dashed); None without
    matplotlib or figures."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    pts = [r for r in rows[1:] if np.isfinite(r.get("shape_u", np.nan)) and np.isfinite(r.get("end_to_end_s", np.nan))]
    if not pts:
        return None
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for r in pts:
        ax.scatter(r["end_to_end_s"], r["shape_u"], color="tab:green" if r.get("rule_ok") else "tab:gray")
        ax.annotate(r["setting"], (r["end_to_end_s"], r["shape_u"]), fontsize=7, xytext=(3, 3),
                    textcoords="offset points")
    ax.axhline(1.5, color="tab:red", ls="--", lw=1, label="1.5 U (the default rule)")
    ax.axvline(rows[0].get("end_to_end_s", np.nan), color="black", ls=":", lw=1, label="reference run")
    ax.set_ylim(0, max([1.8] + [1.1 * r["shape_u"] for r in pts]))
    ax.set_xlabel("end to end, s")
    ax.set_ylabel("shape residual after the best rigid fit, U")
    ax.set_title(f"{engine}: green = meets every check of the rule", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    name = f"pareto_u_{engine}.png"
    fig.savefig(outdir / name, dpi=110)
    plt.close(fig)
    return name


def bench_strips(outdir: Path, scene: Scene, keep: tuple[int, ...], rows: list[dict], row_k: list[int],
                 outputs: list[RunOutput], progress: bool) -> list[str]:
    """Render ``strip_<engine>.png`` (rows: the reference, the cheapest setting within 1 % and within 5 %
    of the object size, as in the summary table) and return the summary's ``## Frames`` lines."""
    groups: dict[str, list[StripRow]] = {}
    captions: dict[str, str] = {}
    for eng in dict.fromkeys(r["engine"] for r in rows):
        idx = [i for i, r in enumerate(rows) if r["engine"] == eng]
        ref = rows[idx[0]]
        shown = {idx[0]: ["reference"]}
        for level, (c, _) in ((1, cheapest_ranked([rows[i] for i in idx], 0.01)),
                              (5, cheapest_ranked([rows[i] for i in idx], 0.05))):
            if c is not None:
                shown.setdefault(next(i for i in idx if rows[i] is c), []).append(f"within {level} %")
        groups[eng], parts = [], []
        for i, what in shown.items():
            r, name = rows[i], " and ".join(what)
            groups[eng].append(StripRow(f"{name}:\n{r['setting']}", outputs[row_k[i]].keyframes))
            cost = f"{r['wall_s']:.3g} s" if r["status"] == "ok" else r["status"]
            err = "" if i == idx[0] else f", err_max {100 * r['err_max']:.2g} %"
            parts.append(f"{name} `{r['setting']}` ({cost}{err})")
        captions[eng] = f"`{eng}`, rows top to bottom: " + "; ".join(parts)
        if ref["status"] != "ok":
            captions[eng] += " (no reference: no errors to choose by)"
    strips = render_strips(outdir, groups, keep, scene.frame_dt, ground_height(scene))
    if progress:
        print("gasp bench: strips: " + (f"skipped ({strips.skipped})" if strips.skipped else
              f"{len(strips.files)} rendered in {strips.render_s:.1f} s"), file=sys.stderr, flush=True)
    return strips_markdown(strips, scene.frame_dt, captions)
