"""Round 81 (``docs/rigid.md`` "Round 81: the coarse roll's leak fixed"): rounds 41-43's :data:`B_FRICTION
<gasp_core.mpm.fields.B_FRICTION>` where field A is rigid. A rigid body's own ground contact is the rigid law's, so the
particle contact's ground friction, which the grid update applies to a node's mean velocity, is given to field B
alone at the nodes the fields share (A's offset less ``dv``, B's plus ``dv f / (1 - f)``, ``f`` A's mass fraction
there, scattered in P2G to ``grid_mf``; on the mean's velocity, round 41's rule). Before it both fields took it: a
cylinder of R 3 cm = 1.5 dx rolling down a jelly slab on a ground took the slab's ground friction at the node layer
2 dx under its centre and rolled 6.5 % slow at n_grid 24 (round 80).
"""
from __future__ import annotations

import numpy as np


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
