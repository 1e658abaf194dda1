"""Property-based fuzzing of the PLY and scene readers (hypothesis).

Whatever bytes or TOML document they get, the readers either return a valid object or raise
:class:`~gasp_core.seam.engine.SceneError` (one line naming the file), never another exception type
and never a numpy RuntimeWarning. Bounded (``max_examples``) so the module runs in well under 60 s.
The last part (issue 21) sets one scene key at a time to a value at, or just beyond, each of its
limits and takes the scene through preparation and the build-time checks; its ``_slow`` twin
(``-m slow``) draws 10x as many examples.
"""
from __future__ import annotations

import importlib.util
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import DONUT, GUITAR, needs_package

hypothesis = needs_package("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from gasp_core.errors import GaspError, SceneError  # noqa: E402
from gasp_core.gs.gaussians import Gaussians  # noqa: E402
from gasp_core.gs.io import read_gaussians  # noqa: E402
from gasp_core.scene.spec import Scene, parse_scene  # noqa: E402

FUZZ = settings(max_examples=100, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _small_ply_bytes(path: Path, n: int) -> bytes:
    """The header and first ``n`` rows of a real binary PLY (a valid file, quick to mutate)."""
    from plyfile import PlyData, PlyElement
    import io
    ply = PlyData.read(str(path))
    els = []
    for el in ply.elements:
        rows = el.data[: max(1, -(-n // 256))] if el.name == "chunk" else el.data[:n]
        els.append(PlyElement.describe(rows, el.name))
    buf = io.BytesIO()
    PlyData(els, byte_order="<").write(buf)
    return buf.getvalue()


SEEDS = {"donut": _small_ply_bytes(DONUT, 40), "guitar": _small_ply_bytes(GUITAR, 40)}


def _read(tmp_path: Path, raw: bytes):
    path = tmp_path / "fuzz.ply"
    path.write_bytes(raw)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # numpy chatter is a failure too
        try:
            g = read_gaussians(path)
        except SceneError as e:
            assert str(e).startswith(str(path)) and "\n" not in str(e)
            return None
        except GaspError as e:    # bytes that look like .spz or .sog, and no gsply to read them
            assert importlib.util.find_spec("gsply") is None, e
            assert str(e).startswith(str(path)) and "\n" not in str(e) and '[formats]"' in str(e)
            return None
    assert isinstance(g, Gaussians)
    # an opacity logit of +-inf is alpha 1 or 0 (issue 19: splat-transform writes +inf); NaN is refused
    assert np.isfinite(g.means).all() and np.isfinite(g.scales).all() and not np.isnan(g.opacities).any()
    assert np.isfinite(g.sh_dc).all() and np.isfinite(g.sh_rest).all()
    return g


@st.composite
def mutated_ply(draw):
    """A small real PLY with 1-4 mutations; the ones that keep it parseable come first, since
    hypothesis favours the first choices (special floats on field boundaries, body bytes), then
    header edits (types, counts, list properties) and truncation."""
    raw = bytearray(SEEDS[draw(st.sampled_from(sorted(SEEDS)))])
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["float", "body", "float", "header", "truncate", "byte"]))
        if op == "float" and len(raw) >= end + 4:  # a special float32 on a field (all fields are 4 bytes)
            i = end + 4 * draw(st.integers(0, (len(raw) - end) // 4 - 1))
            v = draw(st.sampled_from([math.nan, math.inf, -math.inf, 1e38, -1e38, 1e20, 100.0, -0.0]))
            raw[i:i + 4] = np.float32(v).tobytes()
        elif op == "body" and len(raw) > end:
            raw[draw(st.integers(end, len(raw) - 1))] = draw(st.integers(0, 255))
        elif op == "byte" and raw:
            raw[draw(st.integers(0, len(raw) - 1))] = draw(st.integers(0, 255))
        elif op == "truncate":
            raw = raw[: draw(st.integers(0, len(raw)))]
            end = min(end, len(raw))
        elif op == "header" and b"end_header\n" in raw:  # replace one header line
            end = raw.index(b"end_header\n") + len(b"end_header\n")
            lines = raw[:end].split(b"\n")
            j = draw(st.integers(0, len(lines) - 1))
            lines[j] = draw(st.sampled_from([
                b"property uchar opacity", b"property list uchar float x", b"element vertex 0",
                b"element vertex 99999", b"property double opacity", b"format ascii 1.0",
                b"element chunk 7", b"property float packed_color", b"", lines[j][::-1]]))
            head = b"\n".join(lines)
            raw = bytearray(head) + raw[end:]
            end = len(head)
    return bytes(raw)


@FUZZ
@given(raw=mutated_ply())
def test_mutated_ply_reads_or_raises_scene_error(tmp_path, raw):
    _read(tmp_path, raw)


@FUZZ
@given(seed=st.sampled_from(sorted(SEEDS)), field=st.integers(0, 10_000),
       value=st.sampled_from([math.nan, math.inf, -math.inf, 1e38, -1e38, 1e20, 100.0, -100.0]))
def test_special_float_in_any_field(tmp_path, seed, field, value):
    """One float32 field (any row, any property) set to NaN, inf or a huge value: an error or finite."""
    raw = bytearray(SEEDS[seed])
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    i = end + 4 * (field % ((len(raw) - end) // 4))
    raw[i:i + 4] = np.float32(value).tobytes()
    _read(tmp_path, bytes(raw))


@FUZZ
@given(raw=st.binary(max_size=600))
def test_random_bytes_read_or_raise_scene_error(tmp_path, raw):
    _read(tmp_path, b"ply\n" + raw if raw[:1] == b"\x00" else raw)


# ----------------------------------------------------------------------------- scene documents

_scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=True),
                     st.text(max_size=8), st.sampled_from(["jelly", "ground", "fixed_region", "+z", "keep"]))
_values = st.recursive(_scalars.filter(lambda v: v is not None),
                       lambda inner: st.one_of(st.lists(inner, max_size=4),
                                               st.dictionaries(st.text(max_size=6), inner, max_size=4)),
                       max_leaves=8)
_keys = {
    "top": ["name", "frame_dt", "n_frames", "gravity", "output", "engine", "domain", "boundary", "object"],
    "engine": ["name", "options"], "domain": ["lo", "hi", "n_grid", "padding", "particles_per_cell"],
    "boundary": ["kind", "height", "friction", "lo", "hi"],
    "object": ["file", "up_axis", "scale", "recentre", "position", "velocity", "material", "fill", "alpha",
               "thickness", "min_opacity", "core_fraction", "dynamic_time"],
    "material": ["name", "E", "nu", "rho", "yield_stress", "friction_angle", "softening"],
}


def _table(kind, children=None):
    vals = st.one_of(_values, *(children or []))
    return st.dictionaries(st.sampled_from(_keys[kind] + ["typo"]), vals, max_size=6)


@st.composite
def scene_doc(draw):
    """A TOML-shaped dict near a valid scene: right keys, random values and types."""
    material = _table("material")
    obj = _table("object", [material]).map(lambda d: d if draw(st.booleans()) else {**d, "file": "donut.ply"})
    doc = draw(st.dictionaries(st.sampled_from(_keys["top"]), _values, max_size=5))
    if draw(st.booleans()):
        doc["engine"] = draw(st.one_of(_table("engine"), st.text(max_size=10), _values))
    if draw(st.booleans()):
        doc["domain"] = draw(_table("domain"))
    if draw(st.booleans()):
        doc["boundary"] = draw(st.lists(_table("boundary"), max_size=2))
    doc["object"] = draw(st.one_of(st.lists(obj, min_size=0, max_size=2), _values))
    return doc


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz_scene")
    (d / "donut.ply").symlink_to(DONUT)
    return d


@FUZZ
@given(doc=scene_doc())
def test_scene_documents_parse_or_raise_scene_error(scene_dir, doc):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            s = parse_scene(doc, scene_dir / "fuzz.toml")
        except SceneError as e:
            assert "\n" not in str(e)
            return
    # [engine] name may be left out (the command line's --engine names it then): EngineSpec.name None
    assert isinstance(s, Scene) and s.objects and (s.engine.name is None or isinstance(s.engine.name, str))
    assert all(isinstance(v, float) and math.isfinite(v) for o in s.objects for v in (*o.position, o.scale))
    assert isinstance(s.domain.n_grid, int) and isinstance(s.n_frames, int) and s.n_frames >= 1


@FUZZ
@given(text=st.text(max_size=300))
def test_scene_text_parses_or_raises_scene_error(tmp_path, text):
    """Arbitrary text through load_scene (TOML errors included) gives SceneError or a Scene."""
    from gasp_core.scene.spec import load_scene
    p = tmp_path / "s.toml"
    p.write_text(text, encoding="utf-8")
    try:
        load_scene(p)
    except SceneError as e:
        assert "\n" not in str(e).strip() or "not valid TOML" in str(e)


# ------------------------------------------------------------- scene values at each limit (issue 21)
# One key of a valid scene set to a value at, or just beyond, one of its limits (or a generic extreme:
# 0, negative, nan, inf, the largest TOML integer). Through load_scene, prepare_scene and the build-time
# checks (options, engine limits, precision): a prepared scene with finite points, or one SceneError line.
_EXTREMES = ["0", "-1", "nan", "inf", "-inf", "1e308", "9223372036854775807"]
LIMITS = {
    ("top", "frame_dt"): ["1e-300", "1e300", "1e-9"],
    ("top", "n_frames"): ["1", "1000000000"],
    ("top", "gravity"): ["[0.0, 0.0, -1e4]", "[0.0, 0.0, -1.0001e4]", "[nan, 0.0, 0.0]", "[0.0, 0.0]"],
    ("domain", "n_grid"): ["7", "8", "9", "1025", "16.5"],
    ("domain", "padding"): ["10.0", "10.001", "1e-9"],
    ("domain", "particles_per_cell"): ["1", "64", "65"],
    ("object", "scale"): ["1e-6", "9.9e-7", "1e6", "1.01e6", "1e-3"],
    ("object", "position"): ["[1e6, 0.0, 0.0]", "[1.0001e6, 0.0, 0.0]", "[-1e6, -1e6, -1e6]"],
    ("object", "velocity"): ["[1e4, 0.0, 0.0]", "[1.0001e4, 0.0, 0.0]"],
    ("object", "min_opacity"): ["1.0", "1.1", "-0.1"],
    ("object", "core_fraction"): ["1e-9", "1.0", "1.0001"],
    ("material", "E"): ["1e-300", "1.8e19", "1.9e19", "1e300"],
    ("material", "nu"): ["-1.0", "-0.999", "0.4999999", "0.5"],
    ("material", "rho"): ["1e-300", "1.8e19", "1e300"],
    ("boundary", "friction"): ["1e6", "-0.1"],
    ("boundary", "height"): ["1e6", "-1.0001e6", "0.2"],
}
_TABLE_LINE = {"top": "frame_dt = 0.0333333", "domain": "n_grid = 24", "object": 'up_axis = "+z"',
               "material": 'name = "jelly"', "boundary": 'kind = "ground"'}


@pytest.fixture(scope="module")
def limit_scene(tmp_path_factory):
    """A valid scene's text: every 64th Gaussian of the donut on warp_mpm, n_grid 16, a ground."""
    needs_package("gasp_warp_mpm")
    from gasp_core.gs.io import write_gaussians
    from gasp_testing import scene_text
    d = tmp_path_factory.mktemp("limits")
    g = read_gaussians(DONUT)
    ply = write_gaussians(d / "donut.ply", g.subset(np.arange(0, g.n, 64)))
    text = scene_text(ply, n_frames=2, n_grid=24, engine="warp_mpm", engine_options="{ }")
    return d, text


def _with_value(text: str, table: str, key: str, value: str) -> str:
    """``text`` with ``key = value`` in ``table`` (replacing the key's line when present)."""
    lines = text.splitlines()
    hit = [i for i, ln in enumerate(lines) if ln.split("=")[0].strip() == key]
    anchor = next(i for i, ln in enumerate(lines) if ln.strip() == _TABLE_LINE[table]) if not hit else None
    if table == "top" and not hit:
        return f"{key} = {value}\n{text}"
    if hit:
        lines[hit[0]] = f"{key} = {value}"
    else:
        lines.insert(anchor + 1, f"{key} = {value}")
    return "\n".join(lines) + "\n"


def _prepare_or_refuse(folder: Path, text: str) -> None:
    from gasp_core.errors import GaspError
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.limits import check_limits, check_precision, precision_of
    from gasp_core.seam.options import check_options
    (folder / "scene.toml").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        warnings.filterwarnings("ignore", message=".*enclose no volume")   # the fill's own warning, in words
        try:
            prep = prepare_scene(load_scene(folder / "scene.toml"))
            setup, info = prep.setup, prep.info
            setup.options = check_options(setup.options, info.options, info.name)
            check_limits(info.name, info.limits, setup)
            check_precision(info.name, precision_of(info.capabilities.precisions, setup.options), setup)
        except GaspError as e:
            assert "\n" not in str(e).strip() and str(e).strip(), str(e)
            return
    assert np.isfinite(setup.x).all() and np.isfinite(setup.v).all() and np.isfinite(setup.p_vol).all()
    assert (setup.p_vol >= 0).all() and setup.p_vol.sum() > 0
    inside = (setup.x >= setup.domain_lo) & (setup.x <= setup.domain_hi)
    assert inside.all(), "a prepared point starts outside the domain"


def _scene_limit_case(limit_scene, where, value):
    folder, text = limit_scene
    table, key = where
    _prepare_or_refuse(folder, _with_value(text, table, key, value))


_LIMIT_ARGS = dict(where=st.sampled_from(sorted(LIMITS)), value=st.data())


def _draw_limit(limit_scene, where, value):
    v = value.draw(st.sampled_from(LIMITS[where] + _EXTREMES))
    _scene_limit_case(limit_scene, where, v)


test_scene_value_at_each_limit = settings(FUZZ, max_examples=60)(given(**_LIMIT_ARGS)(_draw_limit))
test_scene_value_at_each_limit_slow = pytest.mark.slow(
    settings(FUZZ, max_examples=600)(given(**_LIMIT_ARGS)(_draw_limit)))


@pytest.mark.parametrize("where, value", [(w, v) for w, vs in sorted(LIMITS.items()) for v in vs],
                         ids=[f"{w[1]}={v}" for w, vs in sorted(LIMITS.items()) for v in vs])
def test_every_listed_limit_value(limit_scene, where, value):
    """Every value of :data:`LIMITS` once (the generator above draws them with the generic extremes)."""
    _scene_limit_case(limit_scene, where, value)


# ------------------------------------------------------------------ the slow tier: 10x the examples
def _slow_twin(test, **strategies):
    """``test`` (a hypothesis test of this module) again with 10x the examples, marked ``slow``."""
    return pytest.mark.slow(settings(FUZZ, max_examples=10 * FUZZ.max_examples)(given(**strategies)(test.hypothesis.inner_test)))


test_mutated_ply_slow = _slow_twin(test_mutated_ply_reads_or_raises_scene_error, raw=mutated_ply())
test_special_float_slow = _slow_twin(
    test_special_float_in_any_field, seed=st.sampled_from(sorted(SEEDS)), field=st.integers(0, 10_000),
    value=st.sampled_from([math.nan, math.inf, -math.inf, 1e38, -1e38, 1e20, 100.0, -100.0]))
test_random_bytes_slow = _slow_twin(test_random_bytes_read_or_raise_scene_error, raw=st.binary(max_size=600))
test_scene_documents_slow = _slow_twin(test_scene_documents_parse_or_raise_scene_error, doc=scene_doc())
test_scene_text_slow = _slow_twin(test_scene_text_parses_or_raises_scene_error, text=st.text(max_size=300))
