"""The scene-wide tables of a scene file, ``[engine]``, ``[domain]`` and ``[[boundary]]``, and an object's
``material``: their data (:class:`EngineSpec`, :class:`DomainSpec`; ``Material`` and ``Boundary`` are
the seam's, :mod:`gasp_core.seam.setup`) and their checked readers. Every key is checked as
:mod:`gasp_core.scene.spec` says.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from gasp_core.errors import SceneError
from gasp_core.scene.values import (MAX_COORD, MAX_PADDING, N_GRID_RANGE, PPC_RANGE, as_integer, as_number, as_string,
                                    as_table, as_tables, as_vec3, bad_value, check_keys)
from gasp_core.seam.schema import (BODY_MODELS, DEFAULT_MATERIAL, MATERIAL_KINDS, MAX_FRICTION, RIGID_KINDS, body_keys,
                                   in_range)
from gasp_core.seam.setup import BOUNDARIES, Boundary, Material, MATERIALS


@dataclass
class EngineSpec:
    """``[engine]``: ``name`` (a registered engine; ``gasp engines`` lists them) and its ``options``.

    ``name`` may be left out when the command line names the engine (``--engine``).
    """

    name: str | None = None
    options: dict[str, Any] = field(default_factory=dict)


@dataclass
class DomainSpec:
    """``[domain]``: the simulation box (metres) and grid resolution.

    ``lo``/``hi`` default to the objects' bounds padded by ``padding`` times their largest
    extent (the ground, if any, at the bottom); with a ``select``ion, to what moves and where it can reach
    (:func:`gasp_core.prepare.around.reach_domain`, ``padding`` unused). ``particles_per_cell`` sets the interior fill
    spacing ``dx / ppc^(1/3)``.
    """

    lo: tuple[float, float, float] | None = None
    hi: tuple[float, float, float] | None = None
    n_grid: int = 64
    padding: float = 0.5
    particles_per_cell: int = 8


_MATERIAL_KEYS = {f.name for f in fields(Material)} | {"substance"}
_BOUNDARY_KEYS = {f.name for f in fields(Boundary)}
_BOUNDARY_KIND_KEYS = {"ground": {"kind", "height", "friction", "restitution"},
                       "walls": {"kind", "friction", "restitution"},
                       "fixed_region": {"kind", "lo", "hi"}}
_DOMAIN_KEYS = {f.name for f in fields(DomainSpec)}
_ENGINE_KEYS = {"name", "options"}


def read_material(value, where: str, src: Path) -> Material:
    """An object's ``material`` table: ``name`` (default :data:`~gasp_core.seam.schema.DEFAULT_MATERIAL`) picks
    the model, whose keys (:data:`~gasp_core.seam.schema.MATERIAL_KINDS`) are the only others it takes; each
    value is checked against its :data:`~gasp_core.seam.schema.MATERIAL_PARAMS` record.

    Raises
    ------
    SceneError
        One line: a bad ``name``; a key that no material has (``unknown key(s)``, as every table), or one
        that the chosen material does not use, naming the material, the materials that use it and the keys
        the chosen one takes; a value out of range (:meth:`Material.expected`'s words).
    """
    table = as_table(value, where, src)
    name = as_string(table.get("name", DEFAULT_MATERIAL), f"{where}.name", src, MATERIALS)
    check_keys(table, _MATERIAL_KEYS, where, src)
    table = _with_substance(table, name, where, src)
    uses = ("name",) + MATERIAL_KINDS[name].keys + body_keys(name)
    unused = sorted(set(table) - set(uses))
    if unused:
        others = sorted({m for k in unused for m, kind in MATERIAL_KINDS.items() if k in kind.keys + body_keys(m)})
        of = f" (a key of {', '.join(others)})" if others else ""
        why = ("; a flowing body's friction on another body is its own (sand: tan(friction_angle); snow and liquid "
               "slide freely)" if "friction" in unused else "")
        raise SceneError(f"{src}: {where}: material {name!r} does not use {unused}{of}; {name!r} takes "
                         f"{sorted(uses)}{why}")
    kw: dict[str, Any] = {"name": name}
    if "model" in table:
        kw["model"] = as_string(table["model"], f"{where}.model", src, BODY_MODELS)
    if "restitution" in table:
        kw["restitution"] = read_restitution(table["restitution"], f"{where}.restitution", src, substances=True)
    if "friction" in table:
        if not in_range(table["friction"], 0.0, MAX_FRICTION):
            bad_value(src, f"{where}.friction", table["friction"], "a Coulomb coefficient against another body: a "
                      f"finite number in [0, {MAX_FRICTION:g}] (docs/scene_keys.md)")
        kw["friction"] = float(table["friction"])
    for k in sorted(set(table) - {"name", "model", "restitution", "friction"}):
        expected = Material.expected(k, table[k])
        if expected is not None:
            bad_value(src, f"{where}.{k}", table[k], expected)
        kw[k] = float(table[k])
    if kw.get("tensile_strength", 0.0) >= 1e154:     # issue 68: 1e200 overflowed its snap-back limit (OverflowError)
        bad_value(src, f"{where}.tensile_strength", table["tensile_strength"], "a tensile strength whose snap-back "
                  "limit tensile_strength^2 h / (2 E) stays within float64 (below 1e154 Pa; concrete: about 3e6)")
    m = Material(**kw)
    try:   # what the keys allow together (round 99: a snow's stiffening past exp's range)
        m.check(where)
    except SceneError as e:
        raise SceneError(f"{src}: {e}") from None
    return m


def _with_substance(table: dict, name: str, where: str, src: Path) -> dict:
    """``table`` without its ``substance`` key, the handbook values of that substance filled in where the table
    gives none (``brittle`` only: :data:`gasp_core.mpm.fracture_table.BRITTLE_SUBSTANCES`), and its
    ``restitution`` the figure its ``E`` and ``rho`` take (``gasp_core.mpm.restitution.body_restitution``).

    Raises
    ------
    SceneError
        ``substance`` on another material, or a name not in the table (the names listed).
    """
    if "substance" not in table:
        return table
    from gasp_core.mpm.fracture_table import BRITTLE_SUBSTANCES, substance_values
    rest = {k: v for k, v in table.items() if k != "substance"}
    if name != "brittle":
        raise SceneError(f"{src}: {where}.substance is a key of the 'brittle' material only (its handbook E, rho, "
                         f"tensile_strength and fracture_energy); {name!r} does not take it")
    sub = as_string(table["substance"], f"{where}.substance", src, tuple(BRITTLE_SUBSTANCES))
    out = {**rest, **substance_values(sub, rest)}
    if "restitution" not in out:   # the bounce its E and rho give (what the engines would take), for its fragments
        from gasp_core.mpm.restitution import body_restitution
        out["restitution"] = body_restitution(Material(name="brittle", E=out["E"], rho=out["rho"]))
    return out


def read_engine(value, src: Path) -> EngineSpec:
    """``[engine] name = ..., options = {...}``, or the shorthand ``engine = "name"``."""
    if isinstance(value, str):
        value = {"name": value}
    elif not isinstance(value, dict):
        bad_value(src, "engine", value, 'an engine name (engine = "NAME") or an [engine] table with name and options')
    check_keys(value, _ENGINE_KEYS, "[engine]", src)
    name = value.get("name")
    name = None if name is None else as_string(name, "engine.name", src)
    options = as_table(value.get("options", {}), "engine.options", src)
    return EngineSpec(name=name, options=dict(options))


def read_domain(value, src: Path) -> DomainSpec:
    """``[domain]``: ``lo`` and ``hi`` both or neither (``hi > lo`` on every axis), ``n_grid``, ``padding``,
    ``particles_per_cell``."""
    dom_t = as_table(value, "domain", src)
    check_keys(dom_t, _DOMAIN_KEYS, "[domain]", src)
    domain = DomainSpec(
        lo=as_vec3(dom_t["lo"], "domain.lo", src, max_abs=MAX_COORD, unit=" m") if "lo" in dom_t else None,
        hi=as_vec3(dom_t["hi"], "domain.hi", src, max_abs=MAX_COORD, unit=" m") if "hi" in dom_t else None,
        n_grid=as_integer(dom_t.get("n_grid", DomainSpec.n_grid), "domain.n_grid", src, *N_GRID_RANGE),
        padding=as_number(dom_t.get("padding", DomainSpec.padding), "domain.padding", src, 0.0, MAX_PADDING),
        particles_per_cell=as_integer(dom_t.get("particles_per_cell", DomainSpec.particles_per_cell),
                                      "domain.particles_per_cell", src, *PPC_RANGE))
    if (domain.lo is None) != (domain.hi is None):
        raise SceneError(f"{src}: [domain] needs both 'lo' and 'hi', or neither")
    if domain.lo is not None and not all(h > l for l, h in zip(domain.lo, domain.hi)):
        raise SceneError(f"{src}: [domain] 'hi' must exceed 'lo' on every axis, got lo={list(domain.lo)} "
                         f"hi={list(domain.hi)}")
    return domain


def read_restitution(value, where: str, src: Path, substances: bool = False) -> float:
    """A ``restitution`` key: a number in [0, 1], or (``substances``, a material's) a name of
    :data:`gasp_core.mpm.restitution.SUBSTANCES`, taken as its figure.

    Raises
    ------
    SceneError
        Another value, naming the key, the value and what is expected.
    """
    from gasp_core.mpm.restitution import SUBSTANCES
    if substances and isinstance(value, str) and value in SUBSTANCES:
        return SUBSTANCES[value][0]
    if not in_range(value, 0.0, 1.0):
        names = f" or one of {', '.join(map(repr, SUBSTANCES))}" if substances else ""
        bad_value(src, where, value, f"a coefficient of restitution: a finite number in [0, 1]{names}")
    return float(value)


def read_boundary(b: dict, where: str, src: Path) -> Boundary:
    """One ``[[boundary]]``: the keys its ``kind`` takes; a ``fixed_region`` needs ``lo`` and ``hi`` with
    ``hi > lo``."""
    kind = as_string(b.get("kind"), f"{where}.kind", src, BOUNDARIES)
    check_keys(b, _BOUNDARY_KIND_KEYS.get(kind, _BOUNDARY_KEYS), f"{where} (kind = {kind!r})", src)
    kw: dict[str, Any] = {"kind": kind}
    if b.get("height") == "auto" and kind == "ground":    # the support in the scan: gasp_core.prepare.ground
        kw["height"] = "auto"
    elif "height" in b:
        kw["height"] = as_number(b["height"], f"{where}.height", src, -MAX_COORD, MAX_COORD)
    if "friction" in b:
        kw["friction"] = as_number(b["friction"], f"{where}.friction", src, 0.0)
    if "restitution" in b:
        kw["restitution"] = read_restitution(b["restitution"], f"{where}.restitution", src)
    if kind == "fixed_region":
        if "lo" not in b or "hi" not in b:
            raise SceneError(f"{src}: {where} (fixed_region) needs 'lo' and 'hi'")
        kw["lo"] = as_vec3(b["lo"], f"{where}.lo", src, max_abs=MAX_COORD, unit=" m")
        kw["hi"] = as_vec3(b["hi"], f"{where}.hi", src, max_abs=MAX_COORD, unit=" m")
        if not all(h > l for l, h in zip(kw["lo"], kw["hi"])):
            raise SceneError(f"{src}: {where} (fixed_region) 'hi' must exceed 'lo' on every axis, got "
                             f"lo={list(kw['lo'])} hi={list(kw['hi'])}; the box holds nothing")
    return Boundary(**kw)


def read_boundaries(data: dict, src: Path) -> list[Boundary]:
    """The scene's ``[[boundary]]`` tables (:func:`read_boundary` each), with at most one ``ground`` and one ``walls``
    (:class:`SceneError` naming both tables otherwise; round 99): the engines hold the points above the highest ground
    and inside one box of walls, so a lower ground or a second friction would be silently ignored, and the check that
    no point starts below the ground read the lowest plane."""
    boundaries = [read_boundary(b, f"[[boundary]] #{i + 1}", src)
                  for i, b in enumerate(as_tables(data.get("boundary", []), "boundary", src))]
    for kind, instead in (("ground", "a raised support (a step, a shelf) is a [[collider]]"),
                          ("walls", "give one [[boundary]] kind = \"walls\" with its friction")):
        at = [i + 1 for i, b in enumerate(boundaries) if b.kind == kind]
        if len(at) > 1:
            raise SceneError(f"{src}: [[boundary]] #{at[0]} and #{at[1]} are both kind = \"{kind}\"; a scene has "
                             f"one at most; {instead}")
    return boundaries
