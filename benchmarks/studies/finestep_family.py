"""Round 76 (docs/rigid.md "Round 76"): the rigid box under a thrown flowing ball over a family, each at 1x, 4x and 8x
its default substeps, one frame (``finestep_paths.run``): boxes of three shapes (12 x 12 x 6, 8 x 8 x 8, 16 x 8 x 4 cm),
n_grid 32 and 48, sand and snow, and the box halved into two bodies that share a grid field
(``sand_rigid2``: each half's booking ratio 0.29); figures: the box's v_z (m/s), its spin's size (rad/s) and the scene's E / E0.
Usage: ``python benchmarks/studies/finestep_family.py warp_mpm [--before] [--grids 32]`` (``--before``: ``SPIN_BOOKED`` off, the
transfer of rounds 67-75). Writes a Markdown table to stdout; every line dated.
"""
import sys
import time

import numpy as np

import finestep_paths as fp

BOXES = {"12x12x6": (0.12, 0.12, 0.06), "8x8x8": (0.08, 0.08, 0.08), "16x8x4": (0.16, 0.08, 0.04)}


def family(eng, names=("sand_rigid", "snow_rigid", "sand_rigid2"), grids=(32, 48), ks=(1, 4, 8)):
    """Yield ``(name, box, n_grid, k, n_substeps, box_vz, box_w, e_ratio)`` over the family; a run that diverges
    gives nan figures."""
    for name in names:
        for bname, box in BOXES.items():
            for n_grid in grids:
                n1 = None
                for k in ks:
                    try:
                        r = fp.run(eng, name, None if n1 is None else k * n1, n_grid=n_grid, box=box)
                        n1 = n1 or r["n_substeps"]
                        yield name, bname, n_grid, k, r["n_substeps"], float(r["box_v"][2]), r["box_w"], r["e_ratio"]
                    except Exception as exc:   # a divergence is a figure here
                        yield name, bname, n_grid, k, (n1 or 0) * k, np.nan, np.nan, np.nan
                        print(f"<!-- {name} {bname} n{n_grid} {k}x: {type(exc).__name__}: {str(exc)[:120]} -->")


if __name__ == "__main__":
    eng = sys.argv[1]
    if "--before" in sys.argv:
        from gasp_core.mpm import spin_booking
        spin_booking.SPIN_BOOKED = False
    print(f"<!-- {time.strftime('%Y-%m-%d %H:%M')} {eng} SPIN_BOOKED {'off' if '--before' in sys.argv else 'on'} -->")
    print("| scene | box | n_grid | k | substeps | box v_z (m/s) | spin (rad/s) | E / E0 |")
    print("|---|---|---|---|---|---|---|---|")
    grids = tuple(int(g) for g in sys.argv[sys.argv.index('--grids') + 1].split(',')) if '--grids' in sys.argv else (32, 48)
    for row in family(eng, grids=grids):
        name, b, n, k, ns, vz, w, e = row
        print(f"| {name} | {b} | {n} | {k}x | {ns} | {vz:+.4f} | {w:.3f} | {e:.4g} |", flush=True)
