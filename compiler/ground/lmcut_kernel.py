"""LM-cut compiled by numba: :mod:`tmpc.compiler.ground.lmcut`'s algorithm over integer arrays.

The A* engine evaluates LM-cut on every state it generates, and in the Python version that is
most of the search's time. This module runs the same
steps (bucket h_max exploration, goal plateau, cut, incremental decrease, reuse of the parent's
landmarks) in one compiled call per state. It computes the *same* values as the Python version:
supporters are chosen in the same order (last precondition reached; the first highest one after
a decrease), the buckets and the decrease's heap are read in the same order, so the cuts are the
same sets (a test holds them equal on sampled states of the fixtures).

Only for integral costs (the bucket queue); :class:`~tmpc.compiler.ground.lmcut.LMCut` keeps the
Python version for non-integral costs and for the SAT planner's bound, which needs a deadline.

The task is one ``int32`` array (:func:`pack`): a header of offsets, then the CSR lists of
preconditions, effects, the operators each fact is a precondition of and the operators adding
each fact. Landmarks travel packed in one ``int32`` array (A* keeps one per open state),
``[h, n, (cost, k, op_1..op_k) * n]``
(``h = -1`` for a relaxed dead end), so one call takes and returns one array each. Every
per-call array is a view of one workspace allocated per task (:func:`workspace`) and never
reassigned inside a loop, and the helpers are inlined: numba counts references of arrays that
cross a call or are rebound in a loop, which costs time in the inner loops. A region a task does
not bound (supporter lists, buckets, heap, output) that overflows makes the call answer ``[-2]``,
and the caller retries with a workspace twice as large.

numba caches the machine code under ``$NUMBA_CACHE_DIR`` (tmpc's cache folder by default:
:mod:`tmpc.compiler.numbacfg`), so the compilation (seconds of CPU) is paid once per
machine; a process then only loads it (numba's import included). This module is imported
only where LM-cut runs in A*: ``tmpc --help`` and ``tmpc check`` do not load numba.
"""

from __future__ import annotations

import numpy as np

from tmpc.compiler.numbacfg import numba

#: h_max of an unreached fact
UNREACHED = np.int64(1) << 60
#: header fields of the packed task
N_FACTS, TRUE, GOAL, PRE, EFF, PRE_OF, EFF_OF, HEADER = 0, 1, 2, 3, 5, 7, 9, 11


def load() -> None:
    """Compile the kernel (the first time on a machine) or load it from numba's cache, by one
    call on a two-fact task with the argument types
    :meth:`tmpc.compiler.ground.lmcut.LMCut.packed` uses."""
    task = pack([(0,)], [(1,)], [[0], []], [[], [0]], 2, 0, 1)
    sizes = workspace_sizes(task, 1, 1)
    lmcut(task, np.zeros(1, np.int64), b"", np.zeros(2, np.int32), -1,
          workspace(task, 1, sizes), sizes)


def prepare(t, scale: int) -> tuple:
    """What :meth:`tmpc.compiler.ground.lmcut.LMCut.packed` passes for the relaxed task ``t`` (a
    :class:`~tmpc.compiler.ground.lmcut.RelaxedTask` with integral costs): the kernel, the packed
    task, the costs, the relevant-fact mask, the state's byte length, the empty parent, the
    workspace and its sizes (``scale`` times the defaults)."""
    # the decrease's heap keys are h * n_facts + fact, and h is at most the sum of the costs
    assert (sum(t.cost) + 1) * t.n_facts < 2**62, "action costs too large for the kernel"
    assert sum(t.cost) < 2**31, "action costs too large for int32 landmarks"
    task = pack(t.pre, t.eff, t.pre_of, t.eff_of, t.n_facts, t.true_fact, t.goal_fact)
    sizes = workspace_sizes(task, len(t.pre), scale)
    return (lmcut, task, np.array(t.cost, np.int64), t.relevant_mask, (t.true_fact + 7) // 8,
            np.zeros(2, np.int32), workspace(task, len(t.pre), sizes), sizes)


def pack(pre, eff, pre_of, eff_of, n_facts: int, true_fact: int, goal_fact: int) -> np.ndarray:
    """The task as one int32 array: the header, then four CSR lists (offsets ``n + 1``,
    indices), each named in the header by the positions of its offsets and its indices."""
    parts: list[np.ndarray] = []
    header = [n_facts, true_fact, goal_fact]
    pos = HEADER
    for lists in (pre, eff, pre_of, eff_of):
        offsets = np.zeros(len(lists) + 1, np.int64)
        offsets[1:] = np.cumsum([len(x) for x in lists])
        flat = np.fromiter((v for x in lists for v in x), np.int64, int(offsets[-1]))
        header += [pos, pos + len(offsets)]
        parts += [offsets, flat]
        pos += len(offsets) + len(flat)
    out = np.concatenate([np.array(header, np.int64), *parts])
    assert out.max(initial=0) < 2**31, "task too large for int32 offsets"
    return out.astype(np.int32)


#: regions of the workspace whose size a task does not bound: sup list nodes, bucket entries,
#: buckets, the decrease's heap, the output
GROWABLE = 5


def workspace_sizes(task: np.ndarray, n_ops: int, scale: int) -> np.ndarray:
    """The sizes of the growable regions (``scale`` doubles them after an overflow)."""
    n_eff = len(task) - task[EFF_OF + 1]
    return np.array([4 * n_ops + 64, 2 * (n_eff + task[N_FACTS]) + 64, 256, 4 * n_eff + 64,
                     16 * n_ops + 256], np.int64) * scale


def workspace(task: np.ndarray, n_ops: int, sizes: np.ndarray) -> np.ndarray:
    """One int64 array holding every per-call array of :func:`lmcut` (views cut at entry):
    allocated once per task, so a call allocates only its result."""
    nf = int(task[N_FACTS])
    n_eof = len(task) - int(task[EFF_OF + 1])
    fixed = 6 * nf + 6 * n_ops + n_eof + 3
    return np.zeros(fixed + 2 * int(sizes[0]) + 2 * int(sizes[1]) + 2 * int(sizes[2])
                    + int(sizes[3]) + int(sizes[4]), np.int64)


@numba.njit(cache=True)
def lmcut(task, cost0, bits, parent, applied, ws, sizes):
    """The packed landmarks of the state whose relevant facts are the set bits of ``bits``
    (bytes, little-endian), starting from the packed landmarks ``parent`` of a parent state
    (``[0, 0]`` for none) and the operator ``applied`` that led here (-1 for none). ``ws``,
    ``sizes``: :func:`workspace`. Returns ``[-2]`` when a growable region was too small (call
    again with larger ``sizes``)."""
    nf, true_fact, goal = task[N_FACTS], task[TRUE], task[GOAL]
    pre_o, pre_i = task[task[PRE]: task[PRE + 1]], task[task[PRE + 1]:]
    eff_o, eff_i = task[task[EFF]: task[EFF + 1]], task[task[EFF + 1]:]
    pof_o, pof_i = task[task[PRE_OF]: task[PRE_OF + 1]], task[task[PRE_OF + 1]:]
    eof_o, eof_i = task[task[EFF_OF]: task[EFF_OF + 1]], task[task[EFF_OF + 1]:]
    nops = len(cost0)
    # the workspace's views: never reassigned in the loops (numba would count references)
    at = 0
    h, at = ws[at: at + nf], at + nf
    sup_head, at = ws[at: at + nf], at + nf
    sup_tail, at = ws[at: at + nf], at + nf
    zone, at = ws[at: at + nf], at + nf
    before, at = ws[at: at + nf], at + nf
    init, at = ws[at: at + nf + 1], at + nf + 1
    cost, at = ws[at: at + nops], at + nops
    supp, at = ws[at: at + nops], at + nops
    scost, at = ws[at: at + nops], at + nops
    unsat, at = ws[at: at + nops], at + nops
    in_cut, at = ws[at: at + nops], at + nops
    cut, at = ws[at: at + nops], at + nops
    stack, at = ws[at: at + nf + len(eof_i) + 2], at + nf + len(eof_i) + 2
    sup_op, at = ws[at: at + sizes[0]], at + sizes[0]
    sup_next, at = ws[at: at + sizes[0]], at + sizes[0]
    ent_fact, at = ws[at: at + sizes[1]], at + sizes[1]
    ent_next, at = ws[at: at + sizes[1]], at + sizes[1]
    bhead, at = ws[at: at + sizes[2]], at + sizes[2]
    btail, at = ws[at: at + sizes[2]], at + sizes[2]
    heap, at = ws[at: at + sizes[3]], at + sizes[3]
    out = ws[at: at + sizes[4]]
    if len(parent) > len(out):
        return np.full(1, -2, np.int32)
    cost[:] = cost0
    n_lm, total, at = 0, 0, 2
    # the parent's landmarks without the applied operator: kept with their costs
    i = 2
    for _ in range(parent[1]):
        m, size = parent[i], parent[i + 1]
        hit = False
        for j in range(i + 2, i + 2 + size):
            if parent[j] == applied:
                hit = True
                break
        if not hit:
            total += m
            for j in range(i + 2, i + 2 + size):
                cost[parent[j]] -= m
            out[at: at + 2 + size] = parent[i: i + 2 + size]
            at += 2 + size
            n_lm += 1
        i += 2 + size
    init[0] = true_fact
    n_init = 1
    for b in range(len(bits)):
        byte = bits[b]
        bit = 0
        while byte:
            if byte & 1:
                init[n_init] = 8 * b + bit
                n_init += 1
            byte >>= 1
            bit += 1
    start = init[:n_init]
    h[:] = UNREACHED
    supp[:] = -1
    sup_head[:] = -1
    sup_tail[:] = -1
    n_sup = _explore(start, h, cost, supp, scost, unsat, sup_head, sup_tail, sup_op, sup_next,
                     ent_fact, ent_next, bhead, btail, pre_o, pof_o, pof_i, eff_o, eff_i)
    if n_sup < 0:
        return np.full(1, -2, np.int32)
    if h[goal] == UNREACHED:
        out[0], out[1] = -1, 0
        return out[:2].astype(np.int32)
    while h[goal] != 0:
        n_cut = _cut(start, cost, supp, sup_head, sup_op, sup_next, eff_o, eff_i, eof_o, eof_i,
                     goal, zone, before, in_cut, stack, cut)
        m = cost[cut[0]]
        for j in range(n_cut):
            m = min(m, cost[cut[j]])
        total += m
        for j in range(n_cut):
            cost[cut[j]] -= m
        if at + 2 + n_cut > len(out):
            return np.full(1, -2, np.int32)
        out[at], out[at + 1] = m, n_cut
        out[at + 2: at + 2 + n_cut] = cut[:n_cut]
        at += 2 + n_cut
        n_lm += 1
        n_sup = _decrease(cut[:n_cut], h, cost, supp, scost, sup_head, sup_tail, sup_op,
                          sup_next, n_sup, pre_o, pre_i, eff_o, eff_i, heap)
        if n_sup < 0:
            return np.full(1, -2, np.int32)
    out[0], out[1] = total, n_lm
    return out[:at].astype(np.int32)


@numba.njit(cache=True, inline="always")
def _explore(init, h, cost, supp, scost, unsat, sup_head, sup_tail, sup_op, sup_next, ent_fact,
             ent_next, head, tail, pre_o, pof_o, pof_i, eff_o, eff_i):
    """Full h_max, buckets read in append order (as ``lmcut._explore_buckets``); returns the
    number of ``sup`` list nodes used, -1 when a region was too small."""
    nops = len(cost)
    for o in range(nops):
        unsat[o] = pre_o[o + 1] - pre_o[o]
    n_ent, n_sup, top = 0, 0, 0
    head[0], tail[0] = -1, -1
    for p in init:
        h[p] = 0
        n_ent = _list_append(0, p, head, tail, ent_fact, ent_next, n_ent)
    v = 0
    while v <= top:
        i = head[v]
        while i >= 0:
            p = ent_fact[i]
            if h[p] == v:
                for j in range(pof_o[p], pof_o[p + 1]):
                    o = pof_i[j]
                    unsat[o] -= 1
                    if unsat[o] == 0:
                        supp[o] = p
                        scost[o] = v
                        if n_sup >= len(sup_op):
                            return -1
                        n_sup = _list_append(p, o, sup_head, sup_tail, sup_op, sup_next, n_sup)
                        w = v + cost[o]
                        for q in range(eff_o[o], eff_o[o + 1]):
                            e = eff_i[q]
                            if w < h[e]:
                                h[e] = w
                                if w >= len(head) or n_ent >= len(ent_fact):
                                    return -1
                                while top < w:
                                    top += 1
                                    head[top], tail[top] = -1, -1
                                n_ent = _list_append(w, e, head, tail, ent_fact, ent_next,
                                                     n_ent)
            i = ent_next[i]
        v += 1
    return n_sup


@numba.njit(cache=True, inline="always")
def _list_append(p, o, head, tail, item, nxt, n):
    """Append ``o`` to the linked list ``p`` (``head``/``tail`` per list, entries ``item`` and
    ``nxt``; ``n`` entries used, room made by the caller): ``sup[p]``, or a bucket of the
    h_max queue. Returns the entries used."""
    item[n] = o
    nxt[n] = -1
    if tail[p] >= 0:
        nxt[tail[p]] = n
    else:
        head[p] = n
    tail[p] = n
    return n + 1


@numba.njit(cache=True, inline="always")
def _cut(init, cost, supp, sup_head, sup_op, sup_next, eff_o, eff_i, eof_o, eof_i, goal, zone,
         before, in_cut, stack, cut):
    """One landmark cut into ``cut``; returns its size (as ``lmcut._cut``)."""
    zone[:] = 0
    before[:] = 0
    n = 1
    stack[0] = goal
    while n:
        n -= 1
        p = stack[n]
        if zone[p]:
            continue
        zone[p] = 1
        for j in range(eof_o[p], eof_o[p + 1]):
            o = eof_i[j]
            if cost[o] == 0 and supp[o] >= 0:
                stack[n] = supp[o]
                n += 1
    for p in init:
        before[p] = 1
        stack[n] = p
        n += 1
    n_cut = 0
    while n:
        n -= 1
        p = stack[n]
        i = sup_head[p]
        while i >= 0:
            o = sup_op[i]
            i = sup_next[i]
            if supp[o] != p:
                continue
            crosses = False
            for q in range(eff_o[o], eff_o[o + 1]):
                if zone[eff_i[q]]:
                    crosses = True
                    break
            if crosses:
                if not in_cut[o]:
                    in_cut[o] = 1
                    cut[n_cut] = o
                    n_cut += 1
            else:
                for q in range(eff_o[o], eff_o[o + 1]):
                    e = eff_i[q]
                    if not before[e]:
                        before[e] = 1
                        stack[n] = e
                        n += 1
    for j in range(n_cut):
        in_cut[cut[j]] = 0
    return n_cut


@numba.njit(cache=True, inline="always")
def _decrease(cut, h, cost, supp, scost, sup_head, sup_tail, sup_op, sup_next, n_sup, pre_o,
              pre_i, eff_o, eff_i, heap):
    """Incremental h_max after the costs of ``cut`` went down (as ``lmcut._decrease``; its heap
    of ``(h, fact)`` pairs is one of keys ``h * n_facts + fact``, the same order); returns the
    ``sup`` lists' size, -1 when a region was too small."""
    nf = len(h)
    n = 0
    for o in cut:
        w = scost[o] + cost[o]
        for q in range(eff_o[o], eff_o[o + 1]):
            e = eff_i[q]
            if h[e] > w:
                h[e] = w
                if n >= len(heap):
                    return -1
                n = _push(heap, n, w * nf + e)
    while n:
        key = heap[0]
        n = _pop(heap, n)
        v, p = key // nf, key % nf
        if v > h[p]:
            continue
        i = sup_head[p]
        while i >= 0:
            o = sup_op[i]
            i = sup_next[i]
            if supp[o] != p or scost[o] <= v:
                continue
            best, bp = -1, -1
            for q in range(pre_o[o], pre_o[o + 1]):
                x = pre_i[q]
                if h[x] > best:
                    best, bp = h[x], x
            if bp != p:
                supp[o] = bp
                if n_sup >= len(sup_op):
                    return -1
                n_sup = _list_append(bp, o, sup_head, sup_tail, sup_op, sup_next, n_sup)
            if best != scost[o]:
                scost[o] = best
                w = best + cost[o]
                for q in range(eff_o[o], eff_o[o + 1]):
                    e = eff_i[q]
                    if h[e] > w:
                        h[e] = w
                        if n >= len(heap):
                            return -1
                        n = _push(heap, n, w * nf + e)
    return n_sup


@numba.njit(cache=True, inline="always")
def _push(heap, n, key):
    """Binary min-heap ``heap[:n]``: add ``key`` (room checked by the caller); returns the new
    size."""
    i = n
    while i > 0:
        up = (i - 1) >> 1
        if heap[up] <= key:
            break
        heap[i] = heap[up]
        i = up
    heap[i] = key
    return n + 1


@numba.njit(cache=True, inline="always")
def _pop(heap, n):
    """Remove the smallest key (``heap[0]``) of ``heap[:n]``; returns the new size."""
    n -= 1
    last = heap[n]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        if c + 1 < n and heap[c + 1] < heap[c]:
            c += 1
        if heap[c] >= last:
            break
        heap[i] = heap[c]
        i = c
    heap[i] = last
    return n
