"""Engine options: what a plugin declares (:class:`Option`) and the core's one check of a scene's values
against those declarations (:func:`check_options`, called by :func:`gasp_core.seam.build.build_engine`).

Engines only read ``setup.options``, completed with the declared defaults; they check none of them again.
"""
from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

import numpy as np

from gasp_core.errors import SceneError

#: Options that count CPU threads, by their conventional name: a value above this machine's cores is
#: capped at them with a warning (``threads = 100000`` made an engine start 100,000 threads, and other
#: processes could not fork meanwhile).
CPU_THREAD_OPTIONS = ("threads",)


_KINDS = {"int": "an integer", "number": "a number", "str": "a string", "bool": "true or false"}


@dataclass(frozen=True)
class Option:
    """One engine option, declared as data (``gasp engines`` lists them; the core checks them).

    Attributes
    ----------
    name : str
        Key in the scene's ``[engine] options`` table.
    default : Any
        Value when the scene does not give one. ``None`` means "the engine decides" and is
        always accepted.
    doc : str
        Meaning and unit, one line.
    kind : str
        ``"int"``, ``"number"`` (int or float, finite), ``"str"`` or ``"bool"``.
    choices : tuple, optional
        Allowed values (``kind="str"``).
    lo, hi : float, optional
        Inclusive bounds (``kind`` int or number); ``lo_open`` makes ``lo`` exclusive.
    pattern : str, optional
        A regular expression a string value must match in full (e.g. ``cuda(:\\d+)?``); used
        instead of ``choices``.
    excludes : tuple of str
        Options that may not be given together with this one (both not None), e.g. ``dt`` excludes
        ``n_substeps``: a rule across options, declared as data and checked by :func:`check_options`.
    """

    name: str
    default: Any
    doc: str
    kind: str = "number"
    choices: tuple | None = None
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    pattern: str | None = None
    excludes: tuple[str, ...] = ()

    def expected(self) -> str:
        """What a valid value is, in words."""
        if self.choices is not None:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        text = _KINDS[self.kind]
        if self.pattern is not None:
            text += f" matching {self.pattern!r}"
        if self.lo is not None and self.hi is not None:
            text += f" in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"
        elif self.lo is not None:
            text += f" {'>' if self.lo_open else '>='} {self.lo:g}"
        elif self.hi is not None:
            text += f" <= {self.hi:g}"
        return text

    def valid(self, value: Any) -> bool:
        """True when ``value`` is acceptable (``None`` always is)."""
        if value is None:
            return True
        if self.kind == "bool":
            return isinstance(value, bool)
        if self.kind == "str":
            if not isinstance(value, str):
                return False
            if self.pattern is not None:
                return re.fullmatch(self.pattern, value) is not None
            return self.choices is None or value in self.choices
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            return False
        if self.kind == "int" and not isinstance(value, (int, np.integer)):
            return False
        if not math.isfinite(value):
            return False
        if self.choices is not None and value not in self.choices:
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        return self.hi is None or value <= self.hi


def check_options(options: Mapping[str, Any], declared: Iterable[Option], engine: str) -> dict[str, Any]:
    """Every declared option's value: the scene's where given, else the default.

    Parameters
    ----------
    options : mapping
        The scene's ``[engine] options``.
    declared : iterable of Option
        :attr:`EngineInfo.options`.
    engine : str
        Engine name, for messages.

    Returns
    -------
    dict
        ``{name: value}`` for every declared option.

    Raises
    ------
    SceneError
        An unknown option (the message lists the declared ones), a value of the wrong type or
        out of range (the message names the option, the value and what is expected), or two options
        given together that one of them excludes (:attr:`Option.excludes`).

    Notes
    -----
    The only check of engine options: :func:`gasp_core.seam.build.build_engine` calls it before the
    factory, and an engine reads ``setup.options`` (every declared option present) without checking
    them again. It is idempotent: completed options pass unchanged.
    """
    by_name = {o.name: o for o in declared}
    if not isinstance(options, Mapping):
        raise SceneError(f"engine '{engine}': options must be a table like {{ name = value }}, "
                         f"got {options!r}")
    unknown = sorted(set(options) - set(by_name))
    if unknown:
        raise SceneError(f"engine '{engine}': unknown option(s) {unknown}; allowed: {sorted(by_name)}")
    merged = {name: o.default for name, o in by_name.items()}
    for name, value in options.items():
        if not by_name[name].valid(value):
            raise SceneError(f"engine '{engine}': option {name}={value!r}; expected {by_name[name].expected()}")
        merged[name] = _capped_threads(engine, name, value)
    for name, o in by_name.items():
        for other in o.excludes:
            if merged[name] is not None and merged.get(other) is not None:
                raise SceneError(f"engine '{engine}': give option {name} or option {other}, not both")
    return merged


def _capped_threads(engine: str, name: str, value: Any) -> Any:
    """``value``, or this machine's core count with a warning where ``name`` counts CPU threads beyond it."""
    cores = os.cpu_count() or 1
    if name in CPU_THREAD_OPTIONS and isinstance(value, (int, np.integer)) and not isinstance(value, bool) \
            and value > cores:
        warnings.warn(f"engine '{engine}': option {name} = {value} is more than this machine's {cores} CPU "
                      f"cores; using {name} = {cores}", stacklevel=3)
        return cores
    return value
