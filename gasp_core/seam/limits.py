"""Per-engine parameter limits, declared as data (:attr:`gasp_core.seam.engine.EngineInfo.limits`).

Some engines accept a narrower range of a scene value than the core does: an engine whose elasticity
model takes only ``nu >= 0`` where the core takes ``-1 < nu < 0.5``, or one that pads its grid by 3 cells
and so needs ``n_grid >= 8`` (the limits the bundled plugins declare: ``gasp engines``;
``docs/tolerances.md``). A plugin declares such ranges as
:class:`Limit` records keyed by the parameter; the core checks them in one place
(:func:`check_limits`, called by :func:`gasp_core.seam.build.build_engine` before the factory) with
one error text, and ``gasp engines`` lists them.

Keys
----
``"<field>"`` or ``"<material>.<field>"`` for a :class:`~gasp_core.seam.setup.Material` field
(``"nu"``: every material that uses it, :data:`~gasp_core.seam.schema.MATERIAL_KINDS`; ``"metal.yield_stress"``:
metal only; naming a material that does not use the field is the plugin's mistake); ``"<field>"`` or
``"<kind>.<field>"`` for a :class:`~gasp_core.seam.setup.Boundary` field (``"friction"``,
``"ground.height"``); ``"n_grid"`` or ``"frame_dt"`` for the :class:`~gasp_core.seam.setup.SimSetup`
values of those names. The field names of the three do not overlap.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Iterator, Mapping

from gasp_core.errors import SceneError
from gasp_core.seam.schema import MATERIAL_KINDS
from gasp_core.seam.setup import BOUNDARIES, MATERIALS, Boundary, Material, SimSetup

#: Numeric fields a limit may name, by where they live.
#: (A material's ``friction``, the pair rule's coefficient with no scene key, is not one: ``friction`` names the
#: boundaries'.)
MATERIAL_FIELDS = frozenset(f.name for f in dataclasses.fields(Material) if f.name not in ("name", "model", "friction"))
BOUNDARY_FIELDS = frozenset({"height", "friction"})
SETUP_FIELDS = frozenset({"n_grid", "frame_dt"})


@dataclass(frozen=True)
class Limit:
    """The range an engine accepts for one parameter (within the core's own range).

    Attributes
    ----------
    lo, hi : float, optional
        Bounds, in the parameter's unit (Pa, kg/m^3, degrees, seconds, ...); None = unbounded.
        ``lo == hi`` means the engine takes that value only.
    lo_open, hi_open : bool
        Make the bound exclusive.
    why : str
        The engine's reason, one line (quoted in the error), e.g. ``"the engine's elasticity model"``.
    """

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    why: str = ""

    def expected(self, name: str) -> str:
        """The accepted range in words, e.g. ``"nu >= 0"``, ``"friction_angle in (0, 90)"``."""
        if self.lo is not None and self.lo == self.hi:
            return f"{name} = {self.lo:g}"
        if self.lo is not None and self.hi is not None:
            return (f"{name} in {'(' if self.lo_open else '['}{self.lo:g}, "
                    f"{self.hi:g}{')' if self.hi_open else ']'}")
        if self.lo is not None:
            return f"{name} {'>' if self.lo_open else '>='} {self.lo:g}"
        if self.hi is not None:
            return f"{name} {'<' if self.hi_open else '<='} {self.hi:g}"
        return f"any {name}"

    def describe(self, key: str) -> str:
        """The range and the reason for a limit key, e.g. ``"nu >= 0 (the engine's elasticity model)"``."""
        return self.expected(key.rpartition(".")[2]) + (f" ({self.why})" if self.why else "")

    def admits(self, value: float) -> bool:
        """True when ``value`` is finite and within the range."""
        v = float(value)
        if not math.isfinite(v):
            return False
        if self.lo is not None and not (v > self.lo if self.lo_open else v >= self.lo):
            return False
        return self.hi is None or (v < self.hi if self.hi_open else v <= self.hi)


def split_key(key: str) -> tuple[str | None, str]:
    """``(qualifier, field)`` of a limit key: ``"metal.yield_stress"`` -> ``("metal", "yield_stress")``.

    Raises
    ------
    ValueError
        A field that no material, boundary or setup value has, or a qualifier that is not a material
        name (for a material field) or a boundary kind (for a boundary field). The plugin author's
        mistake: raised when the :class:`~gasp_core.seam.engine.EngineInfo` is made.
    """
    qual, _, name = key.rpartition(".")
    qual = qual or None
    if name in MATERIAL_FIELDS:
        allowed, what = MATERIALS, "material"
    elif name in BOUNDARY_FIELDS:
        allowed, what = BOUNDARIES, "boundary kind"
    elif name in SETUP_FIELDS:
        allowed, what = frozenset(), "nothing"
    else:
        raise ValueError(f"limit {key!r}: unknown parameter {name!r}; expected a Material field "
                         f"{sorted(MATERIAL_FIELDS)}, a Boundary field {sorted(BOUNDARY_FIELDS)} or "
                         f"{sorted(SETUP_FIELDS)}")
    if qual is not None and qual not in allowed:
        raise ValueError(f"limit {key!r}: {qual!r} is not a {what}"
                         + (f" (one of {sorted(allowed)})" if allowed else f"; write {name!r} alone"))
    if what == "material" and qual is not None and name not in MATERIAL_KINDS[qual].keys:
        raise ValueError(f"limit {key!r}: material {qual!r} does not use {name!r}; it uses "
                         f"{list(MATERIAL_KINDS[qual].keys)}")
    return qual, name


def _values(setup: SimSetup, qual: str | None, name: str) -> Iterator[tuple[str, Any]]:
    """``(where, value)`` of every value a limit key names in ``setup``."""
    if name in SETUP_FIELDS:
        yield "", getattr(setup, name)
        return
    items: list[Material | Boundary] = setup.materials if name in MATERIAL_FIELDS else setup.boundaries
    for item in items:
        label = item.name if isinstance(item, Material) else item.kind
        if isinstance(item, Material) and name not in MATERIAL_KINDS[label].keys:
            continue   # a field this material does not use (a rigid body's nu): no engine reads it
        if qual is None or qual == label:
            yield f"{'material' if isinstance(item, Material) else 'boundary'} '{label}': ", getattr(item, name)


def check_limits(engine: str, limits: Mapping[str, Limit], setup: SimSetup) -> None:
    """The one check of an engine's declared limits against a setup.

    Parameters
    ----------
    engine : str
        Engine name, for the message.
    limits : mapping of str -> Limit
        :attr:`EngineInfo.limits`, keys as in this module's docstring.
    setup : SimSetup

    Raises
    ------
    SceneError
        ``engine 'NAME': material 'jelly': nu=-0.3; this engine takes nu >= 0 (the engine's
        elasticity)``: the first value outside its limit.
    """
    for key, limit in limits.items():
        qual, name = split_key(key)
        for where, value in _values(setup, qual, name):
            if not limit.admits(value):
                raise SceneError(f"engine '{engine}': {where}{name}={value!r}; this engine takes {limit.describe(key)}")


#: Largest finite value of each precision an engine may run at (``precision`` option / capability).
PRECISION_MAX = {"f32": 3.4028234663852886e38, "f64": 1.7976931348623157e308}


def precision_of(precisions: frozenset[str], options: Mapping[str, Any]) -> str:
    """The precision a run uses: the ``precision`` option, else the engine's only one, else the lower one."""
    p = options.get("precision")
    if isinstance(p, str) and p in PRECISION_MAX:
        return p
    return "f32" if "f32" in precisions or not precisions else sorted(precisions)[0]


def check_precision(engine: str, precision: str, setup: SimSetup) -> None:
    """Refuse material values whose products overflow the run's precision, before the engine casts them.

    A solver multiplies material values by each other and by state (mass x velocity, stress x volume),
    so each must stay below the square root of the precision's largest value: ``1.8e19`` in float32,
    ``1.3e154`` in float64. ``rho = 1e300`` is a float64 number but ``inf`` in float32, after which the
    run would fail and blame its time step. Checked: every numeric :class:`Material` field and the derived
    moduli ``mu``, ``lam``, ``K``.

    Raises
    ------
    SceneError
        ``engine 'NAME': material 'jelly': rho = 1e+300 is beyond precision 'f32': ...``, naming the limit.
    """
    top = math.sqrt(PRECISION_MAX.get(precision, PRECISION_MAX["f32"]))
    band = setup.crack_band if any(m.name == "brittle" for m in setup.materials) else None
    for i, m in enumerate(setup.materials):
        values = {f: getattr(m, f) for f in sorted(MATERIAL_FIELDS)}
        values.update(mu=m.mu, lam=m.lam, K=m.K)
        if m.name == "brittle":
            # the derived values the material table holds (issue 68: tensile_strength = 1e-300 gave
            # s_f = 2 E G_f / (f_t h) = inf in float32, NaN damage and a run that never broke)
            h = float(band[i])
            s_f = 2.0 * float(m.E) * float(m.fracture_energy) / (float(m.tensile_strength) * h)
            values[f"the softening stress 2 E fracture_energy / (tensile_strength h) at tensile_strength = "
                   f"{m.tensile_strength:g} Pa (h = {h:.3g} m)"] = s_f
            values[f"the snap-back limit tensile_strength^2 h / (2 E) at tensile_strength = "
                   f"{m.tensile_strength:g} Pa"] = m.snap_back_limit(h)
        for name, v in values.items():
            if isinstance(v, (int, float)) and not abs(v) <= top:
                raise SceneError(
                    f"engine '{engine}': material '{m.name}': {name} = {v:.3g} is beyond precision '{precision}': "
                    f"material values must stay below {top:.2g} (the square root of its largest number, "
                    f"{PRECISION_MAX.get(precision, PRECISION_MAX['f32']):.2g}, so that their products stay "
                    f"finite); use a realistic value" + _wider(precision, v))


def _wider(precision: str, v: float) -> str:
    """The end of :func:`check_precision`'s line: ``precision = "f64"`` where it holds ``v``, and where it does not,
    that it does not (issue 68: ``tensile_strength = 1e-300`` is beyond both)."""
    if precision != "f32":
        return ""
    if abs(v) <= math.sqrt(PRECISION_MAX["f64"]):
        return " or precision = \"f64\""
    return " (precision = \"f64\" does not hold it either)"

