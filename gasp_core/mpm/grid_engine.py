"""What a grid (MPM) engine does outside its kernels, written once for the grid engines of GASP.

Model: a solver base class (what every solver does around its kernels) and a solver config (the options and
capabilities as a record), as GPU physics libraries shape them. A grid engine subclasses :class:`GridEngineBase`, sets :attr:`ENGINE`
and :attr:`STATE` and supplies how its arrays are read and written (:meth:`GridEngineBase.read_array`,
:meth:`GridEngineBase.write_array`); the base gives it the point order, the substeps, ``get_state`` /
``set_state`` with one error text, and the statistics every grid engine reports. :data:`MPM_CAPABILITIES` is
the capability record of the MLS-MPM algorithm of ``docs/mpm.md``.
"""
from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from gasp_core.errors import EngineError, SceneError
from gasp_core.seam.engine import Capabilities
from gasp_core.mpm.contact import contact_dt, contact_model, flowing_bodies
from gasp_core.mpm.fields import uses_fields
from gasp_core.mpm.shared_fields import fields_record
from gasp_core.mpm.grid_origin import ground_on_node
from gasp_core.mpm.rigid import lift_setup, rigid_affine, step_view
from gasp_core.mpm.points import engine_mass_stats, material_first_order, stranded_passive
from gasp_core.mpm.substeps import CFL, MAX_SUBSTEPS, substeps_for, substeps_from_options
from gasp_core.mpm.transfer import blend_alpha

#: What an engine implementing ``docs/mpm.md`` on CPU and CUDA offers (its plugin may narrow it).
MPM_CAPABILITIES = Capabilities(
    materials=frozenset({"jelly", "neo_hookean", "metal", "sand", "snow", "plasticine", "liquid", "brittle"}),
    boundaries=frozenset({"ground", "walls", "fixed_region"}),
    devices=frozenset({"cpu", "cuda"}),
    precisions=frozenset({"f32", "f64"}),
    deterministic=frozenset({"cpu"}),
    features=frozenset({"grid", "initial_C", "state", "static_colliders", "moving_colliders", "impulse", "wind",
                        "attractors", "passive_points", "viscosity", "damage", "plastic_strain", "left_domain"}),
)


def choose_dt(setup, opts: dict[str, Any], engine: str, implicit_viscosity: bool = False) -> tuple[int, float]:
    """Substeps per frame and substep length, s (``gasp_core.mpm.substeps.substeps_from_options``,
    docs/mpm.md "Time step"); ``implicit_viscosity``: the engine integrates viscosity by backward Euler, so it
    sets no step cap.

    With the particle contact the step is always kept within the contact's stable step
    (``gasp_core.mpm.contact.contact_dt``, ``docs/contact.md``): a longer CFL step is shortened silently; a
    longer step set by hand (the option ``dt``, or ``n_substeps`` too few) is shortened to it, more substeps per
    frame, with a ``UserWarning`` naming the option, its value and the step taken (at ``n_substeps = 2`` the
    ``bounce`` ball gained 91 % of its drop energy, issue 38).

    Raises
    ------
    SceneError
        More substeps per frame than the option ``max_substeps`` (for the contact's stable step: saying so, and
        what to change).
    """
    n, dt = substeps_from_options(setup, opts, engine, implicit_viscosity)
    dt_c = contact_dt(setup)
    if dt <= dt_c:
        return n, dt
    bound = opts.get("max_substeps") or MAX_SUBSTEPS
    n_c, dt_new = substeps_for(setup.frame_dt, dt_c)
    if n_c > bound:
        raise SceneError(
            f"engine '{engine}': the particle contact's stable step {dt_c:.3g} s (docs/contact.md) needs {n_c} "
            f"substeps per frame (frame_dt = {setup.frame_dt:g} s), more than max_substeps = {bound}: raise the "
            f"engine option max_substeps, lower E or frame_dt, or set contact = \"grid\"")
    key = "dt" if opts.get("dt") is not None else "n_substeps" if opts.get("n_substeps") is not None else None
    if key is not None:
        warnings.warn(
            f"engine '{engine}': {key} = {opts[key]:g} gives a substep of {dt:.3g} s, longer than the particle "
            f"contact's stable step {dt_c:.3g} s (docs/contact.md: the ground would pump energy into the body); "
            f"taking dt = {dt_new:.3g} s, {n_c} substeps per frame", stacklevel=2)
    return n_c, dt_new


def grid_substeps(setup) -> int:
    """The substeps a frame :func:`choose_dt` takes for ``setup`` (its options; a rigid body seen as
    :func:`gasp_core.mpm.rigid.step_view` shows it), silently: the grid engines' ``EngineInfo.substeps``.

    Raises
    ------
    SceneError
        From :func:`choose_dt` (more substeps than ``max_substeps``).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return choose_dt(step_view(setup), dict(getattr(setup, "options", None) or {}), "", implicit_viscosity=True)[0]


def transfer_alpha(setup, opts: dict[str, Any], n_substeps: int, implicit_viscosity: bool = False) -> float:
    """The AFLIP blend of a run of ``n_substeps`` substeps a frame (:func:`gasp_core.mpm.transfer.blend_alpha`): its
    reference step is :func:`choose_dt`'s at ``cfl`` :data:`CFL` with the run's other options (no ``dt``, no
    ``n_substeps``), so the step rules that do not depend on the Courant number (the particle contact's, a rigid
    body's view) shorten both alike. Where the reference would need more than ``max_substeps``, ``alpha`` is
    ``flip``. Returns a float in [0, 1]; raises ``ValueError`` for an unknown ``transfer_damping``."""
    damping = opts.get("transfer_damping") or "rate"
    ref = {**opts, "cfl": CFL, "dt": None, "n_substeps": None}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            n_ref = choose_dt(setup, ref, "", implicit_viscosity)[0]
    except SceneError:
        n_ref = None
    return blend_alpha(float(opts.get("flip") or 0.0), damping, n_substeps, n_ref)


class GridEngineBase:
    """The part of a grid engine that is not a kernel.

    Subclasses set :attr:`ENGINE` (the engine's name, for messages) and :attr:`STATE` (the names of the particle
    arrays :meth:`get_state` saves, in the engine's internal point order) and implement :meth:`read_array` and
    :meth:`write_array`; :meth:`state_extras` / :meth:`restore_extras` add what else a state holds.
    """

    ENGINE = "grid engine"
    STATE: tuple[str, ...] = ()

    @staticmethod
    def grid_setup(setup):
        """The setup a grid engine builds from: its grid laid with the ground's plane on a node where the grid contact
        acts (:func:`gasp_core.mpm.grid_origin.ground_on_node`), then each rigid body put inside a ground or wall
        lifted out (:func:`gasp_core.mpm.rigid.lift_setup`, issue 53), and the affine parts of its given spin its points
        carry as the engines' projection does (:func:`gasp_core.mpm.rigid.rigid_affine`, round 67). ``setup`` itself
        when nothing changes."""
        return rigid_affine(lift_setup(ground_on_node(setup)))

    # ------------------------------------------------------------------ point order
    def order_points(self, setup, dx: float) -> None:
        """Set ``_order`` (internal point i is setup point ``_order[i]``: material points by grid cell, then
        passive points by cell; ``gasp_core.mpm.points.material_first_order``) and ``n_material``."""
        self._order, self.n_material = material_first_order(setup, dx)

    @property
    def _inverse(self) -> np.ndarray:
        """Setup point i is internal point ``_inverse[i]`` (from the current ``_order``)."""
        inverse = np.empty(len(self._order), np.int64)
        inverse[self._order] = np.arange(len(self._order))
        return inverse

    def to_setup_order(self, internal: np.ndarray) -> np.ndarray:
        """Rows of an internal-order array put back in the order of ``setup.x``."""
        out = np.empty_like(internal)
        out[self._order] = internal
        return out

    # ------------------------------------------------------------------ state
    def read_array(self, name: str) -> np.ndarray:
        """The particle array ``name`` of :attr:`STATE` as NumPy, internal order (a copy)."""
        raise NotImplementedError

    def write_array(self, name: str, value: np.ndarray) -> None:
        """Overwrite the particle array ``name`` of :attr:`STATE` (internal order)."""
        raise NotImplementedError

    def check_open(self) -> None:
        """Raise :class:`EngineError` where the engine can no longer be used (closed); subclasses add theirs."""

    def state_extras(self) -> dict[str, np.ndarray]:
        """What a state holds besides the :attr:`STATE` arrays (``frame``; subclasses add theirs)."""
        return {"frame": np.array(self.frame)}

    def restore_extras(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_extras` (``frame``)."""
        self.frame = int(state["frame"])

    def state_names(self) -> tuple[str, ...]:
        """The arrays :meth:`get_state` saves: :attr:`STATE`, and ``C_prev`` under ``stress_at = "trapezoid"`` (round
        69, ``gasp_core.mpm.stress_at``: each point's velocity gradient at its last P2G, which the next increment
        averages; without it a resumed run parts from the run it continues)."""
        trap = getattr(getattr(self, "config", None), "stress_at", "start") == "trapezoid"
        return tuple(self.STATE) + (("C_prev",) if trap else ())

    def get_state(self) -> dict[str, np.ndarray]:
        """The state after the current frame: the :attr:`STATE` arrays (internal order) and
        :meth:`state_extras`. With :meth:`set_state` on a fresh engine of the same setup the run continues
        bit for bit (feature ``state``; ``gasp simulate --resume``)."""
        self.check_open()
        out = {k: self.read_array(k) for k in self.state_names()}
        out.update(self.state_extras())
        from gasp_core.mpm.colouring import colour_state
        out.update(colour_state(self))   # round 61: a coloured scene's last fields, so a resumed run keeps them
        return out

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`get_state` into this engine (built from the same setup).

        Raises
        ------
        EngineError
            A key is missing or an array has the wrong shape (naming the key and both shapes).
        """
        self.check_open()
        for k in self.state_names():
            a = np.asarray(state.get(k))
            want = self.read_array(k).shape
            if a.shape != want:
                raise EngineError(f"engine '{self.ENGINE}': saved state '{k}' has shape {a.shape}; this setup needs "
                                  f"{want}")
            self.write_array(k, a)
        self.restore_extras(state)
        from gasp_core.mpm.colouring import restore_colour
        restore_colour(self, state)

    def damage(self) -> np.ndarray:
        """Per-point damage ``d``, shape (n,), float64, in [0, 1], setup order (feature ``damage``): the ``Jp`` of a
        ``brittle`` point (``gasp_core.mpm.materials.brittle_damage``), 0 for every other point. Needs
        :meth:`read_array` to know ``Jp`` (it is in :attr:`STATE`)."""
        self.check_open()
        brittle = np.array([m.name == "brittle" for m in self.setup.materials])[self.setup.body_id]
        jp = self.to_setup_order(np.asarray(self.read_array("Jp"), np.float64))
        return np.where(brittle, np.clip(jp, 0.0, 1.0), 0.0)

    def plastic_strain(self) -> np.ndarray:
        """Per-point accumulated plastic strain, shape (n,), float64, setup order (feature ``plastic_strain``): the
        ``Jp`` of a ``plasticine`` point (the sum of its von Mises return mappings' ``dg``, dimensionless, what its
        ``softening`` acts on), 0 for every other point. Needs :meth:`read_array` to know ``Jp``."""
        self.check_open()
        plastic = np.array([m.name == "plasticine" for m in self.setup.materials])[self.setup.body_id]
        jp = self.to_setup_order(np.asarray(self.read_array("Jp"), np.float64))
        return np.where(plastic, jp, 0.0)

    # ------------------------------------------------------------------ statistics
    def recolour_fields(self, write) -> None:
        """Round 61 (``gasp_core.mpm.colouring.recolour``): at a frame's start, where the scene is coloured, ``write``
        (the engine's setter of its ``in_a`` table) the bodies' fields from the last frame's points."""
        from gasp_core.mpm.colouring import recolour
        colours = recolour(self)
        if colours is not None:
            write(colours)

    def grid_stats(self, device: str, precision: str, x: np.ndarray | None, p_mass: np.ndarray | None,
                   grid_m: np.ndarray | None) -> dict[str, Any]:
        """The statistics every grid engine reports: ``device, precision, n_points, dt`` (s), ``n_substeps`` (the
        last frame's; where the step follows the state, ``gasp_core.mpm.state_step``, also ``n_substeps_setup`` and
        ``n_substeps_most``, the most a frame took; ``dt`` then the last frame's mean, ``frame_dt / n_substeps``, and
        ``dt_last`` its last substep), ``n_grid``, ``dx`` (m), ``frame``, ``n_passive``, ``contact``
        (``gasp_core.mpm.contact.contact_model``:
        ``"particle"``, ``"grid"`` or ``"mixed"``) and ``contact_per_body`` (per body, ``"grid"`` or
        ``"particle"``), ``contact_fields`` (bool: the two-field contact of ``gasp_core.mpm.fields``); with ``x``
        and ``p_mass`` (internal order, the engine's
        own arrays) ``mass`` (kg), ``centre_of_mass`` (m), ``inertia`` (kg m^2); with passive points after a frame
        and ``grid_m`` (node masses of the last grid update, shape (n_grid,)*3), ``passive_stranded``
        (:func:`gasp_core.mpm.points.stranded_passive`)."""
        setup = self.setup
        n = len(setup.x)
        out = {"device": device, "precision": precision, "n_points": int(n), "dt": float(self.dt),
               "n_substeps": int(self.n_substeps), "n_grid": int(setup.n_grid), "dx": float(setup.dx),
               "frame": self.frame, "n_passive": int(n - self.n_material)}
        clock = getattr(self, "clock", None)   # the step from the state (gasp_core.mpm.state_step): snow's hardening
        if clock is not None and clock.on:   # a frame's substeps may differ: dt is the last frame's mean
            out.update(n_substeps_setup=int(clock.n_setup), n_substeps_most=int(max(clock.frames, default=clock.n)),
                       dt=float(setup.frame_dt) / int(self.n_substeps), dt_last=float(self.dt))
        view = step_view(setup)
        out["contact"] = contact_model(view)
        out["contact_per_body"] = ["grid" if f else "particle" for f in flowing_bodies(view, out["contact"])]
        out["contact_fields"] = uses_fields(view)   # two velocity fields (gasp_core.mpm.fields)
        colouring = fields_record(view)   # round 61: the coloured bodies' fields, or those that still share one
        if colouring:
            if getattr(self, "colour_shared", None):   # recoloured per frame: the pairs that shared at any frame
                colouring["shared_pairs_run"] = sorted([int(i), int(j)] for i, j in self.colour_shared)
            out["field_colouring"] = colouring
        if x is not None:
            out.update(engine_mass_stats(x, p_mass))
            if grid_m is not None and self.n_material < n and self.frame > 0:
                out["passive_stranded"] = stranded_passive(x[self.n_material:], grid_m, setup.domain_lo, setup.dx)
        return out
