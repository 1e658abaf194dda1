"""The grid update (docs/mpm.md step 3): node velocity, gravity, forces, impulses and colliders, then the
walls, grounds and fixed regions, as a Warp kernel per scalar type (:mod:`gasp_warp_mpm.precision`).

The grid update clears ``grid_mv`` after reading it, so no separate clear pass is needed (the spec's step 1
is folded into the previous substep's step 3).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.grid_tables import FT_TIME

from .colliders import build_blend, build_collide, build_collider_func
from .balance import build_balance, f64, keep_row, support_dv, v64
from .contact import build_collider_contact, build_contact
from .field_nodes import build_sweep
from .forces import build_extras_struct, build_force_funcs
from .precision import MODULE_OPTIONS, build_types
from .touch import build_dashpot, build_held, build_share, build_touch


@functools.cache
def build_extras(Ft):
    """``(Extras, extras)``: the struct of colliders, forces and impulses and the function applying them
    at a grid node, for the scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    apply_forces, apply_impulses = build_force_funcs(Ft)
    apply_colliders = build_collider_func(Ft)

    @wp.func
    def extras(v_in: vec3, X: vec3, dt: Ft, m: Ft, gsurf: vec3, ex: Extras, frac: Ft):
        # Forces, impulses, then colliders at a node (the same order as taichi_mpm's extras); frac: the node's
        # flowing-mass fraction (colliders.build_blend)
        base = ex.step[0] * ex.width
        t = ex.tab[base + FT_TIME]
        v = apply_forces(v_in, X, dt, m, gsurf, t, ex)
        v = apply_impulses(v, X, base, ex)
        return apply_colliders(v, X, base, ex, frac)

    return Extras, extras


@functools.cache
def build_contact_friction(Ft):
    """``(contact_friction, clear_contact)``: ``contact_friction(vel, m, node, grid_fb, colc, grid_fn, grid_fv)``, the
    particle contact's Coulomb friction
    at a node (:mod:`gasp_warp_mpm.contact`), scalar type ``Ft``: on the tangential (x, y) velocity, or with the
    walls' or colliders' particle contact (``colc``) relative to the supports in the plane normal to their normal; and
    ``clear_contact`` of a node's budget (and its normal and supports' velocity)."""
    vec3, vec4, mat33 = build_types(Ft)
    node_friction = build_contact(Ft)[1]
    surface_friction = build_collider_contact(Ft)[2]

    @wp.func
    def contact_friction(vel: vec3, m: Ft, node: int, grid_fb: wp.array(dtype=Ft), colc: int,
                         grid_fn: wp.array(dtype=vec3), grid_fv: wp.array(dtype=vec3)):
        out = vel
        if colc != 0:
            out = surface_friction(vel, m, grid_fb[node], grid_fn[node], grid_fv[node])
        else:
            out = node_friction(vel, m, grid_fb[node])
        return out

    @wp.func
    def clear_contact(node: int, grid_fb: wp.array(dtype=Ft), colc: int, grid_fn: wp.array(dtype=vec3),
                      grid_fv: wp.array(dtype=vec3)):
        grid_fb[node] = Ft(0.0)
        if colc != 0:
            grid_fn[node] = vec3(Ft(0.0))
            grid_fv[node] = vec3(Ft(0.0))

    return contact_friction, clear_contact


@functools.cache
def build_field_friction(Ft):
    """``(field_friction, field_node, pc_friction)``, scalar type ``Ft``, the particle contact's friction with the
    two-field contact (``grid_dv`` of more than one entry; the engine passes one entry where
    ``gasp_core.mpm.fields.B_FRICTION`` is off). ``field_node(grid_dv, node, f, lo, hi, dx, wall_in, ground, n_grid,
    ground_touch, n_walls, rule)``: 1 where
    the node's two fields keep their offsets (``0 < f < 1``, ``f`` the node's flowing-mass fraction, A's share of
    ``m``; not in a ground's or the walls' node layers, where both move with the mean, ``fields.field_contact``; a
    ground's top layer in an untouched column with ``rule`` bit 1, ``touch.build_field_reach``); there, with
    ``rule`` bit 2 (``gasp_core.mpm.fields.B_OWN_FRICTION``), the grid update takes the friction on B's own velocity
    and mass. ``field_friction(grid_dv, node, dv, f, on)``: at such a node (``on``) the friction's change ``dv`` of
    the mean velocity (m/s; its budget is field B's points', as only the bodies that do not flow take the particle
    contact in a ``"mixed"`` scene; round 81: where field A is rigid, ``RIGID_A_FRICTION``, ``f`` A's mass fraction and
    ``rule`` 8) given to field B alone (``B_FRICTION``): A's offset less ``dv``, B's plus
    ``dv f / (1 - f)``, so A keeps its velocity and B takes ``m dv``; ``on`` 2 (round 82, ``f`` < 0: B rigid at the
    node, ``field_nodes.rigid_side_mass``) to A alone: B's offset less ``dv``, A's plus ``dv (1 - f) / f``. ``pc_friction(vel, m, f, node,
    grid_fb, colc, grid_fn, grid_fv, grid_dv, lo, hi, dx, wall_in, ground, n_grid, ground_touch, n_walls, rule)``: the
    grid update's friction (:func:`build_contact_friction`) on the mean ``vel`` or B's own, then ``field_friction``;
    returns the node's new mean velocity (m/s). ``keep_fraction(grid_mf, grid_fbody, grid_dv, node, f, lo, hi, dx,
    wall_in, ground, n_grid, ground_touch, n_walls, rule)``: with ``rule`` bit 3 (``gasp_core.mpm.fields.B_BALANCE``),
    at a node the contact's balance listed (``grid_fbody`` set) where ``field_node`` is 1, ``f`` kept in ``grid_mf``
    (cleared by the grid update before) for the balance's fix, which gives its change to field B alone
    (``schedule.ordered.contact_fix``, ``schedule.gpu_balance``'s ``fix_nodes``) and clears it."""
    vec3, vec4, mat33 = build_types(Ft)
    held_node = build_held(Ft)
    contact_friction = build_contact_friction(Ft)[0]

    @wp.func
    def field_node(grid_dv: wp.array(dtype=vec3), node: int, f: Ft, lo: vec3, hi: vec3, dx: Ft, wall_in: Ft,
                   ground: wp.array(dtype=vec3), n_grid: int, ground_touch: wp.array(dtype=wp.int32), n_walls: int,
                   rule: int):
        i = node / (n_grid * n_grid)
        j = (node / n_grid) % n_grid
        k = node % n_grid
        X = lo + dx * vec3(Ft(i), Ft(j), Ft(k))
        reach = wall_in * dx
        held = held_node(i, j, k, ground, n_grid, ground_touch, rule % 2, X, lo + vec3(reach), hi - vec3(reach),
                         n_walls)
        on = int(0)
        if grid_dv.shape[0] > 1 and held == 0 and f > Ft(0.0) and f < Ft(1.0):
            on = int(1)
        return on

    @wp.func
    def field_friction(grid_dv: wp.array(dtype=vec3), node: int, dv: vec3, f: Ft, on: int):
        n_nodes = grid_dv.shape[0] / 2
        if on == 1:
            grid_dv[node] = grid_dv[node] - dv
            grid_dv[n_nodes + node] = grid_dv[n_nodes + node] + (f / (Ft(1.0) - f)) * dv
        elif on == 2:   # round 82: to field A alone (a rigid field B)
            grid_dv[n_nodes + node] = grid_dv[n_nodes + node] - dv
            grid_dv[node] = grid_dv[node] + ((Ft(1.0) - f) / f) * dv

    @wp.func
    def pc_friction(vel: vec3, m: Ft, f: Ft, node: int, grid_fb: wp.array(dtype=Ft), colc: int,
                    grid_fn: wp.array(dtype=vec3), grid_fv: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3),
                    lo: vec3, hi: vec3, dx: Ft, wall_in: Ft, ground: wp.array(dtype=vec3), n_grid: int,
                    ground_touch: wp.array(dtype=wp.int32), n_walls: int, rule: int):
        fa = wp.abs(f)   # round 82: f < 0, A's mass fraction where field B is rigid (field_nodes.rigid_side_mass)
        on = field_node(grid_dv, node, fa, lo, hi, dx, wall_in, ground, n_grid, ground_touch, n_walls, rule)
        out = vel
        if on != 0 and (rule / 2) % 2 != 0:   # on field B's own velocity and mass (B_OWN_FRICTION)
            vb = vel + grid_dv[grid_dv.shape[0] / 2 + node]
            out = vel + (Ft(1.0) - fa) * (contact_friction(vb, (Ft(1.0) - fa) * m, node, grid_fb, colc, grid_fn,
                                                           grid_fv) - vb)
        else:
            out = contact_friction(vel, m, node, grid_fb, colc, grid_fn, grid_fv)
        if on != 0 and f < Ft(0.0):
            on = int(2)
        field_friction(grid_dv, node, out - vel, fa, on)
        return out

    @wp.func
    def keep_fraction(grid_mf: wp.array(dtype=Ft), grid_fbody: wp.array(dtype=wp.int32), grid_dv: wp.array(dtype=vec3),
                      node: int, f: Ft, lo: vec3, hi: vec3, dx: Ft, wall_in: Ft, ground: wp.array(dtype=vec3),
                      n_grid: int, ground_touch: wp.array(dtype=wp.int32), n_walls: int, rule: int):
        if (rule / 4) % 2 != 0 and grid_fbody[node] >= 0:
            if field_node(grid_dv, node, f, lo, hi, dx, wall_in, ground, n_grid, ground_touch, n_walls, rule) != 0:
                grid_mf[node] = f

    return field_friction, field_node, pc_friction, keep_fraction


@functools.cache
def build_node_fix(Ft):
    """``node_fix(grid_v, grid_dv, grid_mf, fr_sums, s, node, lo, dx, n_grid)``, scalar type ``Ft``: the contact
    balance's fix at one listed node of support ``s`` (``fr_sums[s, 3] > 0``): its change
    (``gasp_warp_mpm.balance.support_dv`` at the node's place, m/s) added to the mean ``grid_v``, and given to field
    B alone where the grid update kept ``0 < f < 1`` in ``grid_mf`` (``gasp_core.mpm.fields.B_BALANCE``,
    ``keep_fraction``). The one node step of both schedules' fix (``schedule.ordered.contact_fix``,
    ``schedule.gpu_balance``'s ``fix_nodes``)."""
    vec3, vec4, mat33 = build_types(Ft)
    field_friction = build_field_friction(Ft)[0]

    @wp.func
    def node_fix(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), grid_mf: wp.array(dtype=Ft),
                 fr_sums: wp.array2d(dtype=f64), s: int, node: int, lo: vec3, dx: Ft, n_grid: int):
        i = node / (n_grid * n_grid)
        j = (node / n_grid) % n_grid
        k = node % n_grid
        X = v64(f64(lo[0] + dx * Ft(i)), f64(lo[1] + dx * Ft(j)), f64(lo[2] + dx * Ft(k)))
        dv64 = support_dv(fr_sums, s, X)
        dv = vec3(Ft(dv64[0]), Ft(dv64[1]), Ft(dv64[2]))
        grid_v[node] = grid_v[node] + dv
        if grid_mf.shape[0] > 1:   # B_BALANCE: f kept by the grid update where the fields keep offsets
            f = grid_mf[node]
            if f > Ft(0.0) and f < Ft(1.0):
                field_friction(grid_dv, node, dv, f, 1)

    return node_fix


@functools.cache
def build_boundary_rules(Ft):
    """``boundary_rules(vel, X, k, lo, hi, dx, wall_in, wall_full, wall_mu, ground, f, floor, i, j, n_grid,
    ground_touch)``, scalar type ``Ft``: the walls' and grounds' grid rule on node ``(i, j, k)``'s velocity (nodes
    within ``wall_in`` cells of a face, layers ``k <= ground[g][0]`` and the touched layer above, ``touch.py``; with
    the contact chosen per body by the node's flowing-mass fraction ``f`` beyond ``wall_full`` cells and above layer
    ``ground[g][2]``, ``colliders.build_blend``); round 48: the dashpot above the held layers, ``damp = s dt / dx``
    (``touch.build_dashpot``)."""
    vec3, vec4, mat33 = build_types(Ft)
    collide = build_collide(Ft)
    blend_rule = build_blend(Ft)
    ground_reach = build_touch(Ft)[2]
    dashpot = build_dashpot(Ft)
    shares = build_share(Ft)[2]

    @wp.func
    def boundary_rules(vel_in: vec3, X: vec3, k: int, lo: vec3, hi: vec3, dx: Ft, wall_in: Ft, wall_full: Ft,
                       wall_mu: wp.array(dtype=Ft), ground: wp.array(dtype=vec3), f: Ft, floor: int, i: int, j: int,
                       n_grid: int, ground_touch: wp.array(dtype=wp.int32), damp: Ft, slots: wp.array(dtype=Ft),
                       mode: int):
        vel = vel_in
        # the grounds first: a ground on the floor wall's plane keeps its friction there (taichi_mpm's order)
        for q in range(ground.shape[0]):
            gr = ground[q]
            # k <= gr[0], or the touched layer (touch.py); round 49: not a column's touched node that shares its bound
            sh = shares(k, gr, q, i, j, n_grid, ground_touch, slots, mode)
            if ground_reach(k, gr, q, i, j, n_grid, ground_touch) and sh != 1:
                wt = Ft(1.0)
                if Ft(k) > gr[2] and gr[2] < gr[0]:   # the contact chosen per body only (grid and particle: equal)
                    wt = f
                mu_g = gr[1]
                if sh == 2:   # round 51: the held layer's friction given by touch_share's column bound
                    mu_g = Ft(0.0)
                vel = blend_rule(vel, collide(vel, vec3(Ft(0.0), Ft(0.0), Ft(1.0)), mu_g), wt)
            vel = dashpot(vel, k, gr, q, i, j, n_grid, ground_touch, damp, slots)   # round 48: above the held layers
        for w in range(wall_mu.shape[0]):
            mu_b = wall_mu[w]
            for d in range(3):
                if X[d] < lo[d] + wall_in * dx and (d != 2 or floor != 0):   # floor: gasp_core wall_floor
                    n = vec3(Ft(0.0))
                    n[d] = Ft(1.0)
                    wt = Ft(1.0)
                    if X[d] >= lo[d] + wall_full * dx:
                        wt = f
                    vel = blend_rule(vel, collide(vel, n, mu_b), wt)
                if X[d] > hi[d] - wall_in * dx:
                    n = vec3(Ft(0.0))
                    n[d] = Ft(-1.0)
                    wt = Ft(1.0)
                    if X[d] <= hi[d] - wall_full * dx:
                        wt = f
                    vel = blend_rule(vel, collide(vel, n, mu_b), wt)
        return vel

    return boundary_rules


@functools.cache
def build_node_update(Ft):
    """``node_update(node, ...)``, scalar type ``Ft``: the grid update at one node (the parameters of
    :func:`build_grid_update`'s kernel but its sweep's): node velocity, gravity, extras, boundaries. Long because
    each boundary rule acts in turn on the one node."""
    vec3, vec4, mat33 = build_types(Ft)
    boundary_rules = build_boundary_rules(Ft)
    Extras, extras = build_extras(Ft)
    balance_node, touch_keep = build_balance(Ft)[2], build_share(Ft)[0]
    clear_contact, (pc_friction, keep_fraction) = build_contact_friction(Ft)[1], build_field_friction(Ft)[2:]

    @wp.func
    def node_update(node: int,
        grid_mv: wp.array(dtype=vec4), grid_v: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft),
        gravity: vec3, lo: vec3, hi: vec3, dx: Ft, dt: Ft, n_grid: int, wall_in: Ft,
        wall_mu: wp.array(dtype=Ft), ground: wp.array(dtype=vec3), fixed_lo: wp.array(dtype=vec3),
        fixed_hi: wp.array(dtype=vec3), touch_slots: wp.array(dtype=Ft),
        has_extras: int, ex: Extras, grid_g: wp.array(dtype=vec3), has_wind: int,
        grid_mv0: wp.array(dtype=vec4), grid_v0: wp.array(dtype=vec3), flip: int, grid_fb: wp.array(dtype=Ft),
        grid_fbody: wp.array(dtype=wp.int32), fr_sums: wp.array2d(dtype=wp.float64), fr_nodes: wp.array(dtype=wp.int32),
        colc: int, grid_fn: wp.array(dtype=vec3), grid_fv: wp.array(dtype=vec3), wall_full: Ft,
        grid_mf: wp.array(dtype=Ft), fr_dv: wp.array(dtype=vec4), fr_fb: wp.array(dtype=Ft), floor: int,
        ground_touch: wp.array(dtype=wp.int32), grid_dv: wp.array(dtype=vec3), rule: int, touch_speed: Ft, bound: int):
        # wall_in: the walls' grid rule reaches this many cells in (gasp_core.mpm.contact.wall_grid_cells); ground[g]
        # = (top node layer k_max as a float, friction, unused); grid_m (node mass, for passive points) one a node
        # when the setup has passive points, else one unused entry; ground_touch, touch_speed, touch_slots, bound: touch
        # grid_fb: the contact's friction budget per node (kg m/s; one unused entry without it; with colc grid_fn/fv);
        # per body the contact (contact.rule_models): grid_mf the flowing bodies' mass a node (else one entry), the
        # rule fully within wall_full cells / up to ground[g][2], by the flowing fraction f to wall_in / ground[g][0]
        keep_row(grid_fbody, node)   # the contact's balance: a marked node's key to its row (contact_mark)
        g = grid_mv[node]
        m = g[3]
        if grid_m.shape[0] > 1:
            grid_m[node] = m
        out = vec3(Ft(0.0))
        if m > Ft(0.0):
            f = Ft(0.0)
            if grid_mf.shape[0] > 1:
                f = grid_mf[node] / m
                grid_mf[node] = Ft(0.0)
            vel = vec3(g[0], g[1], g[2]) / m + dt * gravity
            i = node / (n_grid * n_grid)
            j = (node / n_grid) % n_grid
            k = node % n_grid
            X = lo + dx * vec3(Ft(i), Ft(j), Ft(k))
            fb = f   # the flowing-mass fraction of the boundaries and colliders (the contact chosen per body)
            if (rule / 8) % 2 != 0:   # round 81: grid_mf is field A's mass beside a rigid field, for the friction alone
                fb = Ft(0.0)
            if has_extras != 0:
                gsurf = vec3(Ft(0.0))
                if has_wind != 0:
                    gsurf = grid_g[node]
                vel = extras(vel, X, dt, m, gsurf, ex, fb)
            touch_keep(touch_slots, vel, m, i, j, k, ground, n_grid, ground_touch, bound)   # round 49 (touch.py)
            vel = boundary_rules(vel, X, k, lo, hi, dx, wall_in, wall_full, wall_mu, ground, fb, floor, i, j, n_grid,
                                 ground_touch, touch_speed * dt / dx, touch_slots, bound)
            if grid_fb.shape[0] > 1:   # friction (field B's with two fields), then the contact's balance (balance.py)
                v_in = vel
                vel = pc_friction(vel, m, f, node, grid_fb, colc, grid_fn, grid_fv, grid_dv, lo, hi, dx, wall_in,
                                  ground, n_grid, ground_touch, wall_mu.shape[0], rule)
                if fr_sums.shape[0] > 0:
                    balance_node(node, v_in, vel, m, grid_fb[node], X, grid_fbody, fr_sums, fr_nodes, fr_dv, fr_fb)
                    keep_fraction(grid_mf, grid_fbody, grid_dv, node, f, lo, hi, dx, wall_in, ground, n_grid,
                                  ground_touch, wall_mu.shape[0], rule)   # B_BALANCE (schedule/ordered.py)
            for r in range(fixed_lo.shape[0]):
                flo = fixed_lo[r]
                fhi = fixed_hi[r]
                if (X[0] >= flo[0] and X[0] <= fhi[0] and X[1] >= flo[1] and X[1] <= fhi[1]
                        and X[2] >= flo[2] and X[2] <= fhi[2]):
                    vel = vec3(Ft(0.0))
            out = vel
        grid_v[node] = out
        grid_mv[node] = vec4(Ft(0.0))
        if grid_fb.shape[0] > 1:
            clear_contact(node, grid_fb, colc, grid_fn, grid_fv)
        if flip != 0:  # the APIC velocity before forces (gasp_core.mpm.transfer)
            g0 = grid_mv0[node]
            grid_v0[node] = vec3(Ft(0.0))
            if m > Ft(0.0):
                grid_v0[node] = vec3(g0[0], g0[1], g0[2]) / m
            grid_mv0[node] = vec4(Ft(0.0))
        if has_wind != 0:
            grid_g[node] = vec3(Ft(0.0))

    return node_update


@functools.cache
def build_grid_update(Ft):
    """The grid-update kernel ``grid_update`` of scalar type ``Ft``: node velocity, gravity, extras, boundaries at
    each node of ``box``'s sweep (``field_nodes.build_sweep``: ``threads`` threads, ``along`` 1 on the CPU, each thread
    a run of rows in the grid's order; 0 on CUDA, strided); round 64: the box is the touched hull of ``grid_box.py``
    (``GRID_BOX``), or the whole grid where that module's proof does not hold."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras(Ft)[0]
    node_update = build_node_update(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def grid_update(
        grid_mv: wp.array(dtype=vec4), grid_v: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft),
        gravity: vec3, lo: vec3, hi: vec3, dx: Ft, dt: Ft, n_grid: int, wall_in: Ft,
        wall_mu: wp.array(dtype=Ft), ground: wp.array(dtype=vec3), fixed_lo: wp.array(dtype=vec3),
        fixed_hi: wp.array(dtype=vec3), touch_slots: wp.array(dtype=Ft),
        has_extras: int, ex: Extras, grid_g: wp.array(dtype=vec3), has_wind: int,
        grid_mv0: wp.array(dtype=vec4), grid_v0: wp.array(dtype=vec3), flip: int, grid_fb: wp.array(dtype=Ft),
        grid_fbody: wp.array(dtype=wp.int32), fr_sums: wp.array2d(dtype=wp.float64), fr_nodes: wp.array(dtype=wp.int32),
        colc: int, grid_fn: wp.array(dtype=vec3), grid_fv: wp.array(dtype=vec3), wall_full: Ft,
        grid_mf: wp.array(dtype=Ft), fr_dv: wp.array(dtype=vec4), fr_fb: wp.array(dtype=Ft), floor: int,
        ground_touch: wp.array(dtype=wp.int32), grid_dv: wp.array(dtype=vec3), rule: int, touch_speed: Ft, bound: int,
        box: wp.array(dtype=wp.int32), threads: int, along: int):
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    node_update(node, grid_mv, grid_v, grid_m, gravity, lo, hi, dx, dt, n_grid, wall_in,
                                wall_mu, ground, fixed_lo, fixed_hi, touch_slots, has_extras, ex, grid_g, has_wind,
                                grid_mv0, grid_v0, flip, grid_fb, grid_fbody, fr_sums, fr_nodes, colc, grid_fn,
                                grid_fv, wall_full, grid_mf, fr_dv, fr_fb, floor, ground_touch, grid_dv, rule,
                                touch_speed, bound)

    return grid_update
