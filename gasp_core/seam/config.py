"""An engine's settings as one typed record (issue 51 item 2): a frozen dataclass whose fields are its options.

A plugin writes its settings once, as a dataclass (a typed, documented ``Config``, as some solver libraries do)::

    @dataclass(frozen=True)
    class MyConfig:
        cfl: float = option(0.4, "Courant number of the automatic substep", lo=0.0, hi=1.0, lo_open=True)
        threads: int | None = option(None, "CPU threads", kind="int", lo=1)
        PRESETS: ClassVar = {"draft": Preset({"cfl": 0.8}, measured="docs/speed_accuracy.md")}

and registers it with ``EngineInfo(config=MyConfig)``. Everything else follows from that class:

- :func:`config_options`: the :class:`~gasp_core.seam.options.Option` declarations (``EngineInfo.options``), so the
  core's one check (:func:`~gasp_core.seam.options.check_options`), ``gasp engines`` and the options table of
  ``docs/engine_options.md`` (:func:`options_markdown`, kept current by ``tests/test_config.py``) read the fields;
- :class:`Preset`: what a quality level (``quality = "draft" | "default" | "reference"``) sets among the engine's
  own options; the core gives a level's options to an engine only as the engine declares them;
- the engine reads ``Config(**setup.options)``: typed attributes instead of string keys.

``run.json``'s ``engine_options`` records the resolved settings (every field, defaults filled in).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Mapping

from gasp_core.seam.options import Option


def option(default: Any, doc: str, **declared: Any) -> Any:
    """A dataclass field that is also an engine option.

    Parameters
    ----------
    default : Any
        The option's default (``None``: the engine decides).
    doc : str
        Meaning and unit, one line (``gasp engines`` prints it).
    **declared
        ``kind``, ``choices``, ``lo``, ``hi``, ``lo_open``, ``pattern``, ``excludes``: as :class:`Option`.

    Returns
    -------
    dataclasses.Field
        With the option's declaration in its metadata (``metadata["option"]``).
    """
    return field(default=default, metadata={"option": dict(doc=doc, **declared)})


def from_option(declared: Option) -> Any:
    """A dataclass field for an :class:`Option` declared elsewhere (a gasp_core.mpm constant shared by engines)."""
    spec = {f.name: getattr(declared, f.name) for f in dataclasses.fields(Option) if f.name not in ("name", "default")}
    return field(default=declared.default, metadata={"option": spec})


def config_options(config: type) -> tuple[Option, ...]:
    """The options of a config class, one per field, in field order (base class fields first).

    Raises
    ------
    TypeError
        ``config`` is not a dataclass, or a field was not made by :func:`option` / :func:`from_option`.
    """
    if not dataclasses.is_dataclass(config):
        raise TypeError(f"{config!r} is not a dataclass")
    out = []
    for f in dataclasses.fields(config):
        spec = f.metadata.get("option")
        if spec is None:
            raise TypeError(f"{config.__name__}.{f.name}: not an option (declare it with gasp_core.seam.config.option)")
        out.append(Option(f.name, f.default, **spec))
    return tuple(out)


@dataclass(frozen=True)
class Preset:
    """What one quality level sets among an engine's options.

    Attributes
    ----------
    options : dict
        ``{option name: value}``; given to the engine where the scene does not set the option.
    measured : str
        Where the level's figures on this engine are (a docs page); ``""`` for values taken over unmeasured.
        ``gasp studio`` prefers engines whose studio level was measured.
    """

    options: Mapping[str, Any] = field(default_factory=dict)
    measured: str = ""


def config_presets(config: type) -> Mapping[str, Preset]:
    """The config class's ``PRESETS`` (``{level: Preset}``), or ``{}``."""
    return dict(getattr(config, "PRESETS", {}) or {})


def options_markdown(name: str, options: tuple[Option, ...], presets: Mapping[str, Preset]) -> str:
    """The options table of one engine for ``docs/engine_options.md``: name, default, accepted values, meaning, and
    a column per quality level (the value the level sets, blank where it sets none)."""
    levels = list(presets)
    head = "| option | default | accepted | " + " | ".join(f"`{lv}`" for lv in levels) + (" | " if levels else "") \
        + "meaning |"
    rule = "|" + "---|" * (4 + len(levels))
    rows = [f"## {name}", "", head, rule]
    for o in options:
        cells = [f"`{o.name}`", f"`{o.default!r}`", o.expected()]
        cells += [f"`{presets[lv].options[o.name]!r}`" if o.name in presets[lv].options else "" for lv in levels]
        rows.append("| " + " | ".join(cells + [o.doc.replace("|", "/")]) + " |")
    return "\n".join(rows) + "\n"
