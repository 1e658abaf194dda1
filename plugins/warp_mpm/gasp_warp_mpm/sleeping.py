"""Sleeping bodies (the feature ``sleep``, ``gasp_core.seam.body_sleep``): :class:`Sleeping`, a mixin of
:class:`gasp_warp_mpm.engine.WarpMPMEngine`.

The points of the sleeping bodies are moved to the end of the material range (a stable partition of the point
order: on CPU of the cell order, which ``_resort`` keeps after every frame) and the per-material-point launches (P2G,
G2P, the contact's moments, the rigid bodies' sums) run over the awake prefix only: a sleeping point costs nothing
and its ``x, v, F, C, Jp`` stay as they are. The partition depends only on the points' positions and the flags,
so a run resumed from a checkpoint (whose flags the core gives again after ``set_state``) repeats bit for bit.
Passive points (after the material range) are not moved; the core never puts a body with passive points or a
rigid body to sleep.
"""
from __future__ import annotations

import numpy as np

#: The kernels launched once per material point, whose launch size follows the awake count.
PER_MATERIAL_POINT = ("p2g", "g2p", "contact_moments", "rigid_reduce")


class Sleeping:
    """``set_asleep`` and the awake-first point order (see the module docstring)."""

    _asleep: np.ndarray | None = None

    def set_asleep(self, asleep: np.ndarray) -> None:
        """Freeze the flagged bodies from the next frame.

        Parameters
        ----------
        asleep : ndarray, shape (n_bodies,), bool
            One flag per ``SimSetup.body_id`` value.
        """
        self.check_open()
        self._asleep = np.asarray(asleep, dtype=bool).ravel().copy()
        if self.n_points == 0:
            return
        if self.device.is_cuda:
            m = self.n_material
            body = self.body.numpy()[:m]
            part = np.argsort(self._asleep[body], kind="stable")
            self.permute(np.concatenate([part, np.arange(m, self.n_points)]))
            self._graph = None   # the launch sizes change: capture again
        else:
            self._resort()
        n_awake = int(np.count_nonzero(~self._asleep[self.body.numpy()[:self.n_material]]))
        for cmd in [*self._launches, *self._pre]:
            if _kernel_name(cmd) in PER_MATERIAL_POINT:
                cmd.set_dim(n_awake)

    def material_order(self, x_m: np.ndarray) -> np.ndarray:
        """The material points' order by cell (``_cell_order``), the sleeping bodies' points last (stable)."""
        perm = self._cell_order(x_m)
        if self._asleep is None or not self._asleep.any():
            return perm
        body = self.body.numpy()[:len(x_m)]
        return perm[np.argsort(self._asleep[body[perm]], kind="stable")]

    def permute(self, perm: np.ndarray) -> None:
        """Reorder every per-point array by ``perm`` (internal order), on any device."""
        if np.array_equal(perm, np.arange(self.n_points)):
            return
        per_point = [self.p_contact] if self.p_contact.shape[0] == self.n_points else []  # (1, 3) without planes
        per_point += [self.X0] if self.any_rigid else []
        for a in (self.x, self.v, self.F, self.C, self.Jp, self.p_mass, self.p_vol, self.body, self.fixed, *per_point):
            a.assign(a.numpy()[perm])
        self.permute_marks(perm[:self.n_material])
        self._order = self._order[perm]

    def permute_marks(self, perm_m: np.ndarray) -> None:
        """Reorder field A's points' marks ``p_pic`` (fields.py; one entry without them) by ``perm_m``, the material
        points' new order (n_material,)."""
        if self.p_pic.shape[0] > 1:
            self.p_pic.assign(self.p_pic.numpy()[perm_m])


def _kernel_name(cmd) -> str:
    """The Python name of a recorded launch's kernel."""
    k = getattr(cmd, "kernel", None)
    return getattr(getattr(k, "func", None), "__name__", "") or str(getattr(k, "key", ""))
