"""The parallel primitives of the GPU schedule (:mod:`gasp_taichi_mpm.schedule`), as Taichi funcs whose loops are
each parallel (call them at a kernel's top level: Taichi inlines a func, so its loops are the kernel's outermost).

- :class:`BoxCompaction`: lists, in node order, of the nodes of a box that pass an owner's test: a count per row
  (one thread a row of the box), an exclusive scan of the rows in each plane (one thread a plane), each plane's
  offset as the sum of the planes before it (one thread a plane), then the scatter (one thread a row). The lists are
  the ones a serial walk of the box in node order gives, entry for entry, on any device and thread count.
- :class:`SliceSums`: sums over slices ``part[t, r] -> out[r]`` for ``t < n`` as a fixed tree: groups of
  :data:`WIDTH` slices summed in slice order by one thread each, twice, then the remaining groups in order. No
  atomics: the same inputs give the same bits on any device and run.

Both replace loops that one thread walked (issue 65, ``../shared/design/gpu-first.md`` rows 1, 3, 4-7).
"""
import taichi as ti

#: Slices a thread sums at each level of :class:`SliceSums`.
WIDTH = 32
#: Points a slice of a per-body sum over points holds at least (:func:`slice_points`), and the most bytes its
#: slices' rows may take.
MIN_SLICE, SLICE_BYTES = 32, 64 << 20


def slice_points(n_points: int, n_cols: int) -> int:
    """Points a thread sums into its slice's row of ``n_cols`` float64 columns: :data:`MIN_SLICE`, more when the
    rows of ``n_points / slice`` slices would pass :data:`SLICE_BYTES` (the memory a bad value can ask for is
    bounded)."""
    return max(MIN_SLICE, -(-int(n_points) * int(n_cols) * 8 // SLICE_BYTES))


@ti.data_oriented
class BoxCompaction:
    """Node-order lists of a box's nodes that pass ``owner.listed(I, q)`` for list ``q``.

    Parameters
    ----------
    owner : data-oriented object
        Has ``@ti.func listed(I, q) -> bool`` (``q`` a static int below ``len(outputs)``) and
        ``@ti.func overflow(I, q)`` (called for a passing node past list ``q``'s capacity, which is left out).
    n_grid : int
        Nodes a side of the grid the boxes lie in.
    outputs : tuple of ti.Vector.field(3, ti.i32)
        The lists (their capacity is their length); :attr:`count` ``[q]`` the entries found (capped at none:
        entries past the capacity are counted and left out).
    """

    def __init__(self, owner, n_grid: int, outputs):
        self.owner = owner
        self.n_lists = len(outputs)
        self.out0 = outputs[0]
        self.out1 = outputs[1] if self.n_lists > 1 else outputs[0]
        ng, nl = int(n_grid), self.n_lists
        self.row = ti.field(ti.i32, shape=(ng * ng, nl))    # a row's count, then its offset within its plane
        self.plane = ti.field(ti.i32, shape=(ng, nl))       # a plane's count
        self.poff = ti.field(ti.i32, shape=(ng, nl))        # a plane's offset
        self.count = ti.field(ti.i32, shape=nl)

    @ti.func
    def _put(self, q: ti.template(), at, I):
        if ti.static(q == 0):
            if at < self.out0.shape[0]:
                self.out0[at] = I
            else:
                self.owner.overflow(I, q)
        else:
            if at < self.out1.shape[0]:
                self.out1[at] = I
            else:
                self.owner.overflow(I, q)

    @ti.func
    def run(self, lo, ext):
        """The lists of the box of nodes ``lo .. lo + ext - 1`` (``ext`` 0 on an axis: an empty box); x-major
        node order (the order of ``(i, j, k)`` loops)."""
        nl = ti.static(self.n_lists)
        for q in ti.static(range(nl)):
            self.count[q] = 0
        e1 = ext[1]
        e2 = ext[2]
        for r in range(ext[0] * e1):   # each row's count
            c = ti.Vector.zero(ti.i32, nl)
            for k in range(e2):
                I = lo + ti.Vector([r // e1, r % e1, k])
                for q in ti.static(range(nl)):
                    if self.owner.listed(I, q):
                        c[q] += 1
            for q in ti.static(range(nl)):
                self.row[r, q] = c[q]
        for i in range(ext[0]):   # the rows' offsets within their plane
            acc = ti.Vector.zero(ti.i32, nl)
            for j in range(e1):
                for q in ti.static(range(nl)):
                    c = self.row[i * e1 + j, q]
                    self.row[i * e1 + j, q] = acc[q]
                    acc[q] += c
            for q in ti.static(range(nl)):
                self.plane[i, q] = acc[q]
        for i in range(ext[0]):   # each plane's offset: the planes before it (a thread a plane, O(n_grid) each)
            acc = ti.Vector.zero(ti.i32, nl)
            for i2 in range(i):
                for q in ti.static(range(nl)):
                    acc[q] += self.plane[i2, q]
            for q in ti.static(range(nl)):
                self.poff[i, q] = acc[q]
                if i == ext[0] - 1:
                    self.count[q] = acc[q] + self.plane[i, q]
        for r in range(ext[0] * e1):   # the scatter, in node order within each row
            at = ti.Vector.zero(ti.i32, nl)
            for q in ti.static(range(nl)):
                at[q] = self.poff[r // e1, q] + self.row[r, q]
            for k in range(e2):
                I = lo + ti.Vector([r // e1, r % e1, k])
                for q in ti.static(range(nl)):
                    if self.owner.listed(I, q):
                        self._put(q, at[q], I)
                        at[q] += 1


@ti.data_oriented
class SliceSums:
    """Deterministic column sums over slices: ``out[r] = sum_t part[t, r]`` for ``t < n``, as a fixed tree.

    Parameters
    ----------
    n_slices : int
        Rows of :attr:`part` (the most slices a sum takes).
    n_cols : int
        Columns summed.
    dtype : taichi dtype
        Default ``ti.f64``.
    """

    def __init__(self, n_slices: int, n_cols: int, dtype=ti.f64):
        t, r = max(int(n_slices), 1), max(int(n_cols), 1)
        self.n_cols, self.dtype = r, dtype
        self.part = ti.field(dtype, shape=(t, r))
        self.l1 = ti.field(dtype, shape=(t // WIDTH + 1, r))
        self.l2 = ti.field(dtype, shape=(t // WIDTH ** 2 + 1, r))
        self.out = ti.field(dtype, shape=r)

    @ti.func
    def clear(self, n):
        """``part[:n]`` set to 0."""
        for t, r in ti.ndrange(n, self.n_cols):
            self.part[t, r] = 0

    @ti.func
    def _fold(self, src: ti.template(), dst: ti.template(), n):
        """``dst[g, r]`` = the sum of ``src[g W .. g W + W - 1, r]`` (below ``n``) in order, one thread a group;
        returns the groups."""
        groups = (n + WIDTH - 1) // WIDTH
        for g, r in ti.ndrange(groups, self.n_cols):
            s = ti.cast(0, self.dtype)
            for t in range(g * WIDTH, ti.min(g * WIDTH + WIDTH, n)):
                s += src[t, r]
            dst[g, r] = s
        return groups

    @ti.func
    def reduce(self, n):
        """``out[r] = sum_{t < n} part[t, r]``: groups of :data:`WIDTH` in order, twice, then the rest in order."""
        n1 = self._fold(self.part, self.l1, n)
        n2 = self._fold(self.l1, self.l2, n1)
        for r in range(self.n_cols):
            s = ti.cast(0, self.dtype)
            for g in range(n2):
                s += self.l2[g, r]
            self.out[r] = s


class GroupSums:
    """Deterministic column sums of in-order groups: the caller writes ``l1[g, r]``, the sum of items
    ``g W .. g W + W - 1`` in order (:data:`WIDTH` ``W``), one thread a group; :meth:`reduce` folds them as
    :meth:`SliceSums.reduce` folds its first level, so the sums are those bits, without a row per item.

    Parameters
    ----------
    n_items : int
        The most items a sum takes (``l1`` holds ``n_items // WIDTH + 1`` rows).
    n_cols : int
    dtype : taichi dtype
    """

    def __init__(self, n_items: int, n_cols: int, dtype=ti.f64):
        t, r = max(int(n_items), 1), max(int(n_cols), 1)
        self.n_cols, self.dtype = r, dtype
        self.l1 = ti.field(dtype, shape=(t // WIDTH + 1, r))
        self.l2 = ti.field(dtype, shape=(t // WIDTH ** 2 + 1, r))
        self.out = ti.field(dtype, shape=r)

    @ti.func
    def reduce(self, n1):
        """``out[r] = sum_{g < n1} l1[g, r]``: groups of :data:`WIDTH` in order, then the rest in order."""
        groups = (n1 + WIDTH - 1) // WIDTH
        for g, r in ti.ndrange(groups, self.n_cols):
            s = ti.cast(0, self.dtype)
            for t in range(g * WIDTH, ti.min(g * WIDTH + WIDTH, n1)):
                s += self.l1[t, r]
            self.l2[g, r] = s
        for r in range(self.n_cols):
            s = ti.cast(0, self.dtype)
            for g in range(groups):
                s += self.l2[g, r]
            self.out[r] = s
