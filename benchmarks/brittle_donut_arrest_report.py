"""The Markdown tables, words and curves of ``benchmarks/brittle_donut_arrest.py`` (docs/fracture.md "Round 45: why
the default donut's cracks stop"): its samples (dicts of :func:`brittle_donut_arrest.sample`) as text and a PNG."""
from __future__ import annotations

import numpy as np


COLS = [("t", "t (ms)", 1e3, ".1f"), ("kinetic", "kinetic", 1, ".2f"), ("spread", "spreading", 1, ".2f"),
        ("stored", "stored", 1, ".3f"), ("tension", "in tension", 1, ".3f"), ("dissipated", "damage", 1, ".3f"),
        ("ligament_J", "G_f x ligament (2 sections)", 1, ".3f"), ("broken", "broken through", 1, ".3f"),
        ("top_broken", "2 most broken sections", 1, None), ("opening", "opening (mm)", 1e3, ".1f"),
        ("opening_mean", "mean (mm)", 1e3, ".1f"), ("hoop_rate_broken", "hoop rate broken / rest / ring (1/s)", 1,
                                                   None), ("tip_smax", "tips s_max / f_t (max; median)", 1, None),
        ("tip_softening", "tips softening", 1, ".2f"), ("tip_hoop", "tips' tension along hoop", 1, ".2f")]


def cell(r, key, scale, fmt):
    if key == "top_broken":
        return " / ".join(f"{x:.2f}" for x in r[key])
    if key == "hoop_rate_broken":
        return f"{r['hoop_rate_broken']:.1f} / {r['hoop_rate_rest']:.1f} / {r['hoop_rate_ring']:.1f}"
    if key == "tip_smax":
        return f"{r['tip_smax']:.2f}; {r['tip_smax_median']:.2f}" if "tip_smax" in r else "-"
    return format(r[key] * scale, fmt) if key in r else "-"


def table(rows, every: int) -> list[str]:
    """A Markdown table of every ``every``-th sample (energies in J)."""
    out = ["| " + " | ".join(c[1] for c in COLS) + " |", "|" + "---|" * len(COLS)]
    for i, r in enumerate(rows):
        if (i + 1) % every == 0:
            out.append("| " + " | ".join(cell(r, c[0], c[2], c[3]) for c in COLS) + " |")
    return out


def cracks_text(last: dict) -> str:
    """The last sample's parts and cracks (:func:`crack_links`) in words."""
    out = [f"At {last['t'] * 1e3:.0f} ms: {last['parts_1']} part(s) of 1 % or more, the largest {last['largest']:.3f} "
           f"of the mass."]
    for c in last["cracks"]:
        out.append(f"Section {c['section']} ({c['broken']:.2f} broken through): {c['cut'] * 100:.0f} % of the "
                   f"{c['links']} links across it cut; stretch median / 90th pct / largest "
                   + " / ".join(f"{s * 1e3:.1f}" for s in c["stretch"]) + " mm, median by height (lower / middle / "
                   "upper third) " + " / ".join(f"{s * 1e3:.1f}" for s in c["stretch_by_height"])
                   + f" mm; the whole links at rest {c['whole_z'] * 1e3:.0f} mm up (section {c['section_z'] * 1e3:.0f}"
                   f" mm), radius {c['whole_r'] * 1e3:.0f} mm.")
    return " ".join(out)


def grady(rows, gf: float = 50.0, rho: float = 1000.0, rbar: float = 0.0702) -> str:
    """Grady's fragment length (Grady 1982, J. Appl. Phys. 53: ``L = (24 G_f / (rho edot^2))^(1/3)``) at the ring's
    largest mean hoop strain rate, and the fragments ``2 pi r_bar / L`` it makes of the ring (``rbar``, m)."""
    edot = max(r["hoop_rate_ring"] for r in rows)
    L = (24 * gf / (rho * edot ** 2)) ** (1 / 3)
    return (f"Grady: the ring's largest mean hoop rate {edot:.1f} /s gives L = {L * 100:.1f} cm, "
            f"{2 * np.pi * rbar / L:.1f} fragments of the ring.")


def plot(runs, path: str) -> None:
    """The energy budget and the tips' stress against time, one column a run (``path``: a PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, len(runs), figsize=(5.5 * len(runs), 7), squeeze=False, sharex=True)
    for j, r in enumerate(runs):
        rw = r["rows"]
        t = [w["t"] * 1e3 for w in rw]
        ax = axes[0, j]
        for key, lab in [("dissipated", "dissipated by damage"), ("tension", "stored in tension (whole body)"),
                         ("tension_near2", "stored in tension (+-2 sections of the two)"),
                         ("spread", "kinetic, in-plane spreading"), ("ligament_J", "G_f x ligament (two sections)")]:
            ax.plot(t, [w[key] for w in rw], label=lab)
        ax.set_yscale("log")
        ax.set_ylim(1e-3, 10)
        ax.set_ylabel("J")
        ax.set_title(f"{r['engine']}, n_grid {r['n_grid']}, {r['speed']} m/s")
        ax.legend(fontsize=7)
        ax = axes[1, j]
        ax.plot(t, [w.get("tip_smax_median", np.nan) for w in rw], label="tips: median s_max / f_t")
        ax.plot(t, [w.get("tip_softening", np.nan) for w in rw], label="tips: share still softening")
        ax.plot(t, [w["top_broken"][0] for w in rw], label="most broken section: broken through")
        ax.plot(t, [w["opening"] / 0.01 for w in rw], label="its opening / w_c (1 cm)")
        ax.axhline(1.0, color="k", lw=0.5)
        ax.set_ylim(0, 6)
        ax.set_xlabel("t (ms)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
