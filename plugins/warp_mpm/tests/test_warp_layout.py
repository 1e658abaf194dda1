"""Issue 65's layout in warp_mpm (the reviewer's point, as ``plugins/taichi_mpm/tests/test_taichi_schedule.py``'s
``test_ordered_loops_only_in_the_cpu_only_module``): the cpu schedule's one-thread loops over points or nodes are in
one CPU-only module, ``gasp_warp_mpm/schedule/ordered.py``; the modules both schedules import hold none.

What is detected, by each ``.py`` file's syntax tree (docstrings and comments do not count), outside :data:`CPU_ONLY`:

- **a one-thread launch**: a ``wp.launch`` call whose ``dim`` (keyword or second argument) is the literal ``1`` (or a
  tuple of ones), or a call of a module's own launch helper (a function that passes one of its parameters to
  ``wp.launch`` as ``dim``, ``gpu_balance``'s ``rec``) with ``1`` for that parameter, whose kernel (the first argument,
  named by its last attribute, name or called builder: ``k.begin`` -> ``begin``) is not in :data:`DIM1_SCALAR`, the
  scalar control kernels that are one thread by nature on both schedules;
- **a serial loop in a kernel**: a ``for`` in the body of a ``@wp.kernel`` or ``@wp.func`` function whose iterator,
  as written (``ast.unparse``), has a bound other than integer literals and is not in :data:`LOOP_BOUNDS`, the
  counts known to be small (planes, colliders, forces, bodies, held boxes) or one block of ``BLOCK`` items. A loop
  over ``n_grid``, a node list's length (``counts[0]``), ``fr_nodes`` or the points is not there, so it fails.

Not detected: a ``dim`` that is a variable equal to 1 at run time (``test_warp_schedule.py``'s recorder checks every
launch of a gpu-schedule substep), a loop bound renamed to an allow-listed spelling.

Shown catching a broken tree (2026-11-28): ``build_ordered_viscosity``'s ``lists`` kernel copied back into
``viscosity.build_viscosity`` and ``wp.launch(k.lists, dim=1, ...)`` put back into ``ImplicitViscosity.solve``,
``test_no_ordered_loop_outside_the_cpu_only_module`` failed with::

    AssertionError: assert [('viscosity....ch of lists')] == []
      Left contains 4 more items, first extra item: ('viscosity.py', 62, 'loop in lists: range(ng)')

(the four: ``('viscosity.py', 62 | 63 | 64, 'loop in lists: range(ng)')``, ``('viscosity.py', 271, 'dim=1 launch
of lists')``), and passed again once reverted. On main's tree before the move (b60f49c) it names 14 places outside
the CPU-only module: ``viscosity.py``'s ``lists`` and ``dot`` loops and their four launches, ``balance.py``'s
``contact_fix`` loops and launch, and ``schedule/gpu.py``'s two ``self.g_cg[i]`` launches (scalar ``cg_begin`` and
``cg_beta``, launched by name since). :func:`test_the_layout_check_catches_each_kind_outside` keeps such a check in
the suite on modules written for it.
"""
import ast
import importlib.util
from pathlib import Path

#: The CPU-only modules: the only ones of warp_mpm that may hold a one-thread launch or loop over points or nodes.
CPU_ONLY = ("schedule/ordered.py",)

#: Kernels launched with ``dim=1`` outside :data:`CPU_ONLY`: scalar work, one thread by nature on both schedules.
DIM1_SCALAR = {
    "tick": "the time table's step counter (engine.py)",
    "begin": "the CG's first r.z kept, the done flag (viscosity.py; the cpu schedule's)",
    "step_alpha": "the CG's step length from two scalars (viscosity.py)",
    "step_beta": "the CG's beta and convergence from two scalars (viscosity.py; the cpu schedule's)",
    "cg_begin": "begin with the device-side loop condition (schedule/gpu.py)",
    "cg_beta": "step_beta with the device-side loop condition (schedule/gpu.py)",
    "fold_final": "the last fold of at most BLOCK block partials (schedule/gpu.py)",
    "build_rigid_pair": "the contact of one pair of rigid bodies, O(1) (rigid.py; taichi_mpm's ONE_ITEM)",
    "build_rigid_pairs": "round 62: the touching pairs of rigid bodies among three or more, SWEEPS (8) x n_on pair "
                         "updates; round 63: only the n_on touching slots the node kernel listed are visited (an "
                         "insertion sort of n_on, their clears), none of the n_bodies^2 table (rigid_pairs.py; "
                         "taichi_mpm's ONE_ITEM)",
    "islands": "round 81: the gpu schedule's islands of touching rigid bodies, integer work over the n_on listed "
               "pairs (union-find, the islands' lists; rigid_pairs.build_rigid_pairs_gpu; the sweeps run one thread "
               "an island)",
    "c_body": "round 63: the rigid body's V* from its field's sums, one body (rigid_collider.py; round 64: launched "
              "one thread a slot, dim rc_ns, the scene's rigid bodies)",
    "c_solve": "round 63: the body's 6 x 6 solve with its layer (Schur, two 3 x 3 inverses), one body "
               "(rigid_collider.py; round 64: one thread a slot)",
    "box_reset": "round 64: the field box's 12 bounds, this substep's moved to the last's (field_nodes.py; the grid "
                 "update's own box, grid_box.py)",
    "held_box": "round 65: the box's 6 bounds of this substep stretched to a domain edge they near, with held boxes "
                "(grid_box.py)",
    "c_coulomb": "round 63: Coulomb's scale of the layer's tangential impulse, one body (rigid_collider.py; round "
                 "64: one thread a slot; round 65: collider_pair.py's rc_coulomb, one thread a contact pair, dim "
                 "rc_ns * rc_ncol)",
}

_PLANES = "the ground and wall planes of a scene (a handful)"
_BLOCK = "one block of BLOCK (256) items, one thread a block (the gpu schedule's block sums)"
_ROWS = "a block partial's rows (bodies, supports) or columns (the balance's sums)"
#: Loop iterators allowed in a kernel or function outside :data:`CPU_ONLY`, as written, each with what it counts.
#: Round 92 (rigid_support.hollow_sums): the cells of a body's outer points within a round body's reach of its
#: contact in a hollow (its radius and 3 point spacings, cells of 4: about (2 R / 4 s + 3)^3, 125-350 on the 5 cm
#: ball at n_grid 32-48), read once a concave pair and substep by the pair's thread, not the body's all points.
_HOLLOW_CELLS = "round 92: the cells within a round body's reach in a hollow (rigid_support.hollow_sums)"
LOOP_BOUNDS = {
    "range(planes.shape[0])": _PLANES,
    "range(ground.shape[0])": _PLANES,
    "range(ground_z.shape[0])": _PLANES,
    "range(wall_mu.shape[0])": "the walls' faces",
    "range(n_pl)": "a rigid body's planes",
    "range(ex.n_col)": "the scene's colliders",
    "range(ex.n_force)": "the scene's forces",
    "range(m0, m0 + int(ex.forces[r + FR_MODE_COUNT]))": "a wind's modes",
    "range(ex.n_imp)": "the scene's impulses and held boxes",
    "range(fixed_lo.shape[0])": "the held (fixed) boxes",
    "range(n_bodies)": "the rigid bodies (one thread a point, rigid_hold)",
    "range(nb)": "the bodies (round 62: node_slot at a touching node; rigid_pairs' one thread)",
    "range(nd)": "a rigid body's support table's 268 directions (round 65: the pair laws' one thread)",
    "range(ns)": "the rigid collider's slots, the scene's rigid bodies (round 64: rigid_collider.owner at a shared "
                 "node, as node_slot's range(nb))",
    "range(sweeps)": "the pairs' sweeps, rigid_pairs.SWEEPS (8; round 62)",
    "range(bisect)": "round 83: a soft point's domain's bisections along a cylinder's axis, roll_contact.DOMAIN_BISECT "
                     "(48; roll_shape.domain_near, one thread a point)",
    "range(i0, i1 + 1)": _HOLLOW_CELLS,
    "range(j0, j1 + 1)": _HOLLOW_CELLS,
    "range(k0, k1 + 1)": _HOLLOW_CELLS,
    "range(hol.cstart[g], hol.cstart[g + 1])": "round 92: one cell's outer points (4 point spacings across: tens of "
                                               "points; rigid_support.hollow_sums)",
    "range(POWER)": "round 92: the plane fit's power steps, rigid_support.HOLLOW_POWER_STEPS (24)",
    "range(SAMPLES)": "round 94: the gap's samples along a cylinder's segment, rigid_fit.FOOT_SAMPLES (16; "
                      "rigid_support.side_foot)",
    "range(n_on)": "the touching pairs, as the node kernel listed them (round 62, 63; rigid_pairs' one thread)",
    "range(n_isl)": "the islands of touching rigid bodies, at most n_bodies (round 81, rigid_pairs' islands)",
    "range(isl_start[i], isl_start[i + 1])": "an island's touching pairs (round 81, rigid_pairs' sweep, one thread "
                                             "an island)",
    "range(SLOTS)": "a ground column's slots (share.SLOTS = 8; touch_share, one thread a column)",
    "range(m)": "the substeps since a passive point's last gather (g2p_passive, one thread a point)",
    "range(blk * BLK, wp.min(blk * BLK + BLK, counts[0]))": _BLOCK,
    "range(blk * BLK, wp.min(blk * BLK + BLK, part_in.shape[0]))": _BLOCK,
    "range(blk * BLK, wp.min(blk * BLK + BLK, n_pts))": _BLOCK,
    "range(blk * BLK, wp.min(blk * BLK + BLK, grid_fbody.shape[0]))": _BLOCK,
    "range(part_in.shape[0])": "at most BLOCK partials (fold_final, schedule.gpu.fold_chain)",
    "range(grid_vf.shape[0] / grid_sv.shape[0])": "a node's field channels (at most 4 parts, field_nodes.field_clear, "
                                                   "one thread a node)",
    "range(wp.tid() * run, wp.min(wp.tid() * run + run, n_on_grid))": "a thread's run of the shared nodes, "
    "ceil(n / threads) of field_nodes.field_shared's list (round 63, fields.field_contact)",
    "range(run)": "a thread's run of the field box's units, ceil(units / threads) (round 64, field_nodes.py: "
                  "field_shared, field_clear, field_old; pair_touch.py: flow_apply, gap_clear; grid.py: the grid "
                  "update, grid_box.py)",
    "range(first, first + unit_len(box, along))": "a unit of the field box: a row along z on the CPU (the box's z "
                                                  "extent, at most n_grid), a node on CUDA (round 64)",
    "range(part.shape[0])": "the blocks' partials, n / BLOCK, one thread a (row, column) (gpu_balance.fold_rows)",
    "range(psums.shape[1])": _ROWS,
    "range(psums.shape[2])": _ROWS,
    "range(pjs.shape[1])": _ROWS,
    "range(pjs.shape[2])": _ROWS,
    "range(part.shape[1])": _ROWS,
    "range(part.shape[2])": _ROWS,
}


def _name(expr) -> str:
    """A launched kernel's name as written: ``k.begin`` -> ``begin``, ``build_rigid_pair(Ft)`` ->
    ``build_rigid_pair``, ``self.g[1]`` -> ``g[...]``."""
    if isinstance(expr, ast.Attribute):
        return expr.attr
    if isinstance(expr, ast.Name):
        return expr.id
    if isinstance(expr, ast.Call):
        return _name(expr.func)
    if isinstance(expr, ast.Subscript):
        return _name(expr.value) + "[...]"
    return ast.unparse(expr)


def _is_one(expr) -> bool:
    if isinstance(expr, ast.Tuple):
        return bool(expr.elts) and all(_is_one(e) for e in expr.elts)
    return isinstance(expr, ast.Constant) and expr.value == 1


def _is_wp(call, attr: str) -> bool:
    f = call.func if isinstance(call, ast.Call) else call
    return isinstance(f, ast.Attribute) and f.attr == attr and isinstance(f.value, ast.Name) and f.value.id == "wp"


def _dim_arg(call, index: int, keyword: str):
    """The argument of ``call`` at position ``index`` or keyword ``keyword``, None without one."""
    for kw in call.keywords:
        if kw.arg == keyword:
            return kw.value
    return call.args[index] if len(call.args) > index else None


def _launch_helpers(tree) -> dict:
    """{name: (position, parameter)} of the module's functions that pass their parameter to ``wp.launch`` as dim."""
    helpers = {}
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef):
            continue
        params = [a.arg for a in fn.args.args]
        for call in ast.walk(fn):
            if isinstance(call, ast.Call) and _is_wp(call, "launch"):
                dim = _dim_arg(call, 1, "dim")
                if isinstance(dim, ast.Name) and dim.id in params:
                    helpers[fn.name] = (params.index(dim.id), dim.id)
    return helpers


def _is_kernel(fn) -> bool:
    return any(_is_wp(d, "kernel") or _is_wp(d, "func") for d in fn.decorator_list)


def _ordered_constructs(root) -> list:
    """[(path relative to root, line, what)] of every one-thread launch not in :data:`DIM1_SCALAR` and every kernel
    loop not in :data:`LOOP_BOUNDS` in the .py files under ``root`` (the module docstring says what counts)."""
    found = []
    for path in sorted(Path(root).rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        tree = ast.parse(path.read_text())
        helpers = _launch_helpers(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and node.args:
                if _is_wp(node, "launch"):
                    dim = _dim_arg(node, 1, "dim")
                elif isinstance(node.func, ast.Name) and node.func.id in helpers:
                    dim = _dim_arg(node, *helpers[node.func.id])
                else:
                    continue
                if dim is not None and _is_one(dim) and _name(node.args[0]) not in DIM1_SCALAR:
                    found.append((rel, node.lineno, f"dim=1 launch of {_name(node.args[0])}"))
            if isinstance(node, ast.FunctionDef) and _is_kernel(node):
                for loop in ast.walk(node):
                    if not isinstance(loop, ast.For):
                        continue
                    it = loop.iter
                    literal = isinstance(it, ast.Call) and _name(it.func) == "range" and \
                        all(isinstance(a, ast.Constant) for a in it.args)
                    if not literal and ast.unparse(it) not in LOOP_BOUNDS:
                        found.append((rel, loop.lineno, f"loop in {node.name}: {ast.unparse(it)}"))
    return sorted(found)


def _package() -> Path:
    """The folder of the gasp_warp_mpm on the path (found without importing it, so without Warp)."""
    return Path(importlib.util.find_spec("gasp_warp_mpm").origin).parent


def test_no_ordered_loop_outside_the_cpu_only_module():
    """No module of warp_mpm but :data:`CPU_ONLY` launches a kernel other than :data:`DIM1_SCALAR`'s on one thread
    or loops over a count outside :data:`LOOP_BOUNDS` in a kernel; the CPU-only module holds the viscous lists, the
    ordered dot and ``contact_fix`` (their launches and loops)."""
    found = _ordered_constructs(_package())
    assert [f for f in found if f[0] not in CPU_ONLY] == []
    inside = {what for rel, _, what in found if rel in CPU_ONLY}
    assert {"dim=1 launch of lists", "dim=1 launch of dot", "dim=1 launch of build_contact_fix",
            "loop in lists: range(wp.min(box[0], box[6]), wp.max(box[3], box[9]) + 1)",   # round 65: the box's rows
            "loop in dot: range(counts[0])", "loop in contact_fix: range(n)"} <= inside


def test_the_layout_check_catches_each_kind_outside(tmp_path):
    """The check sees an ordered launch (``wp.launch`` or a launch helper) and a kernel loop over the grid put back
    in a shared module, not in a docstring or comment, nor in the CPU-only module, nor a scalar kernel's launch."""
    (tmp_path / "schedule").mkdir()
    (tmp_path / "schedule" / "ordered.py").write_text(
        "@wp.kernel\ndef lists(ng: int):\n    for i in range(ng):\n        pass\n"
        "wp.launch(o.lists, dim=1, inputs=[])\n")
    (tmp_path / "viscosity.py").write_text(
        '"""wp.launch(k.lists, dim=1)"""\n# wp.launch(k.dot, dim=1)\n'
        "@wp.kernel(enable_backward=False)\ndef lists(ng: int, counts: wp.array(dtype=int)):\n"
        "    for i in range(ng):\n        for q in range(3):\n            pass\n"
        "    for t in range(counts[0]):\n        pass\n"
        "    for c in range(ex.n_col):\n        pass\n"
        "def solve(k, d):\n    wp.launch(k.lists, dim=1, device=d, inputs=[])\n"
        "    wp.launch(k.dot, 1, inputs=[])\n    wp.launch(k.begin, dim=1, inputs=[])\n"
        "    wp.launch(k.start, dim=n_nodes, inputs=[])\n")
    (tmp_path / "balance.py").write_text(
        "@wp.func\ndef fix(fr_nodes: wp.array(dtype=int)):\n    for q in range(fr_nodes[0]):\n        pass\n"
        "def launches(d):\n    def rec(kernel, dim, inputs):\n"
        "        return wp.launch(kernel, dim=dim, inputs=inputs)\n"
        "    return [rec(build_contact_fix(Ft), 1, []), rec(moments, n, []), rec(k.tick, 1, [])]\n")
    found = _ordered_constructs(tmp_path)
    want = [("balance.py", 3, "loop in fix: range(fr_nodes[0])"),
            ("balance.py", 8, "dim=1 launch of build_contact_fix"),
            ("viscosity.py", 5, "loop in lists: range(ng)"),
            ("viscosity.py", 8, "loop in lists: range(counts[0])"),
            ("viscosity.py", 13, "dim=1 launch of lists"), ("viscosity.py", 14, "dim=1 launch of dot")]
    assert [f for f in found if f[0] not in CPU_ONLY] == want
    assert len([f for f in found if f[0] in CPU_ONLY]) == 2
