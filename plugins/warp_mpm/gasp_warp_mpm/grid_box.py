"""Round 64 (``docs/performance.md`` "Round 64: the grid update over the touched box"): warp_mpm's grid update
(``grid.build_grid_update``) sweeps the hull of the nodes P2G touched this substep and the last (the box of
``field_nodes.py``: 12 int32, this substep's lowest and highest node per axis, then the last substep's) instead of the
whole grid, in every scene where that gives the whole grid's values at every node (:func:`whole_grid_reasons` names
the others, which keep the whole grid). No host reads the box: the launch is ``field_nodes.shared_threads`` threads,
each a run of the box's rows in the grid's order on the CPU (the whole grid's order of the nodes with mass: the
contact balance's sums in the same order, the same bits), strided on CUDA.

Why the hull is enough. At a node the grid update writes ``grid_v`` (its velocity; 0 where the node has no mass),
``grid_m`` (its mass, for passive points and held boxes) and clears ``grid_mv``, ``grid_mv0``, the contact's
``grid_fb`` / ``grid_fn`` / ``grid_fv`` and wind's ``grid_g``; it keeps a marked ``grid_fbody`` key's row (idempotent)
and touches ``grid_mf``, ``touch_slots``, ``grid_dv`` and the balance's sums only where the node has mass. P2G writes
those inputs only at its points' 27 nodes (this substep's box; wind's ``grid_g`` too, ``transfers.py``). Claim: after
each substep every one of these arrays is 0 outside that substep's box. It holds at the start (all zero). Given it for
the last substep, a node outside the hull holds zeros and P2G wrote nothing there, so the grid update would write
zeros over zeros (skipping it changes nothing); a node in the hull is swept as before; a node in the hull but not in
this substep's box has no mass, so it ends with zeros. The passes after the grid update write ``grid_v`` only at nodes
with mass (the balance's fix at listed nodes, round 49's touch share at nodes with a slot's mass, or scaling a
velocity, which keeps a 0; the rigid collider writes ``grid_dv``, cleared by the field passes over the same hull), so
the claim holds after the substep. Passive points and G2P reading nodes beyond the box read the zeros they read before.

Round 65 (``docs/performance.md`` "Round 65: the held boxes and viscous bodies over the touched box"). Viscous
materials: the implicit step (``viscosity.py``, between P2G and the grid update) reads ``grid_mv`` and ``grid_eta``
and writes them only at its solved nodes, the nodes with mass (its lists: ``grid_mv[I][3] > 0``), all in this
substep's box; its own arrays are read by no other pass. So the claim above holds as it is (:data:`VISC_BOX`). With
it the step's own sweeps take its own box (``viscosity.ImplicitViscosity.box``: launched at the step's start, after
P2G, before this module's): ``label_clear`` and the cpu schedule's ``lists`` over its hull (the nodes with mass, the
valid cells' corners, the labelled nodes and last step's ``valid`` 1 all lie in it; the lists in node order).

Held boxes (:data:`HELD_BOX`): the held passes after the grid update (``held.py``'s ``clear_cut`` over both halves of
``grid_cut``, ``held_rule.py``'s ``hold_set_faces``, ``held.py``'s ``mirror_held``) sweep the same box ``B`` as the
grid update: the hull, this substep's half stretched to a domain edge it comes within :data:`HELD_REACH` nodes of
(:func:`build_held_box`). Only ``grid_v`` changes the claim: a set box writes its velocity at each of its nodes, with
mass or not, and a fixed region its ghosts, so a held box's node outside ``B`` may hold a value the whole grid would
have written differently. Claim H, after each substep: (a) at every node of ``B``, ``grid_v``, ``grid_m`` and
``grid_cut`` are the whole grid's; (b) outside ``B``, ``grid_m``, ``grid_cut`` and round 64's arrays are 0, and so is
``grid_v`` at every node in no held box; (c) no kernel reads ``grid_v`` at a held box's node outside ``B``.

(b): ``grid_m`` is written by the grid update only; ``grid_cut`` is marked only at material points' 27 nodes (this
substep's box) and cleared over ``B``, which holds the last substep's marks; a node in no held box takes ``grid_v``
from the grid update (``+0`` where it has no mass) and the passes at nodes with mass only. (a): the grid update does
not read ``grid_v``; ``hold_set_faces`` works at nodes with mass and reads a neighbour's ``grid_v`` only where it has
mass. The mirror at a node ``g`` of ``B`` reads, for a set box, ``g``'s own ``grid_v`` (swept) and its two image
nodes' only where both have mass (in the box); for a fixed region, the two image nodes and, broken through, the first
node past the face and ``grid_cut``, all on ``g``'s line along the face's normal within :data:`HELD_REACH` nodes, past
the face: in no held box where no fixed region comes within :data:`HELD_REACH` cells of another held box
(:func:`held_apart`, else the whole grid), so (b) or (a) gives the whole grid's value. An image beyond the grid's
edge is read at the edge's two nodes, which lie in the region where it reaches the wall: the stretch puts them in
``B``, swept by the grid update and mirrored in the whole grid's order on the CPU (each thread a contiguous run, the
threads in turn), so a ghost reading one mirrored before it reads the whole grid's value (on CUDA the whole grid's
order was a race already). (c): G2P reads its points' 27 nodes (P2G's, the points not moved since: this substep's
box), ``image_C`` uses its image's stencil only where all 27 nodes have mass, the passive points only nodes with
mass, the rigid collider its points' nodes, the next grid update writes without reading; with round 62's push (points
moved between P2G and G2P) the whole grid. One case is left to the tests: rounding may put a fixed ghost's lower
image node on the face itself (``2 s / dx`` an integer less an ulp), read with a weight below 1e-6; a massless face
node outside ``B`` holds ``+0`` there as in the whole grid where its own reads are 0 (a ghost far from mass).
Measured: ``tests/test_held_box.py``, bit for bit on the tension bar and dog-bone, held elastic blocks, a set box that
starts and stops, a block held at the wall, viscous bodies; taking out the stretch or :func:`held_apart` changed no
bit there (their cases read zeros in the family), a box one node short does.

This module must not use ``from __future__ import annotations`` (the house rule of this plugin's kernel modules).
"""
import functools

import numpy as np
import warp as wp

from gasp_core.mpm import gap_push
from gasp_core.mpm.points import MIRROR_CELLS

from . import field_nodes as FN
from .precision import MODULE_OPTIONS

#: Round 64: the grid update over the touched hull (module notes); False: the whole grid (main's before).
GRID_BOX = True
#: Round 65: with held boxes too, the grid update and the held passes over the box (module notes); False: the whole
#: grid with held boxes (round 64's; the catch of ``tests/test_held_box.py``).
HELD_BOX = True
#: Cells: how far a fixed region's ghost node reads along its face's normal (its mirror image ``2 s`` past it,
#: ``s < MIRROR_CELLS`` cells, and the node after; the broken face's first node past the face).
HELD_REACH = int(np.ceil(2 * MIRROR_CELLS)) + 1
#: Round 65: a viscous material's grid update over the box too (module notes); False: the whole grid (round 64's).
VISC_BOX = True


def whole_grid_reasons(eng) -> list:
    """Why ``eng``'s grid update must sweep the whole grid (module notes): a list of short reasons, empty where the
    touched hull gives the same values."""
    from .held import held_boxes   # here: held imports modules that import this one
    out = []
    if held_boxes(eng.setup) and not HELD_BOX:
        out.append("held boxes: the mirror writes grid_v at nodes without mass (HELD_BOX off)")
    elif held_boxes(eng.setup) and not held_apart(eng.setup, eng.dx):
        out.append("held boxes within HELD_REACH cells of each other: a ghost reads another box's ghosts")
    elif held_boxes(eng.setup) and getattr(eng, "gap_touch_on", False) and gap_push.PUSH:
        out.append("held boxes and round 62's push: G2P reads nodes beyond P2G's box")
    if getattr(eng, "visc", None) is not None and not VISC_BOX:
        out.append("viscous: the implicit step solves over the grid")
    return out


def held_apart(setup, dx: float) -> bool:
    """Whether no ``fixed_region`` of ``setup`` comes within :data:`HELD_REACH` cells (``dx``, m) of another held box
    (a fixed region or a set box impulse, whenever it acts): then a region's ghost node reads no other box's node."""
    regions = [(np.asarray(b.lo, float), np.asarray(b.hi, float)) for b in setup.boundaries
               if b.kind == "fixed_region"]
    sets = [(np.asarray(i.lo, float), np.asarray(i.hi, float)) for i in (getattr(setup, "impulses", None) or [])
            if i.shape == "box" and i.mode == "set"]
    r = HELD_REACH * dx
    for n, (lo, hi) in enumerate(regions):
        for m, (lo2, hi2) in enumerate(regions + sets):
            if m != n and bool(np.all(lo - r <= hi2) and np.all(lo2 <= hi + r)):
                return False
    return True


@functools.cache
def build_held_box(Ft):
    """``held_box(box, n_grid, edge)`` (one thread, after the box's ``field_box``): this substep's box (its first six)
    stretched to the grid's first or last node along an axis where it comes within ``edge`` nodes of it (module
    notes: a ghost node near a domain edge reads the nodes at the edge); an empty box left empty."""

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def held_box(box: wp.array(dtype=wp.int32), n_grid: int, edge: int):
        if box[3] >= box[0]:
            for d in range(3):
                if box[d] <= edge:
                    box[d] = 0
                if box[3 + d] >= n_grid - 1 - edge:
                    box[3 + d] = n_grid - 1

    return held_box


def allocate_grid_box(eng) -> None:
    """``eng.grid_box`` (12 int32, ``field_nodes``'s layout), once (a re-recording keeps it: the box must follow the
    grid's arrays): the field passes' own box where they build one (two fields and ``field_nodes.FIELD_BOX``), else
    one of its own built by :func:`grid_box_launches` (``eng.grid_box_own``), or the whole grid (:data:`GRID_BOX`
    off, or :func:`whole_grid_reasons`)."""
    if getattr(eng, "grid_box", None) is not None:
        return
    from .held import held_boxes
    ng = eng.n_grid
    eng.grid_box_own = False
    whole = not GRID_BOX or bool(whole_grid_reasons(eng))
    eng.grid_box_held = held_boxes(eng.setup) and not whole   # round 65: the box stretched to the edges it nears
    if whole:
        box = [0, 0, 0, ng - 1, ng - 1, ng - 1] * 2
    elif getattr(eng, "fields", False) and FN.FIELD_BOX:
        eng.grid_box = eng.field_box
        return
    else:
        eng.grid_box_own = True
        box = [ng] * 3 + [-1] * 3 + [ng] * 3 + [-1] * 3
    eng.grid_box = wp.array(np.array(box, np.int32), dtype=wp.int32, device=eng.device)


def grid_sweep(eng) -> list:
    """The grid update's last three inputs: its box (:func:`allocate_grid_box`), the threads
    (``field_nodes.shared_threads``, also the launch's size) and ``along`` (1 on the CPU, 0 on CUDA)."""
    allocate_grid_box(eng)
    return [eng.grid_box, FN.shared_threads(eng), int(not eng.device.is_cuda)]


def grid_box_launches(eng, Ft) -> list:
    """The recorded ``box_reset`` and ``field_box`` on ``eng.grid_box`` where it is its own (after P2G, before the
    grid update; none where the field passes build it or it is the whole grid), then with held boxes round 65's
    ``held_box`` (:func:`build_held_box`, ``edge`` :data:`HELD_REACH`) on it."""
    allocate_grid_box(eng)
    out = []
    if eng.grid_box_own:
        box_reset, field_box = FN.build_field_box(Ft)
        lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
        out = [wp.launch(box_reset, dim=1, device=eng.device, record_cmd=True, inputs=[eng.grid_box, eng.n_grid]),
               wp.launch(field_box, dim=eng.n_material, device=eng.device, record_cmd=True, inputs=[
                   eng.x, eng.grid_box, lo, Ft(eng.inv_dx), eng.n_grid])]
    if eng.grid_box_held:
        held_box = build_held_box(Ft)
        out.append(wp.launch(held_box, dim=1, device=eng.device, record_cmd=True, inputs=[
            eng.grid_box, eng.n_grid, HELD_REACH]))
    return out
