"""Checked reading of TOML values: every scene value goes through one of these, so that a wrong type
or range is a :class:`~gasp_core.errors.SceneError` naming the file, the key, the value and what was
expected (never another exception, never a silent conversion)."""
from __future__ import annotations

import math
from dataclasses import MISSING, fields
from pathlib import Path
from typing import NoReturn

from gasp_core.errors import SceneError
from gasp_core.seam.schema import in_range, range_text

_TOML_TYPES = ((bool, "boolean"), (int, "integer"), (float, "float"), (str, "string"),
               (list, "array"), (dict, "table"))


def _shown(value) -> str:
    """``value`` as the message shows it: its repr (shortened) and its TOML type."""
    r = repr(value)
    if len(r) > 60:
        r = r[:57] + "..."
    kind = next((n for t, n in _TOML_TYPES if isinstance(value, t)), type(value).__name__)
    return f"{r} ({kind})"


def bad_value(src: Path, key: str, value, expected: str) -> NoReturn:
    """Raise the one-line :class:`SceneError` ``"<src>: <key> = <value> (<TOML type>); expected <expected>"``."""
    raise SceneError(f"{src}: {key} = {_shown(value)}; expected {expected}")


def check_keys(table: dict, allowed: set[str], where: str, src: Path) -> None:
    """Refuse keys of ``table`` not in ``allowed``: a :class:`SceneError` naming them, ``where`` and the
    allowed keys."""
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise SceneError(f"{src}: unknown key(s) {unknown} in {where}; allowed: {sorted(allowed)}")


def is_number(value) -> bool:
    """True for a TOML integer or float (a boolean is not a number here)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def as_table(value, key: str, src: Path) -> dict:
    """``value`` if it is a table (dict); else a :class:`SceneError` naming ``key``."""
    if not isinstance(value, dict):
        bad_value(src, key, value, "a table")
    return value


def as_tables(value, key: str, src: Path) -> list[dict]:
    """An array of tables (``[[key]]``); a single table is an error, not a one-element list."""
    if not isinstance(value, list) or not all(isinstance(t, dict) for t in value):
        bad_value(src, key, value, f"an array of tables ([[{key}]] sections)")
    return value


def as_string(value, key: str, src: Path, choices=None) -> str:
    """``value`` if it is a non-empty string, or one of ``choices`` when given; else a :class:`SceneError`."""
    if choices is not None:
        if not isinstance(value, str) or value not in choices:
            bad_value(src, key, value, f"one of {sorted(choices) if isinstance(choices, (set, frozenset)) else list(choices)}")
    elif not isinstance(value, str) or not value:
        bad_value(src, key, value, "a non-empty string")
    return value


def as_boolean(value, key: str, src: Path) -> bool:
    """``value`` if it is ``true`` or ``false`` (not 0/1, not a string); else a :class:`SceneError`."""
    if not isinstance(value, bool):
        bad_value(src, key, value, "true or false")
    return value


def as_number(value, key: str, src: Path, lo: float | None = None, hi: float | None = None,
              lo_open: bool = False, hi_open: bool = False) -> float:
    """A finite float or integer (never a boolean) in the range given, as ``float``; else a :class:`SceneError`."""
    if not in_range(value, lo, hi, lo_open, hi_open):
        bad_value(src, key, value, range_text(lo, hi, lo_open, hi_open))
    return float(value)


def as_integer(value, key: str, src: Path, lo: int, hi: int | None = None) -> int:
    """An integer (not a float such as 24.9 or 24.0, not a boolean) in ``[lo, hi]``; else a :class:`SceneError`."""
    if not isinstance(value, int) or isinstance(value, bool) or value < lo or (hi is not None and value > hi):
        bad_value(src, key, value, f"an integer in [{lo}, {hi}]" if hi is not None else f"an integer >= {lo}")
    return value


def as_vec3(value, key: str, src: Path, max_abs: float | None = None, max_norm: float | None = None,
            unit: str = "") -> tuple[float, float, float]:
    """A list of 3 finite numbers; each ``|component| <= max_abs`` and the length ``<= max_norm``; else a
    :class:`SceneError`. Returns a tuple of 3 floats."""
    if not isinstance(value, list) or len(value) != 3 or \
            not all(is_number(a) and math.isfinite(a) for a in value):
        bad_value(src, key, value, "a list of 3 finite numbers")
    v = tuple(float(a) for a in value)
    if max_abs is not None and max(abs(a) for a in v) > max_abs:
        bad_value(src, key, value, f"every component within +-{max_abs:g}{unit}")
    if max_norm is not None and math.sqrt(sum(a * a for a in v)) > max_norm:
        bad_value(src, key, value, f"a length of at most {max_norm:g}{unit}")
    return v


# --------------------------------------------------------------------------- limits of scene values
UP_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
#: Largest ``|coordinate|`` (metres) anything may be placed at: object positions, domain and
#: fixed-region corners, ground height, and every Gaussian after placement. Engines compute in
#: float32, whose spacing at 1e6 m is 6 cm; beyond it no object of everyday size is resolved.
MAX_COORD = 1e6
#: Largest initial angular speed ``|angular_velocity|``, rad/s (a fast turbine).
MAX_SPIN = 1e4
#: Largest initial speed ``|velocity|``, m/s (ten times a rifle bullet).
MAX_SPEED = 1e4
#: Largest ``|gravity|``, m/s^2 (about 1000 g).
MAX_GRAVITY = 1e4
#: ``scale`` (metres per file unit) range: micrometres to thousands of kilometres.
SCALE_RANGE = (1e-6, 1e6)
#: Largest ``[domain] padding`` (times the objects' extent on each side): beyond it the objects
#: span fewer than ``n_grid / 21`` cells.
MAX_PADDING = 10.0
#: The least ``[[object]] alpha``, the control rule's stretch bound (paper Eq. alpha_rule; its Table 4 ablates 1 to
#: 5): below 1 the rule shrinks every Gaussian at rest, from frame 0 (round 100: 0.5 halved them all, unsaid).
ALPHA_MIN = 1.0
#: ``[domain] n_grid`` and ``particles_per_cell`` ranges (integers).
N_GRID_RANGE = (8, 1024)
PPC_RANGE = (1, 64)


def resolve_path(src: Path, name: str, key: str) -> Path:
    """``name`` (a scene value) resolved against the scene file's folder; a symlink loop or a name the system
    cannot take is one :class:`SceneError` line naming ``key`` (``Path.resolve`` raises ``RuntimeError``
    for a loop)."""
    try:
        return (src.parent / name).resolve()
    except (RuntimeError, OSError, ValueError) as e:
        raise SceneError(f"{src}: {key} '{name}' cannot be followed ({e}); expected a file, not a symlink loop") \
            from None


def default_of(cls, key: str):
    """The default that dataclass ``cls`` declares for its field ``key`` (the one place it is written)."""
    f = next(f for f in fields(cls) if f.name == key)
    return f.default_factory() if f.default is MISSING else f.default


def read_key(table: dict, key: str, read, *args, default_from, where: str, src: Path, **kw):
    """``read(table[key], "<where>.<key>", src, *args, **kw)`` (one of the ``as_*`` readers above), or, when the
    table leaves ``key`` out, the default that the dataclass ``default_from`` declares for it (:func:`default_of`).
    ``where`` ``""`` names the key alone (the top level)."""
    if key not in table:
        return default_of(default_from, key)
    return read(table[key], f"{where}.{key}" if where else key, src, *args, **kw)
