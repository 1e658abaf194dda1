"""The rigid collider's arrays and recorded launches (``rigid_collider.py``'s kernels; ``docs/rigid.md`` "Round 63",
"Round 64"): :func:`collider_launches` after the grid update, :func:`with_mark` after the fields' first pass.

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import numpy as np
import warp as wp

from gasp_core.mpm import rigid_collider as core_collider
from gasp_core.mpm.face_share import b_band
from gasp_core.mpm.rigid import affine_dx

from . import collider_pair as cp
from . import rigid_collider as rc
from .field_nodes import sweep_args
from .rigid_pairs import vec3d


def allocate_collider(eng, Ft) -> None:
    """``eng.rc_on`` (``gasp_core.mpm.rigid_pairs.pair_data``'s collider, ``rigid_collider.collider_data``, not
    None) and, where on, the per-node marks and owners and each slot's sums (``eng.rc_ns`` slots, one a rigid body; ``eng.rc_multi``: round 64's scenes)."""
    from gasp_core.mpm.rigid_pairs import pair_data
    data = pair_data(eng.setup)[2] if getattr(eng, "fields", False) else None
    eng.rc_on = data is not None
    if not eng.rc_on:
        return
    n, d, nb = eng.n_grid ** 3, eng.device, len(eng.setup.materials)
    bodies = np.asarray(data["bodies"], np.int32)
    eng.rc_ns, eng.rc_multi, eng.rc_rb = len(bodies), int(data["multi"]), int(bodies[0])
    eng.rc_ra = int(eng.in_a.numpy()[eng.rc_rb])   # the pair's rigid field (rc_sum; round 64 reads in_a)
    eng.rc_bodies = wp.array(bodies, dtype=wp.int32, device=d)
    slot = np.full(nb, -1, np.int32)
    slot[bodies] = np.arange(len(bodies), dtype=np.int32)
    eng.rc_slot = wp.array(slot, dtype=wp.int32, device=d)
    # round 65: the pairs' table (collider_pair.py), a column a soft body (one: the pair, or PAIR_MU off)
    mus = np.full((len(bodies), 1), eng.field_mu) if data["mus"] is None else np.asarray(data["mus"], np.float64)
    eng.rc_ncol = int(mus.shape[1])
    eng.rc_cols = wp.array(np.asarray(data["cols"], np.int32), dtype=wp.int32, device=d)
    eng.rc_mus = wp.array(mus.reshape(-1), dtype=wp.float64, device=d)
    eng.rc_pacc = wp.zeros(int(cp.NP) * mus.size, dtype=wp.float64, device=d)
    eng.rc_sb = wp.full(2 * n, -1, dtype=wp.int32, device=d)
    eng.rc_m = wp.zeros(n, dtype=eng.k.vec3, device=d)
    eng.rc_n = wp.zeros(n, dtype=eng.k.vec3, device=d)
    eng.rc_o = wp.full(n, -1, dtype=wp.int32, device=d)   # an empty node's slot (rc_mark sweeps the box only)
    eng.rc_box = wp.array(np.asarray(data["boxes"], np.float64).reshape(-1, 3), dtype=vec3d, device=d)
    eng.rc_acc = wp.zeros(int(rc.NA) * len(bodies), dtype=wp.float64, device=d)
    # round 66: the round bodies' slots (1: the point contact, point_contact.py; 0: the band), their lattices
    eng.rc_points = data.get("points")
    on = np.zeros(len(bodies), np.int32) if eng.rc_points is None else eng.rc_points["on"]
    eng.rc_pt = wp.array(np.asarray(on, np.int32), dtype=wp.int32, device=d)


def with_mark(eng, Ft, launches: list) -> list:
    """``launches`` (``fields.field_launches``: ..., the first pass, the touch's clear where there is one, the fields'
    clear) with ``rc_mark`` put after the first pass; as given where the rule is off."""
    if not getattr(eng, "rc_on", False):
        return launches
    from gasp_core.mpm.fields import GROUND_MIRROR
    from gasp_core.mpm.rigid_pairs import NODE_PAD
    walls = eng.wall_mu.shape[0] > 0   # the walls' reach as fields.field_launches gives it
    side = (np.asarray(eng.setup.domain_hi, float) - np.asarray(eng.setup.domain_lo, float)) / eng.dx
    wall_lo, wall_hi = (eng.wall_in, side - eng.wall_in) if walls else (-1.0, np.full(3, 1e30))
    band_b, face = b_band()
    sweep = sweep_args(eng)   # round 69: the launch's size is the sweep's threads (it was shared_threads: equal)
    mark = wp.launch(rc.build_collider(Ft)[0], dim=sweep[1], device=eng.device, record_cmd=True, inputs=[
        eng.grid_mv, eng.grid_sv, eng.grid_vf, eng.n_grid, eng.ground, Ft(eng.dx ** 3), Ft(wall_lo),
        eng.k.vec3(*[float(c) for c in wall_hi]), Ft(eng.field_touch), eng.ground_touch, eng.flow_touch,
        eng.field_rule % 2, eng.rc_m, eng.rc_n, eng.grid_dv, eng.in_a, eng.rc_bodies, eng.rc_ns, eng.rc_multi,
        int(bool(GROUND_MIRROR)), float(core_collider.BAND * eng.dx),
        eng.k.vec3(*[float(c) for c in eng.setup.domain_lo]), Ft(eng.dx), eng.rc_o, eng.rb_c, eng.rb_R, eng.rc_box,
        float(NODE_PAD * eng.dx), eng.rc_sb, eng.rc_pt, *sweep, float(band_b * eng.dx), Ft(face)])   # round 68: over
    # the box sweep; round 96: a rigid field B's band and face test (gasp_core.mpm.face_share.b_band)
    if eng.rc_pt.numpy().any():   # round 66: the fields' node masses for the point contact (point_contact.py)
        from .point_contact import mass_launch
        mark = [mark, mass_launch(eng, Ft)]
    else:
        mark = [mark]
    at = len(launches) - 1 - int(eng.flow_touch_on or eng.gap_touch_on)
    return launches[:at] + mark + launches[at:]


def collider_launches(eng, Ft, g2p) -> list:
    """The recorded collider pass after the grid update, before G2P (``g2p``, returned after it); none where off
    (allocated here, before :func:`with_mark`). Node passes over the grid; ``rc_psum`` (round 64) over the material
    points; ``rc_body``, ``rc_solve`` one thread a slot (``rc_ns`` rigid bodies), ``rc_coulomb`` one thread a pair
    (round 65: ``rc_ns`` times ``rc_ncol``). Round 66 (``gasp_core.mpm.rigid_sdf.POINT_CONTACT``): ``V*`` only before
    G2P, the contact by the soft points after it (``point_contact.py``)."""
    allocate_collider(eng, Ft)
    if not eng.rc_on:
        return [g2p]
    return _collider_launches(eng, Ft, g2p)


def _collider_launches(eng, Ft, g2p) -> list:
    _, c_nodes, c_body, c_solve, c_coulomb, c_psum = rc.build_collider(Ft)
    d, ng, ns = eng.device, eng.n_grid, eng.rc_ns
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    geo = [eng.rc_m, eng.rc_n, eng.rc_o, eng.in_a, eng.rc_bodies, eng.rb_c, ng, lo, Ft(eng.dx), eng.rc_acc]
    pairs = [eng.rc_sb, eng.rc_cols, eng.rc_ncol, eng.rc_pacc]   # round 65: Coulomb's per pair (collider_pair.py)

    sweep = sweep_args(eng)

    def nodes(job: int):   # round 69: a node pass over the box sweep (rigid_collider.rc_nodes)
        return wp.launch(c_nodes, dim=sweep[1], device=d, record_cmd=True, inputs=[
            eng.grid_v, eng.grid_dv, *geo, *pairs, eng.acc_p, eng.acc_l, rc.REACT, eng.rc_ra, job, *sweep])

    solve = [eng.rc_acc, eng.rb_M, eng.rb_I0, eng.rb_R, eng.rc_bodies, affine_dx(eng.dx)]   # round 67: own I
    if eng.rc_multi:   # round 64: V* from each slot body's points (a field may hold several bodies)
        out = [wp.launch(c_psum, dim=eng.n_material, device=d, record_cmd=True, inputs=[
            eng.x, eng.body, eng.p_mass, eng.grid_v, eng.grid_dv, eng.in_a, eng.rc_slot, lo, Ft(eng.inv_dx), ng,
            eng.rc_acc, eng.rc_sb])]
    else:
        out = [nodes(0)]
    out.append(wp.launch(c_body, dim=ns, device=d, record_cmd=True, inputs=[eng.rc_acc, eng.rb_w, eng.rc_bodies]))
    for mode in (0, 1):   # the normal solve, then the tangential one
        out += [nodes(1 + mode),
                wp.launch(c_solve, dim=ns, device=d, record_cmd=True, inputs=[*solve, mode, rc.IMPLICIT])]
    points = []
    if eng.rc_pt.numpy().any():   # round 66: the round bodies' contact by the soft points (point_contact.py)
        from gasp_core.mpm.rigid_sdf import GRID_PASSES
        if eng.rc_points.get("roll", 0):   # round 70: the option roll_contact (roll_grid.py)
            from .roll_grid import roll_launches
            points = roll_launches(eng, Ft)
        elif GRID_PASSES > 0:   # round 67: the contact as a constraint of the grid velocities (point_grid.py)
            from .point_grid import grid_launches
            points = grid_launches(eng, Ft, GRID_PASSES)
        else:
            from .point_contact import point_launches
            points = point_launches(eng, Ft, c_solve, c_coulomb)
    return out + [
        nodes(3), wp.launch(c_coulomb, dim=ns * eng.rc_ncol, device=d, record_cmd=True, inputs=[
            eng.rc_pacc, eng.rc_mus, float(rc.FRICTION)]), nodes(4)] + points + [g2p]
