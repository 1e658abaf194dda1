"""Property-based fuzzing of the readers of every splat format beside PLY (issue 34): ``.sog``, ``.spz``,
``.splat``, ``.ksplat``, ``.splatv`` (compressed PLY: ``tests/test_fuzz_readers.py``, its guitar seed).

Each strategy starts from a real file of the format (``examples/data``: train-1000 as splat-transform wrote
the ``.sog``, as gsply writes ``.spz``, as antimatter15's convert.py and GaussianSplats3D's SplatBuffer
write ``.splat`` and ``.ksplat``, the first 300 records of the bundled ``spinach_4.splatv``) and changes what the format's reader trusts: header counts and sizes,
``meta.json`` fields, codebooks, special floats in the records, the compressed stream itself, truncation.
Whatever it gets, the reader returns finite Gaussians or raises one :class:`SceneError` line naming the
file, never another exception and never a numpy RuntimeWarning. 25 examples per format by default (about
20 s); ``-m slow`` runs each again with 10x the examples.
"""
from __future__ import annotations

import gzip
import importlib.util
import io
import json
import math
import struct
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package
from formats_testing import write_ksplat, write_splat

hypothesis = needs_package("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from gasp_core.errors import SceneError  # noqa: E402
from gasp_core.gs.gaussians import Gaussians  # noqa: E402
from gasp_core.gs.io import read_gaussians  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
N = 25
FUZZ = settings(max_examples=N, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
SLOW = settings(FUZZ, max_examples=10 * N)

SPECIAL = [math.nan, math.inf, -math.inf, 1e38, -1e38, 1e20, -0.0, 0.0]
COUNTS = [0, 1, 2, 3, 4, 255, 256, 65535, 2**31 - 1, 2**31, 2**32 - 1]


def _seed(fmt: str) -> bytes:
    g = read_gaussians(DATA / "train-1000.ply").subset(np.arange(300))
    buf = io.BytesIO()
    if fmt == "splat":
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            write_splat(Path(d) / "t.splat", g)
            return (Path(d) / "t.splat").read_bytes()
    if fmt.startswith("ksplat"):
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            write_ksplat(Path(d) / "t.ksplat", g, level=int(fmt[-1]))
            return (Path(d) / "t.ksplat").read_bytes()
    if fmt == "spz":   # the decompressed stream of gsply's gzip .spz (version 3)
        import tempfile
        from gasp_core.gs.formats import write_splat_file
        with tempfile.TemporaryDirectory() as d:
            write_splat_file(Path(d) / "t.spz", g, "spz")
            return gzip.decompress((Path(d) / "t.spz").read_bytes())
    if fmt == "splatv":   # the bundled model's header and first 300 records of 64 bytes
        raw = (DATA / "spinach_4.splatv").read_bytes()
        return raw[:8 + struct.unpack_from("<I", raw, 4)[0] + 300 * 64]
    return (DATA / "train-1000.sog").read_bytes()


def _read(tmp_path: Path, raw: bytes, suffix: str):
    path = tmp_path / f"fuzz{suffix}"
    path.write_bytes(raw)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)   # numpy chatter is a failure too
        try:
            if suffix == ".splatv":   # a dynamic model: read, then evaluated as a scene does (psi(V, s))
                from gasp_core.gs.splatv import read_splatv, splatv_at
                g = splatv_at(*read_splatv(path), 0.5)
            else:
                g = read_gaussians(path)
        except SceneError as e:
            assert str(e).startswith(str(path)) and "\n" not in str(e), str(e)
            return None
    assert isinstance(g, Gaussians)   # n == 0 where the header counts none, as a PLY of 0 vertices (round 102)
    assert np.isfinite(g.means).all() and np.isfinite(g.scales).all() and not np.isnan(g.opacities).any()
    assert np.isfinite(g.sh_dc).all() and np.isfinite(g.sh_rest).all() and np.isfinite(g.rotations).all()
    return g


def _mutate_bytes(draw, raw: bytearray, fields: list[tuple[int, str]], body: int) -> bytearray:
    """1-4 edits: a header field (offset, struct format) set to a count, a special float32 in the body
    (4-byte aligned from ``body``), a random byte, or truncation."""
    for _ in range(draw(st.integers(1, 4))):   # sampled_from draws evenly; st.integers favours small values
        op = draw(st.sampled_from(["float", "field", "float", "byte", "truncate"]))
        if op == "field" and fields:
            off, fmt = draw(st.sampled_from(fields))
            if off + struct.calcsize(fmt) <= len(raw):
                big = (1 << (8 * struct.calcsize(fmt))) - 1
                struct.pack_into(fmt, raw, off, min(draw(st.sampled_from(COUNTS)), big))
        elif op == "float" and len(raw) >= body + 4:
            i = body + 4 * draw(st.sampled_from(range((len(raw) - body) // 4)))
            raw[i:i + 4] = np.float32(draw(st.sampled_from(SPECIAL))).tobytes()
        elif op == "byte" and raw:
            raw[draw(st.sampled_from(range(len(raw))))] = draw(st.integers(0, 255))
        elif op == "truncate":
            raw = raw[:draw(st.sampled_from(range(len(raw) + 1)))]
    return raw


FORMATS_EXTRA = 'the formats extra is not installed: python -m pip install -e ".[formats]"'
#: The .spz seed is written by gsply: without the formats extra there is none (and the spz cases skip).
SEEDS = {fmt: _seed(fmt) for fmt in ("splat", "ksplat0", "ksplat1", "spz", "sog", "splatv")
         if fmt != "spz" or importlib.util.find_spec("gsply") is not None}
_KSPLAT_FIELDS = [(4, "<I"), (16, "<I"), (20, "<H"), (36, "<f"), (40, "<f"),
                  *[(4096 + o, f) for o, f in ((0, "<I"), (4, "<I"), (8, "<I"), (12, "<I"), (16, "<f"), (20, "<H"),
                                               (24, "<I"), (32, "<I"), (36, "<I"), (40, "<H"), (5120, "<I"))]]
_SPZ_FIELDS = [(4, "<I"), (8, "<I"), (12, "B"), (13, "B"), (14, "B")]


@st.composite
def splat_file(draw):
    return bytes(_mutate_bytes(draw, bytearray(SEEDS["splat"]), [], 0))


@st.composite
def splatv_file(draw):
    """Edits to the magic, the header length and the records (float16 pairs included), or truncation."""
    raw = bytearray(SEEDS["splatv"])
    return bytes(_mutate_bytes(draw, raw, [(0, "<I"), (4, "<I")], 8 + struct.unpack_from("<I", raw, 4)[0]))


@st.composite
def ksplat_file(draw):
    raw = bytearray(SEEDS[draw(st.sampled_from(["ksplat0", "ksplat1"]))])
    return bytes(_mutate_bytes(draw, raw, _KSPLAT_FIELDS, 4096 + 1024))


@st.composite
def spz_file(draw):
    """gzip of the stream with edits to the header and records, or the gzip bytes themselves cut or changed."""
    raw = _mutate_bytes(draw, bytearray(SEEDS["spz"]), _SPZ_FIELDS, 16)
    if draw(st.booleans()):
        raw += b"\0" * draw(st.sampled_from([1, 2**20, 2**24]))       # more than the count needs
    packed = bytearray(gzip.compress(bytes(raw), 1))
    if draw(st.integers(0, 3)) == 0:
        packed = _mutate_bytes(draw, packed, [], 0)
    return bytes(packed)


_JSON = st.one_of(st.none(), st.booleans(), st.integers(-2**40, 2**40), st.floats(allow_nan=True),
                  st.text(max_size=6), st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=300),
                  st.lists(st.integers(-3, 3), max_size=4), st.sampled_from(["means_l.webp", "quats.webp"]))
_META_PATHS = [("count",), ("version",), ("means", "mins"), ("means", "maxs"), ("means", "files"),
               ("scales", "codebook"), ("sh0", "codebook"), ("quats", "files"), ("shN", "count"),
               ("shN", "bands"), ("shN", "codebook"), ("shN", "files"), ("scales",), ("shN",), ()]


@st.composite
def sog_file(draw):
    """The real bundle with 1-3 ``meta.json`` fields replaced, an image cut or changed, or the zip cut."""
    with zipfile.ZipFile(io.BytesIO(SEEDS["sog"])) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    meta = json.loads(entries["meta.json"])
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["meta", "meta", "image", "zip"]))
        if op == "meta":
            path = draw(st.sampled_from(_META_PATHS))
            value = draw(_JSON)
            if not path:
                meta = value
                continue
            node = meta
            for k in path[:-1]:
                node = node.get(k) if isinstance(node, dict) else None
            if isinstance(node, dict):
                node[path[-1]] = value
        elif op == "image":
            name = draw(st.sampled_from(sorted(n for n in entries if n.endswith(".webp"))))
            entries[name] = bytes(_mutate_bytes(draw, bytearray(entries[name]), [(4, "<I"), (26, "<I")], 20))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        for n, data in entries.items():
            z.writestr(n, json.dumps(meta) if n == "meta.json" else data)
    raw = bytearray(buf.getvalue())
    if draw(st.integers(0, 4)) == 0:
        raw = _mutate_bytes(draw, raw, [], 0)
    return bytes(raw)


CASES = {"splat": (splat_file, ".splat"), "ksplat": (ksplat_file, ".ksplat"), "spz": (spz_file, ".spz"),
         "sog": (sog_file, ".sog"), "splatv": (splatv_file, ".splatv")}


def _needs(fmt: str):
    if fmt in ("spz", "sog"):
        pytest.importorskip("gsply", reason=f"gsply: {FORMATS_EXTRA}")
    if fmt == "sog":
        pytest.importorskip("imagecodecs", reason=f"imagecodecs: {FORMATS_EXTRA}")


def _property(fmt: str, config):
    strategy, suffix = CASES[fmt]

    @config
    @given(raw=strategy())
    def run(tmp_path, raw):
        _read(tmp_path, raw, suffix)
    return run


@pytest.mark.parametrize("fmt", sorted(CASES))
def test_mutated_file_reads_or_raises_scene_error(tmp_path, fmt):
    _needs(fmt)
    _property(fmt, FUZZ)(tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("fmt", sorted(CASES))
def test_mutated_file_reads_or_raises_scene_error_slow(tmp_path, fmt):
    _needs(fmt)
    _property(fmt, SLOW)(tmp_path)


@pytest.mark.parametrize("fmt", sorted(CASES))
def test_the_seed_itself_reads(tmp_path, fmt):
    """The strategies start from files the readers take (else every example would be a refusal)."""
    _needs(fmt)
    raw = SEEDS["ksplat1" if fmt == "ksplat" else fmt]
    g = _read(tmp_path, gzip.compress(raw) if fmt == "spz" else raw, CASES[fmt][1])
    assert g is not None and g.n in (300, 1000)
