"""Round 76: the spin a rigid body's points carry, booked and taken back (``docs/rigid.md`` "Round 76").

Since round 67 (:data:`gasp_core.mpm.rigid.APIC_SPIN` 0) a rigid body turns with its own lattice inertia ``I``. P2G with
APIC's affine parts books ``m dx^2 / 2 w`` of angular momentum per point (``D = dx^2 / 4 I``, Jiang et al. 2015)
beyond ``I w``. The grid plugins' ``rigid_apply`` puts ``carry [w]`` in each point's ``C`` and their ``rigid_update``
takes ``book M dx^2 / 2 w_prev`` off the angular momentum it reads, per body (:func:`spin_shares`).
"""
from __future__ import annotations

import numpy as np

import gasp_core.mpm.rigid as _rigid   # APIC_SPIN read when called (a test sets it)
from gasp_core.mpm.rigid import body_frames, rigid_mask


#: Whether a rigid body carries its whole spin in its points' affine parts (``C = [w]``) while it still turns with
#: its own inertia (``gasp_core.mpm.rigid.APIC_SPIN`` 0): P2G then books ``M dx^2 / 2 w`` of angular momentum in the
#: grid on top of the body's own ``I w``, and the projection takes that booking of the spin the points carried back
#: off what it reads (:func:`booked_share`) before ``w = I^-1 L``. The grid then holds the body's exact rigid field
#: out to its edge nodes (APIC reproduces an affine field), as before round 67. False is rounds 67-75's transfer:
#: ``C = 0``, a PIC field slower than the body at its edge nodes; under a flowing load that mismatch fed the body's
#: spin back with a gain per substep (a hardwood box under thrown sand spun up 2x a millisecond and left the ground at
#: +3.2 m/s at 4x the default substeps, its energy 6e4 times the start's; ``docs/rigid.md`` "Round 76"). Which
#: bodies book: :func:`spin_shares` (alone in their field, or a booking ratio of at most 1).
SPIN_BOOKED = True


def carried_spin() -> float:
    """The share of a rigid body's spin ``w`` its points carry in ``C`` after the projection (the grid plugins'
    ``rigid_apply``) where it books (:func:`spin_shares`): 1 under :data:`SPIN_BOOKED`, else ``APIC_SPIN``."""
    return 1.0 if SPIN_BOOKED else float(_rigid.APIC_SPIN)


def booked_share() -> float:
    """The share of ``M dx^2 / 2 w_prev`` (``w_prev`` the spin the points carried) the projection subtracts from the
    angular momentum it reads where a body books (:func:`spin_shares`): what P2G booked beyond the inertia the rigid
    laws use (``APIC_SPIN M dx^2 / 2``), ``1 - APIC_SPIN`` under :data:`SPIN_BOOKED`, else 0."""
    return 1.0 - float(_rigid.APIC_SPIN) if SPIN_BOOKED else 0.0


def booking_ratio(setup) -> np.ndarray:
    """Per body (shape (n_bodies,)), ``M dx^2 / 2`` over the least principal moment of its lattice inertia
    (:func:`body_frames`; 0 for a body that is not rigid or has no mass): the booking of the spin against the body's
    own inertia. A body a few cells across reads about 0.1-0.3 (the 12 x 12 x 6 cm box at n_grid 32: 0.12); a
    fragment a cell or two across, 1 to 5."""
    rigid = np.asarray(rigid_mask(setup.materials), bool)
    _, _, inertia0, mass = body_frames(setup.x, setup.p_mass, np.asarray(setup.body_id), rigid)
    out = np.zeros(len(rigid))
    for b in np.flatnonzero(rigid & (mass > 0.0)):
        lam = float(np.linalg.eigvalsh(inertia0[b]).min())
        out[b] = 0.5 * mass[b] * float(setup.dx) ** 2 / lam if lam > 0.0 else np.inf
    return out


def spin_shares(setup) -> tuple[np.ndarray, np.ndarray]:
    """``(carry, book)``, each shape (n_bodies,), float64: per body the share of its spin its points carry in ``C``
    and the share of ``M dx^2 / 2 w_prev`` its projection takes back (the grid plugins' ``rigid_apply`` and
    ``rigid_update``). A rigid body books (:func:`carried_spin`, :func:`booked_share`) when it is alone in its grid
    field (``gasp_core.mpm.fields.field_bodies``; one field: the scene's only body with points), where it reads back
    exactly its own booking, or when its :func:`booking_ratio` is at most 1: where bodies share a field, a node mixes
    their bookings and a body's spin takes up to that ratio times the spin difference of its neighbours, so above 1
    it overshoots it (the cup's fragments at 20 m/s, ratios up to 4.8, diverged). Every other body takes
    ``APIC_SPIN`` and 0 (rounds 67-75's transfer; a soft body's row is not read).

    Round 77: in a scene coloured again at every frame (``gasp_core.mpm.colouring.RECOLOUR`` and
    ``colouring.coloured``: three or more bodies on the particle contact) a body's field-mates change during the run,
    so only the ratio decides there: the shares are set once at the build, and a body alone at the build that came to
    share its field would book what its neighbours' nodes mix (a switch between frames would misread one substep:
    the points carry the old share). Such scenes have no flowing body, whose load fed the transfer before."""
    import gasp_core.mpm.colouring as colouring
    from gasp_core.mpm.fields import field_bodies
    n = len(setup.materials)
    carry, book = np.full(n, float(_rigid.APIC_SPIN)), np.zeros(n)
    rigid = np.asarray(rigid_mask(setup.materials), bool)
    present = np.bincount(np.asarray(setup.body_id), minlength=n)[:n] > 0
    fields = field_bodies(setup)
    side = np.zeros(n, bool) if fields is None else np.asarray(fields, bool)
    ratio = booking_ratio(setup)
    fixed = not (colouring.RECOLOUR and colouring.coloured(setup))   # the fields hold for the whole run
    for b in np.flatnonzero(rigid & present):
        if (fixed and int((present & (side == side[b])).sum()) == 1) or ratio[b] <= 1.0:
            carry[b], book[b] = carried_spin(), booked_share()
    return carry, book
