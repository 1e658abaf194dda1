"""warp_mpm's kernels are valid CUDA, checked without a GPU (``benchmarks/cuda_compile.py``: Warp's NVRTC compiles a
module ahead of time for an architecture with no device, ``warp.compile_aot_module``).

Known answers: a plain kernel compiles for sm_90; a kernel whose native snippet calls a function CUDA does not have
fails, and the check names its module (the catch). Slow tier: every kernel of the plugin (``warmup.all_kernels``,
both schedules) compiles for sm_90 in float32 (measured 2026-12-03, Warp 1.19.0: 0 failed, 81 s
under load 1.1; float64 too in the benchmark: 204 modules)."""
from __future__ import annotations

import sys

import pytest

from gasp_testing import ROOT

wp = pytest.importorskip("warp")
sys.path.insert(0, str(ROOT / "benchmarks"))
import cuda_compile as cc  # noqa: E402

ARCH = 90


@wp.func_native("return a_function_cuda_does_not_have(x);")
def _not_cuda(x: float) -> float:
    ...


@wp.kernel(enable_backward=False, module="unique")
def _doubles(a: wp.array(dtype=float)):
    i = wp.tid()
    a[i] = 2.0 * a[i]


@wp.kernel(enable_backward=False, module="unique")
def _calls_what_cuda_lacks(a: wp.array(dtype=float)):
    i = wp.tid()
    a[i] = _not_cuda(a[i])


def _needs_nvrtc():
    if wp.get_cuda_toolkit_version() is None:
        pytest.skip("this Warp build has no CUDA (a CPU-only build): it cannot compile for CUDA")


def test_a_plain_kernel_compiles_and_a_broken_one_is_named():
    _needs_nvrtc()
    good, bad = cc.compile_modules([_doubles.module, _calls_what_cuda_lacks.module], ARCH)
    assert good["error"] == "" and good["kernels"] == ["_doubles"], good
    assert bad["error"] and bad["module"] == _calls_what_cuda_lacks.module.name, bad


@pytest.mark.slow
def test_every_warp_mpm_kernel_compiles_for_sm_90(tmp_path):
    _needs_nvrtc()
    assert cc.main(["--precision", "f32", "--out", str(tmp_path)]) == 0, (tmp_path / "cuda_compile.md").read_text()
    import json
    rec = json.loads((tmp_path / "cuda_compile.json").read_text())
    assert rec["modules"] >= 100 and rec["not_reached"] == [], rec["not_reached"]
