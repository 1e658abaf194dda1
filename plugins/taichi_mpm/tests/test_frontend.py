"""Taichi's frontend with the lighter position note (``gasp_taichi_mpm.frontend``): installed by the engine on the
Taichi version it was measured on, and a kernel's error still names the file, the line, the kernel and its source."""
import inspect

import pytest

pytest.importorskip("taichi")

import taichi as ti  # noqa: E402
from taichi.lang.ast import ast_transformer_utils as utils  # noqa: E402

from gasp_taichi_mpm import frontend  # noqa: E402

from test_taichi_mpm import block_setup, build  # noqa: E402

MEASURED = tuple(ti.__version__) in frontend.VERSIONS


@ti.kernel
def _uses_an_undefined_name() -> ti.i32:
    return undefined_in_this_kernel + 1  # noqa: F821


@pytest.mark.skipif(not MEASURED, reason=f"Taichi {ti.__version__}: the note is left as Taichi makes it")
def test_the_engine_installs_the_lighter_note_and_errors_still_say_where():
    build(block_setup())
    assert utils.ASTTransformerContext.get_pos_info is frontend._position_note
    line = inspect.getsourcelines(_uses_an_undefined_name)[1] + 2
    with pytest.raises(Exception) as err:
        _uses_an_undefined_name()
    msg = str(err.value)
    assert f'test_frontend.py", line {line}, in _uses_an_undefined_name:' in msg
    assert "return undefined_in_this_kernel + 1" in msg and "undefined_in_this_kernel" in msg.splitlines()[-1]


def test_an_unmeasured_taichi_version_is_left_alone(monkeypatch):
    original = utils.ASTTransformerContext.get_pos_info
    monkeypatch.setattr(frontend, "VERSIONS", {(0, 0, 1)})
    monkeypatch.setattr(utils.ASTTransformerContext, "get_pos_info", original)
    assert frontend.lighten_position_notes() is False
    assert utils.ASTTransformerContext.get_pos_info is original


@pytest.mark.skipif(not MEASURED, reason=f"Taichi {ti.__version__}: the frontend is left as Taichi makes it")
def test_sources_read_once_give_the_same_run(monkeypatch):
    """Round 65's cache of each function's source (``cache_kernel_sources``): the engine installs it, it holds one
    entry per code object with the text Taichi would read, and a run with it is bit for bit the run without it."""
    from taichi.lang import kernel_impl
    setup = block_setup()
    e = build(setup)
    assert kernel_impl._get_tree_and_ctx is frontend._tree_and_ctx and frontend.TAICHI_TREE_AND_CTX is not None
    for _ in range(2):
        e.step_frame()
    cached = e.positions().copy()
    some = next(iter(frontend._SOURCES))
    assert isinstance(some, type(_uses_an_undefined_name.__code__))
    monkeypatch.setattr(frontend, "cache_kernel_sources", lambda: False)
    monkeypatch.setattr(kernel_impl, "_get_tree_and_ctx", frontend.TAICHI_TREE_AND_CTX)
    e = build(setup)
    for _ in range(2):
        e.step_frame()
    assert (e.positions() == cached).all()


def test_one_entry_per_code_object():
    """Two closures of one ``def`` share their source entry; the text is ``inspect``'s, dedented."""
    def make(k):
        def f(x):
            return x + k
        return f
    a, b = make(1), make(2)
    assert frontend._source(a) is frontend._source(b)
    assert frontend._source(a)[3].startswith("def f(x):") and frontend._source(a)[2] == inspect.getsourcelines(a)[1]
