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

Round 65: :func:`cache_kernel_sources`. Taichi reads a kernel's or ``ti.func``'s source again each time it turns it
into IR (``kernel_impl._get_tree_and_ctx``: ``inspect.getsourcefile`` and ``getsourcelines``, which tokenize the
function's block, and ``textwrap.fill`` on every line), for every kernel of every engine built (``ti.init`` each time)
and at every call site of a ``ti.func``, which Taichi inlines: 1,711 reads for the 70 kernels of a three-body collider
scene. A function's source does not change in a process, so its file, lines and first line number are read once per
code object and kept; the tree is parsed afresh each time (the transformer writes into it) and the rest of the context
is built as Taichi builds it. :func:`lighten_frontend` installs both.
"""
import ast
import textwrap

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


#: a function's code object -> (file, source lines as Taichi reads them, first line, the dedented text); keyed by the
#: code, which the closures of one ``def`` share (a plugin builds some kernels per engine), and which holds no closure
_SOURCES: dict = {}
#: Taichi's own ``kernel_impl._get_tree_and_ctx``, kept when :func:`cache_kernel_sources` replaces it (the tests run
#: both)
TAICHI_TREE_AND_CTX = None


def _source(func) -> tuple:
    """``(file, src, start_lineno, text)`` of ``func`` as ``kernel_impl._get_tree_and_ctx`` reads them, once per
    code object."""
    key = getattr(func, "__code__", func)
    got = _SOURCES.get(key)
    if got is None:
        from taichi.lang._wrap_inspect import getsourcefile, getsourcelines
        src, start = getsourcelines(func)
        src = [textwrap.fill(line, tabsize=4, width=9999) for line in src]
        got = _SOURCES[key] = (getsourcefile(func), src, start, textwrap.dedent("\n".join(src)))
    return got


def _tree_and_ctx(self, excluded_parameters=(), is_kernel=True, arg_features=None, args=None, ast_builder=None,
                  is_real_function=False):
    """``kernel_impl._get_tree_and_ctx`` of Taichi 1.7.4 with the source read once per function (module notes)."""
    from taichi.lang import kernel_impl
    from taichi.lang.ast import ASTTransformerContext
    file, src, start_lineno, text = _source(self.func)
    tree = ast.parse(text)
    tree.body[0].decorator_list = []
    global_vars = kernel_impl._get_global_vars(self.func)
    if is_kernel or is_real_function:   # template parameters into the globals, as Taichi does
        for i in self.template_slot_locations:
            global_vars[self.arguments[i].name] = args[i]
    return tree, ASTTransformerContext(excluded_parameters=excluded_parameters, is_kernel=is_kernel, func=self,
                                       arg_features=arg_features, global_vars=global_vars, argument_data=args,
                                       src=list(src), start_lineno=start_lineno, file=file, ast_builder=ast_builder,
                                       is_real_function=is_real_function)


def cache_kernel_sources() -> bool:
    """Install :func:`_tree_and_ctx` as Taichi's ``kernel_impl._get_tree_and_ctx``; True if installed (or already),
    False for a Taichi version not in :data:`VERSIONS` or without that function. Process-wide, idempotent."""
    import taichi
    from taichi.lang import kernel_impl
    global TAICHI_TREE_AND_CTX
    if tuple(taichi.__version__) not in VERSIONS or not hasattr(kernel_impl, "_get_tree_and_ctx"):
        return False
    if kernel_impl._get_tree_and_ctx is not _tree_and_ctx:
        TAICHI_TREE_AND_CTX = kernel_impl._get_tree_and_ctx
    kernel_impl._get_tree_and_ctx = _tree_and_ctx
    return True


def lighten_frontend() -> tuple[bool, bool]:
    """:func:`lighten_position_notes` and :func:`cache_kernel_sources` (what each returns), as the engine installs
    them before its kernels are first called."""
    return lighten_position_notes(), cache_kernel_sources()
