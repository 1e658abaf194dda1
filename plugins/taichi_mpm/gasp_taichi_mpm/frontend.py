"""A lighter position note in Taichi's kernel frontend (issue 39: the first frame's kernel load).

Taichi 1.7 turns each kernel's Python AST into its IR at the kernel's first call, even when the compiled kernel
then comes from the offline cache. For every AST node it formats, in advance, the note an error at that node would
print (``ASTTransformerContext.get_pos_info``: the file, the line, and the source lines under a caret line, each
run through ``textwrap``), although no error follows on a working kernel. On the README donut that formatting was
148,000 ``textwrap`` calls and about 1.1 s of frame 1's 2.9 s of kernel loading (measured: frame 1 3.25 s with
the lighter note against 4.3 s, frame 2 unchanged; docs/performance.md, "The first frame's kernel load").

:func:`lighten_position_notes` replaces that method, for the Taichi versions where it was measured
(:data:`VERSIONS`), by one that gives the same first line (``File "...", line N, in kernel:``) and the node's first
source line, without the caret line and the wrapping. Errors still name the file, line and kernel. Other Taichi
versions are left alone.
"""
#: Taichi versions whose ``ASTTransformerContext.get_pos_info`` was read and measured here.
VERSIONS = {(1, 7, 4)}


def _position_note(self, node) -> str:
    """The file, line and kernel of ``node``, and its first source line (``ASTTransformerContext.get_pos_info``'s
    first two parts)."""
    line = node.lineno - 1
    source = self.src[line] if 0 <= line < len(self.src) else ""
    return f'File "{self.file}", line {node.lineno + self.lineno_offset}, in {self.func.func.__name__}:\n{source}\n'


def lighten_position_notes() -> bool:
    """Install :func:`_position_note` as Taichi's ``get_pos_info``; True if installed (or already), False for a
    Taichi version not in :data:`VERSIONS` or without that method. Process-wide, idempotent."""
    import taichi
    from taichi.lang.ast import ast_transformer_utils as utils
    ctx = getattr(utils, "ASTTransformerContext", None)
    if tuple(taichi.__version__) not in VERSIONS or ctx is None or not hasattr(ctx, "get_pos_info"):
        return False
    ctx.get_pos_info = _position_note
    return True
