"""The two-field grid contact between flowing bodies and the others (issue 53 item 3, ``docs/contact.md``, "Sand that
slides on what it touches"): the shared maths and parameters; each grid engine's ``fields.py`` spells the same steps.

In a single-velocity-field MPM grid, two bodies that share a node move with one velocity: the no-slip of a sand pile
glued to a ball. Here, in a ``"mixed"`` scene (:func:`gasp_core.mpm.contact.contact_model`: a flowing body beside
one that does not flow), the flowing bodies (field A) also scatter their momentum and mass to a grid of their own; the
other bodies' field (B) is the whole grid's less A's. Where both fields have mass at a node, the contact normal comes
from the mass gradients and the two velocities are corrected by Coulomb's law (Bardenhagen, Brackbill and Sulsky
2000, "The material-point method for granular materials", CMAME 187, 529-541; Homel and Herbold 2017, "Field-gradient
partitioning for fracture and frictional contact in the material point method", IJNME 109, 1013-1044): they do not
approach along the normal and slide with friction ``mu``. G2P then reads each point's own field. The whole grid's
velocity (mass-weighted mean of the two) is updated as before, with gravity and the boundaries; each field's
velocity is that mean plus its own offset, so a scene whose fields never share a node runs as before. Two soft bodies
(:func:`soft_pair`: a scene of two bodies on the particle contact, neither rigid nor flowing) take the same contact,
the smaller as field A against the larger, with friction :data:`SOLID_FRICTION` and the touch by geometry
(:data:`GAP_TOUCH`, round 60; :data:`SOFT_TOUCH_FRACTION` before), so they meet at their surfaces (issue 53 item 5,
``docs/contact.md`` "Two jelly balls stacked").

Per node, with ``m = m_A + m_B`` and the velocities ``v_A = p_A / m_A``, ``v_B = p_B / m_B`` after P2G:

    u = v_A - v_B,   n = grad m_B / |.|   (into B: field B's surface normal)
    approaching (u . n > 0):  q = (u . n) n + u_t            if |u_t| <= mu (u . n)   (stick)
                              q = (u . n) n + mu (u . n) t   otherwise, t = u_t / |u_t|   (slide)
    else q = 0;  u' = u - q,  dv_A = (m_B / m) u',  dv_B = -(m_A / m) u'

``v_A' = v_cm + dv_A``, ``v_B' = v_cm + dv_B`` conserve the node's momentum (``m_A dv_A + m_B dv_B = 0``). The mass
gradient is a central difference of field B's node masses. **The normal is B's alone** (the solid under a flowing
body, the larger of two soft bodies), the choice of a specified normal among the multi-material options (Nairn's
NairnMPM documents "each material's gradient", "maximum gradient", "average gradient", "maximum volume" and a
specified normal, and finds that no one option works for every problem): with the average of the two
(``grad m_B - grad m_A``, before round 22) a block's edges tilt the normal, its front ploughs (approach made of the
slide) and its back lets go; a jelly block thrown along a jelly slab then stopped as with a coefficient 0.88-0.91
for 0.5 (n_grid 32), 0.68-0.76 at n_grid 64; with the slab's normal 0.58-0.60 and **0.502-0.504** at 64, at every
speed (``docs/contact.md``, "Friction between bodies"). At and below a ground's top node layer B's mass is seen with its
mirror image (:func:`ground_mirror`): the ground is B's support, so the middle layer of a thin support on it still
finds its face above (round 41). A node in a ground's node layers or the walls' (the grid rule's reach) takes no offset:
both fields move with the mean there, except a ground's top layer in a column no flowing point touches (TOP_FREE).
Colliders are not looked at.
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.options import Option
from gasp_core.mpm.contact import contact_model, explicit_grid, flowing_bodies
from gasp_core.mpm.fields_reference import (FLOW_TOUCH_DELTA, MIN_FRACTION, combine_friction,  # noqa: F401
                                           field_offsets, flow_touch_level, ground_mirror, mass_normals)
from gasp_core.mpm.gap_touch import gap_levels
from gasp_core.mpm.colouring import coloured, colour_scene

#: Engine option ``contact_fields`` of the MPM engines.
FIELDS = Option("contact_fields", True, "in a scene with flowing (sand, snow, liquid) and other bodies, the flowing "
                "bodies take a grid velocity field of their own, in Coulomb contact with the others' (docs/contact.md, "
                "issue 53): sand slides on a ball instead of sticking to it; so do two soft bodies, a field each: "
                "they meet at their surfaces; false: one field, no-slip where they share nodes", kind="bool")
#: The two fields touch at a node when their volumes there (``sum_p w_ip V_p`` per field) fill this fraction of a
#: cell (``dx^3``): where the bodies merely share a node's stencil across a gap, each keeps its own velocity.
TOUCH_FRACTION = 0.9
#: The touch threshold of two soft bodies (:func:`soft_pair`): lower than a flowing body's, as two convex surfaces
#: meet over few nodes whose cells they fill only in part (the stacked balls, ``docs/contact.md``: at 0.9 the top
#: ball rests 0.40 dx inside the bottom one; at 0.7 the lattices' surfaces 0.04-0.21 dx inside each other and the
#: surface Gaussians 0.06-0.18 dx apart; 0.55 put the lattices within 0.03 dx of touching but left the Gaussians of
#: the lightest balls 0.41 dx apart).
SOFT_TOUCH_FRACTION = 0.7
#: A soft body's Coulomb coefficient against another body (:func:`body_friction`): rubber-like jelly on itself.
SOLID_FRICTION = 0.5
#: The flowing body's touch (round 37, ``docs/contact.md`` "Round 37"): in a ``"mixed"`` scene a node is a contact
#: node where a point of field A within ``FLOW_TOUCH_DELTA`` cells of field B's surface has it in its stencil (the
#: grounds' ``touch_delta`` before round 47), and a contact node on A's side of the surface (``m_A > m_B``) gives A the
#: pair's whole Coulomb correction, its reaction going to B at the node behind it. False: :data:`TOUCH_FRACTION` and the
#: node's share alone (the rule before; the catch of ``tests/test_contact_fields.py``).
FLOW_TOUCH = True   # FLOW_TOUCH_DELTA 0.25: fields_reference.py, with flow_touch_level
#: Its level per body, the points' reach added (round 75): :mod:`gasp_core.mpm.flow_reach`.
#: The ground's mirror in the normal (round 41, ``docs/contact.md`` "Round 41: the thin support's rub"): B's mass at
#: a node at or below a ground's top node layer is seen with its mirror image in that layer (:func:`ground_mirror`),
#: the ground beneath B being B's support, not a surface of B. False: the nodes' own mass (the rule before, the catch
#: of ``tests/test_thin_support.py``): at the middle node layer of a support 2 cells thick, B's mass is the same one
#: node above and below, its gradient about 1/250 of a face's, and the normal taken from it tilts along the slide.
GROUND_MIRROR = True
#: The particle contact's friction on field B alone (round 41): in a ``"mixed"`` scene the bodies that do not flow
#: (B) take the particle contact, whose friction with the ground the grid update applies to a node's mean velocity;
#: at a node B shares with A, A's offset is taken back by that change and B's raised, so A keeps its velocity and B
#: takes the friction's whole momentum. False: both fields take it (the rule before; a sand block on a support 2
#: cells thick shares the support's lowest free node layer and was braked by the support's ground friction there).
B_FRICTION = True
#: Field A's affine momentum at B (round 41, ``docs/contact.md`` "Round 41: the sand's affine momentum at the face"):
#: in a ``"mixed"`` scene with the flowing body's touch (:func:`flow_touch`), a point of A that touched B at the last
#: substep (the touch's test: B's gathered volume fraction at the point reaches :func:`flow_touch_level`, the point
#: within :data:`FLOW_TOUCH_DELTA` cells of B's surface) scatters without its APIC affine momentum
#: ``m C (x_i - x_p)`` (its stress kept): A's velocity at the nodes in and around B's face is then its points' own,
#: not their shearing base's extrapolation into B. False: every point keeps
#: it (the rule before: Coulomb's ratio -6.9 % for sand thrown at 0.7 m/s on a face 3/4 of a cell above a node
#: layer; the catch of ``tests/test_sand_on_rigid.py``). Away from B (a free sand column, no B) nothing changes.
PIC_AT_B = True
#: The ground's top node layer free for the two fields (issue 67, ``docs/contact.md`` "Round 42: a support 1 cell
#: thick"): in a ``"mixed"`` scene with the grounds' touched columns, a node on a ground's top layer in a column no
#: flowing point touches (round 47's touch: no point's lowest extent near the plane) takes the two-field
#: contact like any node above (the ground's grid rule still acts on its mean velocity). False: both fields move with
#: the mean at every ground layer (the rule before: on a support 1 cell thick the sand's lowest stencil layer is the
#: ground's top layer, where it was snapped to the support's velocity; Coulomb's ratio +46 / +76 %).
TOP_FREE = True
#: The particle contact's friction on field B's own velocity (round 42): at a node where the fields keep their
#: offsets, with :data:`B_FRICTION`, the friction is taken on B's velocity ``v_B`` and mass ``m_B`` (its budget is B's
#: points'), not on the mean's, whose tangential part carries A's share ``f v_A``. False: on the mean, its whole
#: change then given to B (round 41's rule: the budget spent against the sand's share pushes B back; with
#: :data:`TOP_FREE` the sand on a support 1 cell thick then read -3.1 / -3.7 %).
B_OWN_FRICTION = True
#: The contact's balance on field B alone (round 43, ``docs/contact.md`` "Round 43: the stiff 1-cell slab's -1 %"):
#: the balance's change of a marked node's mean velocity (``contact_balance``: B's bodies' particle contact, their
#: net friction and torque made a smooth contact's) is given to field B alone where the fields keep their offsets,
#: as :data:`B_FRICTION` gives it the friction. False: both fields take it (the rule before: a sand block on a
#: support 1 cell thick took the slab's ground friction and torque fix at the layers it shares with the slab and read
#: -1.0 / -1.3 % on a stiff slab, +2.4 % to -1.5 % as the ground's friction under the slab went 0.2 to 1.0).
B_BALANCE = True
#: Round 59 (docs/contact.md "Round 59: AFLIP's old velocity per field"): with AFLIP (``alpha > 0``: option ``flip``,
#: or ``transfer_damping = "rate"`` past the reference step, ``alpha = 1 - n_ref / n_substeps``) each field's points
#: take AFLIP's old velocity ``v_PIC(old)`` of their own field, as they take the new one. False: the whole grid's (the
#: rule before, the catch of ``tests/test_contact_fine_step.py``): a point's ``v_new - v_old`` carried its field's
#: offset, ``alpha`` times, each substep; two jelly bodies 5 mm apart diverged at 400 substeps a frame (n_grid 32).
FIELD_OLD_VELOCITY = True
#: Round 60 (docs/contact.md "Round 60", :mod:`gasp_core.mpm.gap_touch`): two bodies (:func:`body_pair`) touch where a
#: point's surface reaches the other's, not by :data:`SOFT_TOUCH_FRACTION` (False: the rule before, the catch).
GAP_TOUCH = True
#: Round 81: :data:`B_FRICTION` also where field A is rigid, not ``"mixed"`` (:mod:`gasp_core.mpm.rigid_a`; False: off).
RIGID_A_FRICTION = True
#: Round 82: the mirror of :data:`RIGID_A_FRICTION`, a rigid field B (a rigid body larger than the soft one it lies on)
#: whose soft field A takes the friction alone (:func:`gasp_core.mpm.rigid_a.rigid_friction_side` 2; False: off).
RIGID_B_FRICTION = True
#: A body of field B that names no ``friction``, in :func:`node_friction`'s ``mu_b`` where :func:`b_unnamed_mix`
#: (round 44): its points scatter ``w_ip m_p`` to B's unnamed channel, not ``w_ip m_p mu`` to B's named one.
UNNAMED = -2.0


def field_rule() -> int:
    """The engines' flags of rounds 42 and 43 as one int: bit 1 :data:`TOP_FREE`, bit 2 :data:`B_OWN_FRICTION`, bit 3
    :data:`B_BALANCE` (read when an engine is built)."""
    return int(bool(TOP_FREE)) + 2 * int(bool(B_OWN_FRICTION)) + 4 * int(bool(B_BALANCE))


#: A node's mass gradient shorter than this (kg/m, relative to ``m / dx``) gives no normal: the fields move as one.
MIN_GRADIENT = 1e-6


def field_bodies(setup) -> np.ndarray | None:
    """Which bodies make field A (shape (n_materials,), bool), or None where the scene runs one field. With the
    option ``contact_fields`` true (the default): in a ``"mixed"`` scene the flowing bodies (A) against the others
    (B); two soft bodies (:func:`soft_pair`), two rigid ones (:func:`rigid_pair`) or a rigid one and a soft one
    (:func:`mixed_pair`) the smaller by volume (A; body 1 when equal) against the larger (B), whose surface gives the
    contact normal (a block on a slab: the slab's face); three or more soft bodies (round 61,
    :func:`gasp_core.mpm.colouring.coloured`) by a 2-colouring of the bodies within reach of each other
    (``colouring.colour_scene``). Any other scene runs one field (three or more bodies with a rigid one)."""
    c = contact_model(setup)
    if not setup.options.get("contact_fields", True) or (c == "mixed" and explicit_grid(setup)):
        return None   # contact = "grid" by hand: one field, as before its rigid bodies took the particle contact
    if c == "mixed":
        return flowing_bodies(setup, c)
    if c == "particle" and body_pair(setup):
        if len(setup.materials) > 2:   # round 61: three or more soft bodies, by colouring (colouring.py)
            return colour_scene(setup)[0]
        # A the smaller body (by volume; body 1 when equal): B's is the normal
        vol = np.bincount(np.asarray(setup.body_id), weights=np.asarray(setup.p_vol, float), minlength=2)
        return np.array([False, True]) if vol[1] <= vol[0] else np.array([True, False])
    return None


def body_pair(setup) -> bool:
    """Whether a scene is two bodies on the particle contact, soft or rigid in any mix (:func:`soft_pair`,
    :func:`rigid_pair`, :func:`mixed_pair`): they take a field each; or (round 61, :func:`colouring.coloured`) three
    or more soft ones, whose fields a colouring gives."""
    return (len(setup.materials) == 2 and contact_model(setup) == "particle") or coloured(setup)


def soft_pair(setup) -> bool:
    """Whether a scene is two soft bodies on the particle contact (two materials, neither flowing nor rigid): they
    take a field each, the smaller (A) against the larger (B), so they meet at their surfaces (issue 53 item 5,
    ``docs/contact.md`` "Two jelly balls stacked"). Three or more soft bodies: :func:`body_pair` (round 61)."""
    from gasp_core.mpm.rigid import rigid_mask
    return (len(setup.materials) == 2 and contact_model(setup) == "particle"
            and not np.asarray(rigid_mask(setup.materials)).any())


def rigid_pair(setup) -> bool:
    """Whether a scene is two rigid bodies on the particle contact (two materials, both ``model = "rigid"``): they take
    a field each (the smaller A), whose nodes only find where they touch; their contact is then taken on the two
    bodies as one, by force balance (``gasp_core.mpm.rigid_friction.pair_contact``, issue 67 item 4). One rigid
    body beside a soft one: :func:`mixed_pair`; three or more bodies keep one field."""
    from gasp_core.mpm.rigid import rigid_mask
    return (len(setup.materials) == 2 and contact_model(setup) == "particle"
            and bool(np.asarray(rigid_mask(setup.materials)).all()))


def pair_mode(setup) -> int:
    """0: no rigid pair law; 1: two rigid bodies (:func:`rigid_pair`, issue 67 item 4); 2 (round 62,
    ``gasp_core.mpm.rigid_pairs``): three or more bodies coloured of which two or more are rigid, their pairs solved
    together."""
    from gasp_core.mpm.rigid import rigid_mask
    if rigid_pair(setup):
        return 1
    return 2 if coloured(setup) and int(np.asarray(rigid_mask(setup.materials)).sum()) >= 2 else 0


def mixed_pair(setup) -> bool:
    """Whether a scene is a rigid body and a soft one on the particle contact (two materials, one ``model = "rigid"``):
    they take a field each, the rigid body a moving collider of the soft field (round 63, ``rigid_collider``; without
    it the nodes' Coulomb correction of the module notes; issue 67 item 4: a rigid block thrown along a jelly slab slides
    0.4 % past ``V0^2 / (2 mu g (1 + m1 / m2))``, a jelly block on a rigid slab 0.4 % short, both engines; with one
    field they stuck, -99 %, ``tests/test_block_on_block.py``)."""
    from gasp_core.mpm.rigid import rigid_mask
    rigid = np.asarray(rigid_mask(setup.materials))
    return len(setup.materials) == 2 and contact_model(setup) == "particle" and int(rigid.sum()) == 1


def uses_fields(setup) -> bool:
    """Whether a setup runs the two-field contact (:func:`field_bodies` is not None)."""
    return field_bodies(setup) is not None


def field_friction(setup) -> float:
    """The Coulomb coefficient between the two fields, dimensionless, where one number serves the whole grid. Flowing
    bodies: ``tan(phi)`` of their largest friction angle (sand: its ``friction_angle``, degrees; the angle of the
    sand's internal friction taken as its friction on the other body's surface), combined (:func:`combine_friction`)
    with the other bodies' ``friction`` (:func:`b_frictions`; a body that names none takes the sand's own, so the pair
    is ``tan(phi)``); 0 where no flowing body has a friction angle (liquid, snow: they slide freely). Where field B's
    bodies take different coefficients the engines build the pair's friction per node (:func:`node_friction`, round
    42; :func:`pair_frictions` per body) and this is round 41's scalar, the smallest named; where A brings several
    (:func:`a_node_friction`: sands of several angles, round 43; sand beside liquid or snow, round 44) A's side is per
    node too and this scalar takes the largest angle's. Two soft bodies (:func:`soft_pair`), two rigid ones
    (:func:`rigid_pair`) or one of each (:func:`mixed_pair`): the pair's (:func:`combine_friction` of theirs)."""
    if contact_model(setup) != "mixed":
        mus = [body_friction(m) for m in setup.materials[:2]] or [SOLID_FRICTION]
        pairs = colour_scene(setup)[2] if coloured(setup) else []   # round 61: the smallest of the graph's pairs
        if pairs:
            return min(combine_friction(body_friction(setup.materials[i]), body_friction(setup.materials[j]))
                       for i, j in pairs)
        return combine_friction(mus[0], mus[-1])
    flows = flowing_bodies(setup, "mixed")
    angles = [m.friction_angle for m, f in zip(setup.materials, flows) if f and m.name == "sand"]
    if not angles:
        return 0.0
    own = math.tan(math.radians(max(angles)))
    named = [m.friction for m, f in zip(setup.materials, flows) if not f and m.friction is not None]
    return combine_friction(own, min(named)) if named else own


def sand_friction(setup) -> float:
    """Field A's one coefficient in a ``"mixed"`` scene: ``tan(phi)`` of its sand bodies' largest ``friction_angle``
    (degrees), 0 without sand (liquid, snow). Dimensionless. Where A brings several coefficients (sands of several
    angles, round 43; sand beside liquid or snow, round 44) the engines take each body's per node
    (:func:`a_node_friction`)."""
    flows = flowing_bodies(setup, "mixed")
    angles = [m.friction_angle for m, f in zip(setup.materials, flows) if f and m.name == "sand"]
    return math.tan(math.radians(max(angles))) if angles else 0.0


def b_frictions(setup) -> np.ndarray:
    """Per body (shape (n_materials,), float64, dimensionless) the coefficient a body of field B brings to its pair
    with the sand in a ``"mixed"`` scene: its ``friction`` where it names one, else the sand's own
    (:func:`sand_friction`: the pair is ``tan(phi)``, round 41's rule; per node A's own where :func:`b_unnamed_mix`);
    0 for field A."""
    own = sand_friction(setup)
    flows = flowing_bodies(setup, "mixed")
    return np.array([0.0 if f else (own if m.friction is None else float(m.friction))
                     for m, f in zip(setup.materials, flows)], np.float64)


def node_friction(setup):
    """The per-node friction of a ``"mixed"`` scene's two-field contact (round 42, ``docs/contact.md`` "Round 42:
    several bodies' frictions in field B"), or None where one scalar (:func:`field_friction`) is exact: not a mixed
    scene with two fields, no sand (the pair 0), or field B's bodies all bring one coefficient (every scene of one
    body in B: the engines then run the scalar path, bit-identical to round 41). Else ``(own, mu_b, lo, hi)``:
    ``own`` the sand's ``tan(phi)`` (:func:`sand_friction`), ``mu_b`` per body (:func:`b_frictions`, shape
    (n_materials,)), ``lo``/``hi`` the smallest and largest of B's. The engines scatter ``w_ip m_p mu_b[body_p]``
    of B's points to one more node channel in P2G; at a contact node ``mu_B = clamp(that / m_B, lo, hi)`` (the
    mass-weighted mean, clamped against the round-off of ``m_B = m - m_A``) and the Coulomb limit takes
    :func:`combine_friction` ``(own, mu_B)``. Where :func:`b_unnamed_mix` (round 44: A per node, B's bodies some
    named and some not), ``mu_b`` is :data:`UNNAMED` for B's unnamed bodies, whose points scatter ``w_ip m_p`` to a
    channel of their own (``S_u``); then ``mu_B = clamp((S_mu + tan_A S_u) / m_B, lo, hi)``, ``tan_A`` A's per-node
    coefficient (:func:`a_node_friction`): an unnamed body brings the touching sand's own, and ``lo``/``hi`` span
    B's named values and A's range."""
    if contact_model(setup) != "mixed" or not uses_fields(setup):
        return None
    own = sand_friction(setup)
    flows = flowing_bodies(setup, "mixed")
    mu_b = b_frictions(setup)
    if b_unnamed_mix(setup):   # round 44: B's unnamed bodies at A's per-node coefficient, a channel of their own
        a_lo, a_hi = a_node_friction(setup)[1:3]
        named = [float(m.friction) for m, f in zip(setup.materials, flows) if not f and m.friction is not None]
        mu_b = np.array([UNNAMED if not f and m.friction is None else mu
                         for m, f, mu in zip(setup.materials, flows, mu_b)], np.float64)
        return own, mu_b, min(named + [a_lo]), max(named + [a_hi])
    vals = sorted({float(mu_b[b]) for b in range(len(mu_b)) if not flows[b]})
    if own <= 0.0 or len(vals) < 2:
        return None
    return own, mu_b, vals[0], vals[-1]


def b_unnamed_mix(setup) -> bool:
    """Whether field B's bodies that name no ``friction`` take A's per-node coefficient in a channel of their own
    (round 44, ``docs/contact.md`` "Round 44"): :func:`a_node_friction` is on (A brings several coefficients) and
    B holds both bodies that name a ``friction`` and bodies that name none. Elsewhere an unnamed body brings
    :func:`sand_friction` to B's mean (round 42), or B's bodies all name none and the pair is A's own (round 43)."""
    if a_node_friction(setup) is None:
        return False
    flows = flowing_bodies(setup, "mixed")
    named = [m.friction is not None for m, f in zip(setup.materials, flows) if not f]
    return any(named) and not all(named)


def a_frictions(setup) -> np.ndarray:
    """Per body (shape (n_materials,), float64, dimensionless) the coefficient a body of field A brings to its pair in
    a ``"mixed"`` scene (round 43): a sand body's own ``tan(friction_angle)``; a flowing body without an angle
    (liquid, snow) 0, so its pair is 0 and it slides freely beside sand as it does alone (round 44; before, the
    sand's :func:`sand_friction`, the largest angle's); 0 for field B."""
    flows = flowing_bodies(setup, "mixed")
    return np.array([math.tan(math.radians(m.friction_angle)) if f and m.name == "sand" else 0.0
                     for m, f in zip(setup.materials, flows)], np.float64)


def a_node_friction(setup):
    """Field A's per-node friction (round 43, ``docs/contact.md`` "Round 43: several sands' angles in field A"), or
    None where field A brings one coefficient (one sand angle, or only liquid or snow: :func:`node_friction` or the
    scalar, bit-identical to round 42). Else ``(mu_a, lo, hi, mu_b)``: ``mu_a`` per body (:func:`a_frictions`, shape
    (n_materials,)), ``lo``/``hi`` A's smallest and largest (``lo`` 0 where a liquid or snow body is in A, round
    44), ``mu_b`` B's one coefficient where :func:`node_friction` is None (the one its bodies name; -1.0 where none
    names one: the pair is then A's own per node, round 41's rule). A's points scatter ``w_ip m_p mu_a[body_p]`` to
    a node channel; at a contact node ``tan_A = clamp(that / m_A, lo, hi)`` and the Coulomb limit is
    :func:`combine_friction` ``(tan_A, mu_B)`` (0 at a node of liquid alone: ``sqrt(0 mu_B)``), ``mu_B`` per node
    where :func:`node_friction` is on (B's unnamed bodies then bring ``tan_A`` itself, :func:`b_unnamed_mix`), else
    ``mu_b`` (``tan_A`` for -1)."""
    if contact_model(setup) != "mixed" or not uses_fields(setup):
        return None
    flows = flowing_bodies(setup, "mixed")
    mu_a = a_frictions(setup)
    vals = sorted({float(mu_a[b]) for b in range(len(mu_a)) if flows[b]})
    if len(vals) < 2:
        return None
    named = {float(m.friction) for m, f in zip(setup.materials, flows) if not f and m.friction is not None}
    return mu_a, vals[0], vals[-1], (min(named) if named else -1.0)


def hold_pairs(setup):
    """Per (A body, holding body) the pair's coefficient, shape (n_materials, n_materials), float64, ``[a, b]``:
    :func:`combine_friction` of :func:`a_frictions` ``[a]`` and body b's ``friction`` (A's own where b names none),
    what a rigid body's hold on a flowing body takes (``gasp_core.mpm.rigid_hold``; a liquid's row 0, round 44)
    where :func:`a_node_friction` is on; None elsewhere (the hold takes :func:`pair_frictions` per body, round 42)."""
    from gasp_core.mpm.rigid import step_view
    setup = step_view(setup)
    if a_node_friction(setup) is None:
        return None
    mu_a = a_frictions(setup)
    return np.array([[a if m.friction is None else combine_friction(a, m.friction) for m in setup.materials]
                     for a in mu_a], np.float64)


def pair_frictions(setup) -> np.ndarray:
    """Per body (shape (n_materials,), dimensionless) the pair's coefficient of a body of field B with the sand
    (:func:`combine_friction` of :func:`sand_friction` and :func:`b_frictions`) in a ``"mixed"`` scene: what a rigid
    body's hold on the sand takes (``gasp_core.mpm.rigid_hold``); elsewhere :func:`field_friction` for every body."""
    n = len(setup.materials)
    if node_friction(setup) is None:
        return np.full(n, field_friction(setup))
    own = sand_friction(setup)
    return np.array([own if m.friction is None else combine_friction(own, mu)
                     for m, mu in zip(setup.materials, b_frictions(setup))])


def body_friction(material) -> float:
    """A body's Coulomb coefficient against another body: its material's ``friction`` where it has one (the scene key
    ``friction``, :data:`gasp_core.seam.schema.FRICTION_KINDS`), else :data:`SOLID_FRICTION`."""
    mu = getattr(material, "friction", None)
    return SOLID_FRICTION if mu is None else float(mu)


def touch_fraction(setup) -> float:
    """The touch threshold of the two fields (fraction of a cell's volume their volumes fill at a node):
    :data:`SOFT_TOUCH_FRACTION` for two bodies on the particle contact (:func:`body_pair`), else
    :data:`TOUCH_FRACTION`."""
    return SOFT_TOUCH_FRACTION if body_pair(setup) else TOUCH_FRACTION


def flow_touch(setup) -> bool:
    """Whether a setup's two-field contact takes the flowing body's touch (:data:`FLOW_TOUCH`): a ``"mixed"`` scene
    (field A its flowing bodies) that runs two fields."""
    return bool(FLOW_TOUCH) and contact_model(setup) == "mixed" and uses_fields(setup)


def pic_at_b(setup) -> bool:
    """Whether field A's points drop their affine momentum where they meet B (:data:`PIC_AT_B`, with
    :func:`flow_touch`)."""
    return bool(PIC_AT_B) and flow_touch(setup)


def field_setup(setup) -> tuple:
    """``(field_bodies, field_friction, touch_fraction, pair_mode, flow_touch, node_friction, a_node_friction,
    gap_levels)`` of a setup: what an engine allocates the contact from (round 60: ``gap_touch.gap_levels``; round 62:
    :func:`pair_mode`)."""
    return (field_bodies(setup), field_friction(setup), touch_fraction(setup), pair_mode(setup), flow_touch(setup),
            node_friction(setup), a_node_friction(setup), gap_levels(setup, bool(GAP_TOUCH) and body_pair(setup)))
