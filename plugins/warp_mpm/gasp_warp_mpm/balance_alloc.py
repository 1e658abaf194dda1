"""The contact balance's arrays on a :class:`~gasp_warp_mpm.engine.WarpMPMEngine` (:mod:`gasp_warp_mpm.balance`'s
kernels read them): apart from the kernels so that ``balance.py`` keeps the house's file size (round 59)."""
import warp as wp

from gasp_core.mpm.contact_mark import check_mark_rows

from .balance import FR_COLUMNS, f64
from .precision import build_types


def allocate_balance(engine, planes: list, Ft, n_sup: int = 1) -> None:
    """The contact's balance arrays on ``engine`` (a :class:`~gasp_warp_mpm.engine.WarpMPMEngine` with ``setup``,
    ``device``, ``n_grid``): per body its sums, shift, reach (m) and mass (kg); per support (``n_sup`` a body: the
    grounds, then each collider with the particle contact) its contact sums and friction sums; the contact nodes'
    supports and list. No particle contact (``planes`` empty and ``n_sup`` 1), or ``contact_balance = false``: zero
    bodies, no balance."""
    import numpy as np
    from gasp_core.mpm.contact import balance_mass, contact_reach, JSUMS, SUMS, rigid_bodies
    setup, d = engine.setup, engine.device
    reach = contact_reach(setup) if planes or n_sup > 1 else np.zeros(0)
    nb = len(reach)
    engine.n_sup = n_sup
    check_mark_rows(nb * n_sup)
    jsums = np.zeros((nb * n_sup, len(JSUMS)))
    box = JSUMS.index("x_min")
    jsums[:, box:box + 6:2] = 1.0e30   # the box of the pushed points starts inverted
    jsums[:, box + 1:box + 6:2] = -1.0e30
    engine.c_sums = wp.zeros((nb, len(SUMS)), dtype=f64, device=d)
    engine.c_jsums = wp.array(jsums, dtype=f64, device=d)
    engine.c_shift = wp.zeros((nb, 12), dtype=f64, device=d)
    engine.c_reach = wp.array(reach, dtype=f64, device=d)
    # round 59: 0 for a body whose material flows, which the balance leaves alone (gasp_core.mpm.contact.balance_mass)
    mass = balance_mass(setup)[:nb] if nb else np.zeros(0)
    engine.c_mass = wp.array(mass.astype(np.float64), dtype=f64, device=d)
    rigid = np.zeros(max(nb, 1), np.int32)   # rigid bodies (body_fix's closing bound, round 59)
    rigid[:nb] = np.resize(rigid_bodies(setup.materials).astype(np.int32), nb) if nb else 0
    engine.c_rigid = wp.array(rigid, dtype=wp.int32, device=d)
    n_nodes = engine.n_grid ** 3 if nb else 1
    engine.grid_fbody = wp.array(np.full(n_nodes, -1, np.int32), dtype=wp.int32, device=d)
    engine.fr_sums = wp.zeros((nb * n_sup, FR_COLUMNS), dtype=f64, device=d)
    engine.fr_nodes = wp.zeros(1 + min(n_nodes, 8 * engine.n_grid ** 2 * max(1, len(planes) + n_sup - 1)),
                               dtype=wp.int32, device=d)
    # the gpu schedule (gasp_warp_mpm.schedule): each contact node's friction change and mass, and its budget
    n_gpu = n_nodes if nb and getattr(engine, "schedule", "cpu") == "gpu" else 1
    engine.fr_dv = wp.zeros(n_gpu, dtype=build_types(Ft)[1], device=d)
    engine.fr_fb = wp.zeros(n_gpu, dtype=Ft, device=d)
