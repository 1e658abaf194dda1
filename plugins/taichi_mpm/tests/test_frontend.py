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
