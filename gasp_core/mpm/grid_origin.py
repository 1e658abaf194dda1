"""Where a grid engine lays its grid: the ground's plane on a node layer for the grid contact (issue 67, round 35;
docs/contact.md "The ground on a node layer").

The grid contact (the separate collider with Coulomb friction, docs/mpm.md step 3) stops the node layers at and below a
ground's plane and leaves the layer above it free. In the weak form the plane's reaction reaches every node whose
kernel covers the plane, in the share ``w(z_node - height)`` (the quadratic B-spline: 3/4 on a node at the plane,
1/8 on each neighbour); the free node above the plane takes its share of the base's shear from the stress but none of
the ground's reaction, so the friction the ground can give falls short of Coulomb's. That share is 1/8 with the
plane on a node and grows to 0.28, 1/2 and 0.69 with the plane 1/4, 1/2 and 3/4 of a cell above its top node: a jelly
block on a 30 deg slope at mu 0.6 (``tests/test_elastic_slope.py``'s, grid contact, n_grid 24) crept 120, 147,
193 and 271 mm in 1 s, and the sand column of a = 2 (n_grid 48) ran out -20.1, -20.1, -20.1 and -28.8 % from Lube et
al.'s fit with heights -7.8 to -11.4 %: the same scene gave different answers for where the grid happened to lie.
:func:`ground_on_node` moves the grid (never the scene) so that the plane lies on a node: every offset then reads as
offset 0, the least of the free share.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from gasp_core.mpm.contact import flowing_bodies


def ground_shift(height: float, domain_lo_z: float, dx: float) -> float:
    """The move of the grid's origin along z (m, within ``[-dx/2, dx/2)``) that puts the plane ``z = height`` on a
    node layer: ``lo_z + shift + k dx = height`` for an integer ``k``.

    Parameters
    ----------
    height, domain_lo_z : float
        The ground's height and the grid origin's z, m.
    dx : float
        Cell size, m (> 0).
    """
    frac = (float(height) - float(domain_lo_z)) / float(dx)
    off = frac - math.floor(frac)          # the plane's height above its top node, in cells, [0, 1)
    if off >= 0.5:
        off -= 1.0
    return off * float(dx)


def ground_on_node(setup):
    """The setup with its grid origin moved along z so that its first ground inside the domain lies on a node layer,
    where any of its bodies takes the grid contact (:func:`gasp_core.mpm.contact.flowing_bodies`); else ``setup``
    itself. The points, the ground and every other boundary stay where the scene put them; the domain's box moves by
    :func:`ground_shift` (at most half a cell, the same ``dx``). Called by the MPM engines before they build anything.

    Parameters
    ----------
    setup : gasp_core.seam.setup.SimSetup

    Returns
    -------
    SimSetup
        A shallow copy with ``domain_lo`` and ``domain_hi`` moved along z, or ``setup`` when nothing moves.
    """
    if not np.any(flowing_bodies(setup)):
        return setup
    lo = np.asarray(setup.domain_lo, np.float64)
    hi = np.asarray(setup.domain_hi, np.float64)
    heights = [float(b.height) for b in setup.boundaries if b.kind == "ground" and lo[2] <= b.height < hi[2]]
    if not heights:
        return setup
    shift = ground_shift(heights[0], lo[2], setup.dx)
    if shift == 0.0:
        return setup
    move = np.array([0.0, 0.0, shift])
    return dataclasses.replace(setup, domain_lo=lo + move, domain_hi=hi + move)
