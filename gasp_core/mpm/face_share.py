"""Round 96 (issue 67 item 4, ``docs/contact.md`` "Round 96: a soft block on a thin soft support"): where two solid
fields meet, a node takes the two-field contact only where field B shows a face towards field A.

The two-field contact (:mod:`gasp_core.mpm.fields`) corrects the two velocities at a node by Coulomb's law about
B's surface normal ``grad m_B``. On a support one or two cells thick that normal is not B's surface everywhere A's
kernel reaches:

- on B's middle node layer (a support 2 cells thick whose faces lie on node layers) B's mass is the same one layer
  above and below, so ``grad m_B`` is nought up to roundoff and the dynamics' asymmetry, and its direction is
  noise; A's points 1.25 cells above reach that layer, and the contact there, or the glue where the gradient is
  under ``MIN_GRADIENT``, braked a jelly block sliding on a jelly support: its slide came out 8-13 % short at
  n_grid 24-48, the more the faster it slid (0.25-1 m/s);
- on a support 1 cell thick, A's kernel reaches B's lower layer, whose gradient points up into B from its bottom
  face (the ground's side): there the contact met A's tail with B's far face and took the pair's vertical ringing
  as an approach, with its friction: -30 % and -82 % of Coulomb's slide with the grid shifted a quarter and half a
  cell.

The rule: the node takes the contact where ``-grad m_B . grad m_A > FACE_SHARE m_B |grad m_A|``: B's mass falls
towards A (the two gradients point into their own bodies, so they oppose at an interface) by at least ``FACE_SHARE``
of B's own mass at the node over the central difference's two cells. Elsewhere the fields keep their offsets, neither
corrected nor glued. A face, and the tail of one (B's mass small, its fall steep), pass; B's middle layer (its fall
nought up to noise) and B's far face (its fall away from A) do not. Measured (``docs/contact.md``): the
slide's error and the stacked jelly balls' gap (``tests/test_stacked_balls.py``) are flat for ``FACE_SHARE`` 0.03-1.
A first form against A's own face's steepness (``FACE_SHARE |grad m_A|^2``) met the slides at 0.03-0.3 but sank the
stacked balls 0.076 cell at 0.1 (where B's tail meets A's surface off the balls' axis B's gradient is weak against
A's): not kept. It acts between two solids that do not flow (:func:`face_share`); a flowing body's touch (sand on a
support) keeps its own rule, and a ground's mirror (:func:`gasp_core.mpm.fields_reference.ground_mirror`) is
unchanged.
"""
from __future__ import annotations

import numpy as np

#: Round 96: B's face towards A must be at least this share of A's own face's steepness (``|grad m_A|``) for a node
#: to take the two-field contact (:func:`faced`); 0 switches the rule off (the rule before, the catch).
FACE_SHARE = 0.1


#: Round 97 (``docs/contact.md`` "Round 97: where a block on a thin support comes to rest"): True takes the rule to
#: scenes whose bodies are all rigid (two, :func:`gasp_core.mpm.fields.rigid_pair`, or three or more coloured, round
#: 62's pairs); False: off there (the rule before: a rigid block on a rigid board 1 cell thick, half a cell off the
#: nodes, never stuck, sliding on at 0.04 m/s, +27 % of Coulomb's slide; two blocks on it slid -13.7 % short).
RIGID_PAIR_FACE = True

#: Round 98 (``docs/contact.md`` "Round 98: three bodies mixed"): True keeps the rule on in a coloured scene (three or
#: more bodies) that mixes rigid and soft ones, whose rigid/soft nodes the moving collider takes
#: (:func:`gasp_core.mpm.rigid_collider.collider_multi`): it writes those nodes after the contact's pass, so the rule
#: then acts at the soft/soft nodes (and, with :data:`RIGID_PAIR_FACE`, the rigid/rigid ones) alone. False: off in every
#: such scene (the rule before: a jelly block on a jelly support 1 cell thick beside a rigid block came to rest -22 %
#: and -82 % short of Coulomb's distance with the grid a quarter and half a cell off, round 96's failure back).
MIXED_FACE = True


def face_share(setup) -> float:
    """``FACE_SHARE`` where a scene's two-field contact is between solids that do not flow and none is rigid (two
    soft bodies, or three or more coloured ones: :func:`gasp_core.mpm.fields.body_pair`), or (round 97,
    :data:`RIGID_PAIR_FACE`) between rigid bodies, all of the scene's, or (round 98, :data:`MIXED_FACE`) in a scene of
    both, three or more coloured, where the moving collider takes the rigid/soft nodes
    (``rigid_collider.collider_multi``; the collider's band keeps its own test, ``b_band``), else 0.0
    (off: a rigid body beside one soft body, whose every shared node the collider writes)."""
    from gasp_core.mpm.fields import body_pair
    from gasp_core.mpm.rigid import rigid_mask
    from gasp_core.mpm.rigid_collider import collider_multi
    if not body_pair(setup):
        return 0.0
    rigid = np.asarray(rigid_mask(setup.materials), bool)
    if rigid.all():
        return float(FACE_SHARE) if RIGID_PAIR_FACE else 0.0
    if rigid.any() and not (MIXED_FACE and collider_multi(setup)
                            and (RIGID_PAIR_FACE or int(rigid.sum()) < 2)):
        return 0.0
    return float(FACE_SHARE)


def faced(grad_b, grad_a, m_b, share: float = FACE_SHARE) -> np.ndarray:
    """Whether each node takes the two-field contact (the NumPy reference of the engines' test).

    Parameters
    ----------
    grad_b, grad_a : array_like, shape (n, 3)
        ``grad m_B`` and ``grad m_A`` at the nodes as the engines take them: central differences of the node masses
        (kg; ``grad m_B`` with a ground's mirror where the engine sees it).
    m_b : array_like, shape (n,)
        B's mass at the nodes, kg.
    share : float
        :data:`FACE_SHARE`; 0 or less: every node (the rule off).

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    gb, ga = np.asarray(grad_b, np.float64), np.asarray(grad_a, np.float64)
    if not share > 0.0:
        return np.ones(len(gb), bool)
    return -(gb * ga).sum(axis=1) > share * np.asarray(m_b, np.float64) * np.linalg.norm(ga, axis=1)


def b_band() -> tuple[float, float]:
    """Round 96: ``(band, share)`` of the moving collider's band where the rigid body is field B
    (:mod:`gasp_core.mpm.rigid_collider`): its ``FACE_BAND`` (cells) and :data:`FACE_SHARE` with the face rule on;
    its ``BAND`` and 0.0 with it off (``FACE_SHARE`` 0: the rule before, the catch). Here since round 98 (it was
    ``rigid_collider.b_band``), so that :func:`face_share` may read the collider's switches without a loop."""
    from gasp_core.mpm.rigid_collider import BAND, FACE_BAND
    share = float(FACE_SHARE)
    return (float(FACE_BAND), share) if share > 0.0 else (float(BAND), 0.0)
