"""Scenes of the pair's friction in the rigid collider (round 65, ``docs/rigid.md`` "Round 65: the pair's friction in
the collider", ``tests/test_pair_friction.py``; :mod:`gasp_core.mpm.rigid_collider`).

- :func:`far_setup`: a rigid 6 x 6 x 3 cm block (body 0) thrown at ``v0`` along +x on a jelly slab A 32 x 16 x 3 cm
  (body 1) on a frictionless ground (``scenes_rigid3.mixed_setup``'s block and slab); with ``mu_far`` a second jelly
  B (body 2, 12 x 6 x 3 cm) at rest on the ground 6 cm beside the slab (beyond the colouring's reach at n_grid >= 24:
  never touched by the block or the slab).
- :func:`bridge_setup`: a rigid block 6 cm long, 2 Y wide, 3 cm tall (body 0) thrown along +x across three jelly
  slabs side by side on a ground that holds them, each 3 cm thick: A (body 1) in the middle, B1 and B2 (bodies 2, 3) one
  each side, ``GAP_CELLS`` cells from A (beyond the colouring's reach: A and the B's share a field, the block the
  other). The block's overlap with A (6 cm) equals its overlaps with B1 and B2 together (3 cm each), so that with
  the slabs alike but for ``friction`` and the block level their loads are equal, ``N_A = N_B1 + N_B2 = M g / 2``
  (no lever: B1 and B2 mirror each other, so their friction turns the block neither way); Coulomb's deceleration is
  ``(mu_A N_A + mu_B N_B) / M = g (mu_A + mu_B) / 2``, the pairs' ``mu`` (``combine_friction`` of the block's and
  the slab's ``friction``).

Jelly rho 1000, E 1e5 Pa (``scenes_rigid3._setup``), frames of 1/60 s.
"""
from __future__ import annotations

import numpy as np

from gasp_core.testing import scenes_rigid3 as S3
from gasp_core.testing.scenes_rigid3 import G, SIDE

#: The gap between slab A and each of B1, B2 of :func:`bridge_setup`, in cells (3: the colouring's reach).
GAP_CELLS = 3.5


def far_setup(n_grid: int = 32, mu_block: float = 0.5, mu_a: float = 0.5, mu_far: float | None = None,
              v0: float = 0.5):
    """The block on slab A, with a far jelly B of ``friction`` ``mu_far`` (None: no B, the two-body pair)."""
    boxes = [([-0.03, -0.03, 0.03], [0.03, 0.03, 0.06]), ([-0.12, -0.08, 0.0], [0.20, 0.08, 0.03])]
    models, mus = ["rigid", "elastic"], [mu_block, mu_a]
    if mu_far is not None:
        boxes.append(([-0.06, 0.14, 0.0], [0.06, 0.20, 0.03]))
        models.append("elastic")
        mus.append(mu_far)
    return S3._setup(boxes, models, [v0, 0.0, 0.0], n_grid, 0.0, mus)


def bridge_setup(n_grid: int = 32, mu_block: float = 1.0, mu_a: float = 0.16, mu_b: float = 0.64, v0: float = 1.0,
                 ground_mu: float = 1.0):
    """The block across slabs B1, A, B2 (module notes) on a ground of friction ``ground_mu`` (1: it holds the slabs,
    whose friction on the block, at most 0.4 of its weight, is below the ground's cap on each)."""
    dx = SIDE / n_grid
    a, g = 0.03, GAP_CELLS * dx   # A's half-width, the gaps (m)
    Y = 2 * a + g   # the block's half-width: its overlap with each B is a
    boxes = [([-0.03, -Y, 0.03], [0.03, Y, 0.06]), ([-0.12, -a, 0.0], [0.20, a, 0.03]),
             ([-0.12, a + g, 0.0], [0.20, Y + a, 0.03]), ([-0.12, -Y - a, 0.0], [0.20, -a - g, 0.03])]
    return S3._setup(boxes, ["rigid", "elastic", "elastic", "elastic"], [v0, 0.0, 0.0], n_grid, ground_mu,
                  [mu_block, mu_a, mu_b, mu_b])


def pair_mu(s, slab: int = 1) -> float:
    """The block's (body 0) pair coefficient with body ``slab``: ``combine_friction`` of their ``friction``."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    return combine_friction(body_friction(s.materials[0]), body_friction(s.materials[slab]))


def far_closed_form(s) -> float:
    """Coulomb's slide (m) of the block on slab A alone (the slab free on a frictionless ground; B takes no part):
    ``v0^2 / (2 mu g (1 + m0 / m_A))``, ``mu`` the block's pair with A."""
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    v0 = float(np.asarray(s.v)[0, 0])
    return v0 ** 2 / (2 * pair_mu(s) * G * (1 + pm[body == 0].sum() / pm[body == 1].sum()))


def measure_far(engine: str, s, T: float = 0.3) -> dict:
    """``slide`` (m): the change of the block's separation from slab A along x over ``T`` (s); ``closed`` (m):
    :func:`far_closed_form`; ``far`` (m): body 2's largest move of its centre (0 without it)."""
    C, _, _, _ = S3._run(engine, s, T)
    far = float(np.abs(C[:, 2] - C[0, 2]).max()) if C.shape[1] > 2 else 0.0
    return {"slide": float((C[-1, 0, 0] - C[-1, 1, 0]) - (C[0, 0, 0] - C[0, 1, 0])), "closed": far_closed_form(s),
            "far": far}


def measure_bridge(engine: str, s, t0: float = 1.0 / 30.0, t1: float = 0.1) -> dict:
    """``decel`` (m/s^2): the block's x deceleration, the slope of a line fitted to its centre's x velocity (frame
    differences) from ``t0`` to ``t1`` s (sliding throughout: at ``v0`` 1 m/s and ``g (mu_A + mu_B) / 2`` its speed
    falls to about 0.4 m/s by 0.1 s); ``expect`` (m/s^2): ``g (mu_A + mu_B) / 2``; ``turn`` (deg): the block's yaw
    at the end."""
    C, turn, _, _ = S3._run(engine, s, t1 + 2 * s.frame_dt)
    t = np.arange(len(C)) * s.frame_dt
    v = np.diff(C[:, 0, 0]) / s.frame_dt
    tm = 0.5 * (t[1:] + t[:-1])
    sel = (tm >= t0 - 1e-9) & (tm <= t1 + 1e-9)
    slope = np.polyfit(tm[sel], v[sel], 1)[0]
    return {"decel": float(-slope), "expect": G * 0.5 * (pair_mu(s, 1) + pair_mu(s, 2)), "turn": float(turn[0]),
            "v": v}
