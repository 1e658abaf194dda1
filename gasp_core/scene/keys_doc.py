"""``docs/scene_keys.md``, the key tables of a scene's ``material``, generated from the schema
(:mod:`gasp_core.seam.schema`) so that the documentation cannot drift from what the reader takes.

Write it with ``python -m gasp_core.scene.keys_doc [PATH]`` (default ``docs/scene_keys.md``, from the repository
root); ``tests/test_scene_schema.py`` checks that the file in the repository is what this module writes.
"""
from __future__ import annotations

import sys
from pathlib import Path

from gasp_core.mpm.fields import SOLID_FRICTION
from gasp_core.mpm.restitution import BOUNDARY_RESTITUTION, DEFAULT_RESTITUTION, SUBSTANCES
from gasp_core.seam.schema import (BODY_MODEL_DOCS, BODY_MODELS, DEFAULT_MATERIAL, FRICTION_KINDS, MATERIAL_KINDS,
                                   MATERIAL_PARAMS, MAX_FRICTION, RIGID_KINDS, body_keys)

HEADER = ("<!-- Generated from gasp_core/seam/schema.py by `python -m gasp_core.scene.keys_doc`; do not edit by hand "
          "(tests/test_scene_schema.py checks it). -->")


def _range(key: str) -> str:
    """The range of a material parameter in the table's words, e.g. ``"in (-1, 0.5)"``, ``"> 0"``."""
    return MATERIAL_PARAMS[key].range.removeprefix("a finite number").strip() or "any finite number"


def scene_keys_markdown() -> str:
    """The Markdown of ``docs/scene_keys.md``: which keys each material takes, and each key's default, range,
    unit and meaning, from :data:`~gasp_core.seam.schema.MATERIAL_KINDS` and
    :data:`~gasp_core.seam.schema.MATERIAL_PARAMS`; the ``model`` key's values from
    :data:`~gasp_core.seam.schema.BODY_MODELS` and :data:`~gasp_core.seam.schema.BODY_MODEL_DOCS`."""
    lines = [HEADER, "", "# Scene keys: `[object.material]`", "",
             f"`name` picks the material model (default `{DEFAULT_MATERIAL}`). A material takes only its own keys, "
             "besides `name`; any other key is an error naming the material and the keys it takes, e.g. "
             "`name = \"jelly\"` with `yield_stress` (a key of metal and plasticine). A key left out takes "
             "its default. Units are SI. An engine may accept a narrower range (`gasp engines` lists its "
             "limits).", "", "## Materials", "", "| `name` | model | keys (besides `name`) |", "|---|---|---|"]
    for name, kind in MATERIAL_KINDS.items():
        keys = kind.keys + body_keys(name)
        lines.append(f"| `{name}` | {kind.doc} | {', '.join(f'`{k}`' for k in keys)} |")
    lines += ["", "## Parameters", "", "| key | default | range | unit | meaning | used by |",
              "|---|---|---|---|---|---|"]
    for key, p in MATERIAL_PARAMS.items():
        users = [name for name, kind in MATERIAL_KINDS.items() if key in kind.keys]
        lines.append(f"| `{key}` | {p.default:g} | {_range(key)} | {p.unit or '-'} | {p.doc} | {', '.join(users)} |")
    lines += ["", "## `model`: how the body is simulated", "",
              f"Taken by {', '.join(f'`{k}`' for k in RIGID_KINDS)} (issue 40); default `{BODY_MODELS[0]}`.", "",
              "| `model` | what the engine does |", "|---|---|"]
    lines += [f"| `{m}` | {BODY_MODEL_DOCS[m]} |" for m in BODY_MODELS]
    lines += ["", "## `restitution`: the bounce on the rigid route", "",
              f"Taken by {', '.join(f'`{k}`' for k in RIGID_KINDS)} and by `[[boundary]]` `ground` and `walls` "
              "(issue 53, `docs/rigid.md`): a coefficient of restitution in [0, 1], or on a material a substance's "
              "name. Left out: a material takes the substance its `E` and `rho` fall in, else "
              f"{DEFAULT_RESTITUTION:g}; a boundary {BOUNDARY_RESTITUTION:g} (a hard floor). A rigid body bounces on "
              "a boundary with the product of the two (Bullet's rule). Elastic bodies bounce by their own "
              "vibration; the key does not act on them.", "",
              "| substance | restitution on a hard floor | `E` (Pa) | `rho` (kg/m^3) |", "|---|---|---|---|"]
    lines += [f"| `{n}` | {e:g} | {lo:g}-{hi:g} | {rl:g}-{rh:g} |" for n, (e, (lo, hi), (rl, rh)) in SUBSTANCES.items()]
    lines += ["", "## `friction`: Coulomb's coefficient against another body", "",
              f"Taken by {', '.join(f'`{k}`' for k in FRICTION_KINDS)} (issue 67 item 4, `docs/rigid.md` \"A block "
              f"on a block\"): a finite number in [0, {MAX_FRICTION:g}]. Two bodies slide on each other with the "
              "geometric mean of their two coefficients (Bullet's rule, `gasp_core.mpm.fields.combine_friction`); "
              f"left out, a body takes {SOLID_FRICTION:g} (jelly on jelly). Engines with the feature `body_friction` "
              "(`gasp engines`) read it. Sand's own coefficient is `tan(friction_angle)`: sand on a "
              "body that names a `friction` takes the mean of the two, on one that does not its own (each body its own "
              "pair where several beside the sand name different ones, and each sand its own angle where sands of "
              "several angles share a scene: the engines take both per grid node, `docs/contact.md` \"Round 42\", "
              "\"Round 43\"); snow and liquid slide freely. The key does not act on the ground, "
              "the walls or a collider: they take their own `friction`.", ""]
    from gasp_core.mpm.fracture_table import BRITTLE_SUBSTANCES, SUBSTANCE_KEYS
    lines += ["", "## `substance`: a brittle material at its handbook figures", "",
              f"Taken by `brittle` (issue 66, `docs/fracture.md` \"Stiff brittle bodies: fragments\"): fills "
              f"{', '.join(f'`{k}`' for k in SUBSTANCE_KEYS)} from the table below where the material leaves them out "
              "(`gasp_core/mpm/fracture_table.py`, its sources there). At these stiffnesses `model = \"auto\"` "
              "takes the rigid route, and an impact that breaks the body splits it into rigid fragments.", "",
              "| `substance` | `E` (Pa) | `nu` | `rho` (kg/m^3) | `tensile_strength` (Pa) "
              "| `fracture_energy` (J/m^2) |",
              "|---|---|---|---|---|---|"]
    lines += [f"| `{n}` | {r.E:g} | {r.nu:g} | {r.rho:g} | {r.tensile_strength:g} | {r.fracture_energy:g} |"
              for n, r in BRITTLE_SUBSTANCES.items()]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Write :func:`scene_keys_markdown` to ``argv[0]`` (default ``docs/scene_keys.md``)."""
    argv = sys.argv[1:] if argv is None else argv
    path = Path(argv[0] if argv else "docs/scene_keys.md")
    path.write_text(scene_keys_markdown(), encoding="utf-8")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
