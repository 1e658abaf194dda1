"""Which support a contact node's friction is booked to, for the contact's balance (docs/contact.md "Round 55: a node's
support"; the engines' ``balance.py``).

In P2G a point that a support pushes marks its 27 nodes. A node marked by points of several rows of the balance (a
corner of the ground and a wall, two bodies' points) keeps the row of the point that pushes it most, ``w_ip |j_p|``
(its B-spline weight on the node times its contact impulse). Until round 55 the last point to write won: the result
hung on the order of the points, so it differed between the engines, between an engine's CPU and GPU schedules
and, on a GPU, from run to run (a race). The rule here is an atomic max of one 32-bit key per node,

``key = q << MARK_ROW_BITS | row``, ``q = clamp(floor((log2(w |j|) + MARK_OCTAVES_BELOW) MARK_STEPS), 0, 2^15 - 1)``,

so it is the same on any order, thread count or device; ties (pushes within ``2^(1/MARK_STEPS)``, 0.27 %) go to the
higher row. The grid update keeps the row, ``key & MARK_ROW_MASK``, before the balance reads it.
"""
from __future__ import annotations

import numpy as np

#: Bits of a node's key that hold the balance's row (``body n_sup + support``): at most ``2^16`` rows.
MARK_ROW_BITS = 16
#: ``(1 << MARK_ROW_BITS) - 1``: a key's row.
MARK_ROW_MASK = (1 << MARK_ROW_BITS) - 1
#: Steps of the push's quantised log2 per octave (a key tells pushes apart down to 0.27 %).
MARK_STEPS = 256
#: The smallest push a key tells apart from zero is ``2^-MARK_OCTAVES_BELOW`` kg m/s (the largest ``2^64``).
MARK_OCTAVES_BELOW = 64
#: The largest quantised push: 15 bits, so a key stays a positive int32.
MARK_Q_MAX = (1 << (31 - MARK_ROW_BITS)) - 1


def mark_key(push: float, row: int) -> int:
    """A node's key for a point of the balance's ``row`` (int, ``0 <= row <= MARK_ROW_MASK``) that pushes it with
    ``push = w_ip |j_p|`` (kg m/s, >= 0); the engines' kernels spell the same (their ``mark_key``)."""
    q = 0
    if push > 0.0:
        q = int(np.clip(np.floor((np.log2(push) + MARK_OCTAVES_BELOW) * MARK_STEPS), 0, MARK_Q_MAX))
    return (q << MARK_ROW_BITS) | int(row)


def check_mark_rows(n_rows: int) -> None:
    """Raise ``ValueError`` when the balance has more rows (bodies times supports) than a key holds."""
    if n_rows > MARK_ROW_MASK + 1:
        raise ValueError(f"the contact's balance has {n_rows} rows (bodies x supports), more than the "
                         f"{MARK_ROW_MASK + 1} a contact node's key holds (gasp_core.mpm.contact_mark); set "
                         "contact_balance = false or use fewer bodies or colliders with the particle contact")
