"""Round 81 (``docs/rigid.md`` "Round 81: the coarse roll's leak fixed"): rounds 41-43's :data:`B_FRICTION
<gasp_core.mpm.fields.B_FRICTION>` where field A is rigid. A rigid body's own ground contact is the rigid law's, so the
particle contact's ground friction, which the grid update applies to a node's mean velocity, is given to field B
alone at the nodes the fields share (A's offset less ``dv``, B's plus ``dv f / (1 - f)``, ``f`` A's mass fraction
there, scattered in P2G to ``grid_mf``; on the mean's velocity, round 41's rule). Before it both fields took it: a
cylinder of R 3 cm = 1.5 dx rolling down a jelly slab on a ground took the slab's ground friction at the node layer
2 dx under its centre and rolled 6.5 % slow at n_grid 24 (round 80).

Round 82 (``docs/rigid.md`` "Round 82: the mirror"): the same leak where the rigid body is field B (larger by volume
than the soft body it lies on: a cylinder of R 4.5 cm, 12 cm long, on a slab 6 cm wide rolled 8.5 % slow at n_grid 24),
so there the friction goes to field A alone (:func:`rigid_friction_side` 2): B's offset less ``dv``, A's plus
``dv (1 - f) / f``, ``f`` still A's mass fraction. The rule in one line: the friction goes to the soft field, whose
points the ground holds, never to a rigid one. Decided per node (:func:`rigid_node_rule`), it also holds where
three or more bodies are coloured: two cylinders on one slab rolled 8.2 % slow before, 4.4 % after (n_grid 24).
"""
from __future__ import annotations

import numpy as np


def rigid_node_rule(setup) -> int:
    """Round 82: the engines' rule, decided per node (``docs/rigid.md`` "Round 82"), as bits read when an engine is
    built: 1 a node whose field A holds only rigid mass and B none gives the friction to B alone
    (:data:`gasp_core.mpm.fields.RIGID_A_FRICTION`), 2 a node whose B holds only rigid mass and A none gives it to A
    alone (:data:`gasp_core.mpm.fields.RIGID_B_FRICTION`); 0 off. On in a two-field scene on the particle contact, not
    ``"mixed"``, with a rigid body: two bodies or more, coloured (their ``in_a`` may change between frames; the node
    reads it from P2G). P2G scatters the rigid bodies' mass to ``grid_mf``; the fields' pass compares it with field
    A's and B's mass at each node they share and writes A's mass back signed (+ rule 1, - rule 2, 0 neither)."""
    import gasp_core.mpm.fields as fields
    from gasp_core.mpm.rigid import rigid_mask, step_view
    setup = step_view(setup)
    if fields.contact_model(setup) != "particle" or fields.field_bodies(setup) is None:
        return 0
    if not np.asarray(rigid_mask(setup.materials)).any():
        return 0
    return int(bool(fields.RIGID_A_FRICTION)) + 2 * int(bool(fields.RIGID_B_FRICTION))


def rigid_friction_side(setup) -> int:
    """Which field takes the particle contact's ground friction in a two-body scene, as a whole (the engines decide
    it per node, :func:`rigid_node_rule`, which gives this at every node such a scene's fields share), not
    ``"mixed"``: 1 field B alone (:func:`rigid_a_friction`: field A rigid), 2 field A alone (round 82,
    :data:`gasp_core.mpm.fields.RIGID_B_FRICTION`: a soft field A beside a rigid field B, :func:`fields.mixed_pair`), 0
    both (the rule before; any other scene). A description the tests read; the engines read :func:`rigid_node_rule`."""
    import gasp_core.mpm.fields as fields
    from gasp_core.mpm.rigid import rigid_mask, step_view
    if rigid_a_friction(setup):
        return 1
    setup = step_view(setup)
    if not fields.RIGID_B_FRICTION or fields.contact_model(setup) != "particle" or not fields.mixed_pair(setup):
        return 0
    in_a = fields.field_bodies(setup)
    if in_a is None:
        return 0
    rigid = np.asarray(rigid_mask(setup.materials))
    in_a = np.asarray(in_a, bool)
    return 2 if in_a.any() and not rigid[in_a].any() and rigid[~in_a].all() else 0


def rigid_a_friction(setup) -> bool:
    """Whether the grid update gives the particle contact's ground friction to field B alone in a scene that is not
    ``"mixed"`` (:data:`gasp_core.mpm.fields.RIGID_A_FRICTION`, round 81): two bodies on the particle contact running two fields
    (:func:`fields.field_bodies`) whose field A holds only rigid bodies (a rigid body smaller than the soft one it lies on,
    :func:`fields.mixed_pair`, or either of :func:`fields.rigid_pair`). Not where A is soft (a jelly block on a larger rigid slab:
    the rigid body is B) nor in a coloured scene of three or more bodies, whose ``in_a`` may change between frames
    (``colouring.RECOLOUR``). Read when an engine is built."""
    import gasp_core.mpm.fields as fields
    from gasp_core.mpm.rigid import rigid_mask, step_view
    setup = step_view(setup)
    if not fields.RIGID_A_FRICTION or fields.contact_model(setup) != "particle" or len(setup.materials) != 2:
        return False
    in_a = fields.field_bodies(setup)
    if in_a is None or not np.asarray(in_a).any():
        return False
    return bool(np.asarray(rigid_mask(setup.materials))[np.asarray(in_a, bool)].all())
