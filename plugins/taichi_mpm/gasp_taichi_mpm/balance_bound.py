"""The balance's closing bound (round 59; :mod:`gasp_taichi_mpm.balance`'s ``body_fix``; warp_mpm's
``gasp_warp_mpm.balance.closing_bound``): apart so that ``balance.py`` keeps the house's file size."""

import taichi as ti


@ti.func
def closing_bound(dF, alpha, inertia, Mc, um, omega, dv_j):
    """The factor (1 at most) on a support's fix that holds it to the pair's closing motion at its listed nodes
    (round 59; warp_mpm's ``closing_bound``; ``docs/fracture.md`` "Round 59: the cup at 20 m/s").

    The fix ``dv + alpha x (X - x_m)`` (``dv = dF / Mc``) is the contact's own impulse redistributed (its friction
    made Coulomb's on the body's rigid motion, its normal impulse's centre moved within the reach): momentum
    exchanged between the body and its support where they touch, which brings the two together. It may not move the
    listed nodes faster than the pair meets there over the substep, or it makes motion instead of taking it (no node
    takes a velocity the body never had). Measured as mass-weighted root mean squares over the listed nodes (mass
    ``Mc``, inertia ``I`` about their mass centre ``x_m``), exactly:

    - the fix's: ``sqrt(|dF|^2 / Mc^2 + alpha . I alpha / Mc)`` (the cross term ``dv . alpha x sum m (X - x_m)``
      is 0);
    - the pair's: ``sqrt(|u_m|^2 + omega . I omega / Mc) + dv_j``: the body's rigid velocity relative to the support
      at the nodes, ``u_m + omega x (X - x_m)`` (``u_m`` at ``x_m``, with this substep's gravity), plus ``dv_j``, the
      velocity change the support's normal impulse ``J`` gives the points it pushes, ``J / M_p`` (their mass), or
      ``J / M`` for a rigid body, whose points all move as one (at rest the weight's share, where ``u_m`` is near 0).

    One factor on ``dv`` and ``alpha`` alike keeps the fix's shape. Why it is needed: a support whose listed nodes are
    light (the push key, ``gasp_core.mpm.contact_mark``, leaves it the fringe of its points' stencils, the rows that
    push harder keeping the rest), or lie nearly on a line (``I`` near singular), took the whole body's correction,
    its torque up to ``J reach TORQUE_REACH``, on that mass: on the cup's rigid fragments at 20 m/s, root mean squares
    of 22 m/s to 1 500 m/s on listed masses of 1e-7 to 1e-3 kg (the run's divergence there was a NaN, the inertia
    guard in :meth:`Balance.body_fix`). f64: ``dF`` (kg m/s, 3), ``alpha`` and ``omega`` (1/s, 3),
    ``inertia`` (kg m^2, 3x3), ``Mc`` (kg), ``um`` (m/s, 3), ``dv_j`` (m/s); returns the factor in (0, 1]."""
    ms = dF.dot(dF) / (Mc * Mc) + alpha.dot(inertia @ alpha) / Mc
    cap = ti.sqrt(um.dot(um) + ti.max(omega.dot(inertia @ omega), 0.0) / Mc) + dv_j
    k = ti.cast(1.0, ti.f64)
    if ms > cap * cap:
        k = cap / ti.sqrt(ms)
    return k
