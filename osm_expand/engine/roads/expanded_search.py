"""Dijkstra on the heading-expanded graph, compiled, its turn rows made as the search reaches them.

:mod:`osm_expand.engine.roads.routing` searches a route with turn penalties
on a *heading-expanded* graph (arrival, departure and hub states per vertex,
numbered as ``routing._States`` says). Four fifths of that graph's entries
are the same for every vertex: an arrival ``arr(v, i)`` turns to
``dep(v, i + q)`` for the cheap turns q and to ``hub(v)`` at S_p, the hub
departs on every heading for free. Only the departures' rows (the plain
graph's edges, each from ``dep(u, b)`` to ``arr(w, b)``) differ, and their
lattice moves are regular too (a direction's step is the same everywhere,
its weight a function of the edge's kind). So the search here makes every
row when it pops its state: the turns from the penalties, the lattice
moves from the lattice's kind table, and only the few other edges
(streets, stitches, long bridges) are gathered first, by vertex (:class:`Expanded`).
No expanded CSR matrix is written (Campo Grande: 213 M entries for its 36
searches, session 35).

The routes must keep their bytes, and with them which of several paths of
exactly equal cost a search takes. scipy's Dijkstra (1.17,
``scipy.sparse.csgraph.dijkstra``) keeps a priority queue of
``(−distance, state)`` pairs (a C++ ``std::priority_queue``, entries made
stale by a later decrease skipped when popped): it scans the states in the
order of their distance and, of equal ones, the highest numbered first,
and a relaxation takes a state only when strictly cheaper and not above the
limit. A state is never pushed twice at one distance, so that order is
total and any heap that pops by it scans the states as scipy's does. So
this is the same search step for step: a 4-ary heap keyed by (distance,
−state), indexed (a state queued once, its entry moved up when its
distance falls, :func:`_queue`: no stale entries to sift through, the same
states scanned in the same order), the same rows in the same entry order, the same float sums
(``dist[u] + w``; A*'s reduced weight ``w + (h[col] − h[row])`` raised to
``eps``, as ``routing._reduced`` writes it into the matrix): the same
distances, the same predecessors, ties included.
``tests/test_routing_search.py`` holds it to scipy entry for entry.

A route search (plain Dijkstra up to the best cost C) can keep its route and
search fewer states (``ties``): A* by a consistent bound h on the graph's
own weights makes the same float sums, and every in-neighbour that attains
the distance of a state on a route below C has ``g + h`` within C too, so
applying scipy's choice among them (the least distance, then the highest
state) as they relax gives those states scipy's predecessors
(:func:`expanded_dijkstra`). Campo Grande's 36 captured searches: the same
36 routes, 26.1 s CPU against 32.7 (session 36). That rule is scipy's only
where no two consecutive edges of a path cost 0 in float (a zero edge gives
a state its predecessor's distance, and scipy's queue then orders the two by
number, not by when they relax): it holds because every arrival → departure
or hub and every hub → departure edge costs at least ``eps`` (1e-9), and
``g + eps > g`` only while g is below 2²⁴ ≈ 1.7e7 (above it half an ulp
exceeds 1e-9 and the sum rounds back to g). A town's route costs are far
below that.

The plain (turn-free) searches of a window — from the source with
predecessors (the plain route), from the target up to the first bound, from
the exits joined at their bounds (``routing._via_exits``) — are the same
search on G′ itself (:func:`plain_dijkstra`): a vertex's row is its lattice
moves, read from the kind table, then its other edges, in the order
``PathGraph._csr`` writes them, so the distances and predecessors are
scipy's on that matrix, which is no longer written (Campo Grande's 36
captured searches: 32.3 → 26.3 s CPU, peak 0.98 → 0.50 GB; session 37).

numba compiles it (``cache=True``: a user's first run compiles and stores
it; later runs load it, about 0.4 s with numba's import). Compiling the
search for one set of argument types takes 3–4 s CPU (session 36's review:
3.9 s with a float64 ``plain`` table, 3.1 s float32, 3.5 s with an int64
``local``), and numba compiles once per set, so ``routing._heading_search``
passes one set always (a float32 ``plain``, a (1, 1) one beside a kind
table; an int32 ``local``): a run compiles the search once. The plain
search's kernels (``_plain_seeded``, ``_plain_scan``) cost 1.8 s CPU more
to compile with an empty cache (session 37's review). Only this module and
:mod:`osm_expand.engine.traffic.trip_search` (which takes ``_compiled`` and
``_before`` from here, and whose kernels cost 4.65 s more to compile) import
numba, each imported only when its searches first run (``routing`` when it
first searches a route, ``trips`` when it first searches trips), so commands
that search neither do not pay it. numba's import holds about 110 MB (LLVM)
for the rest of the run.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, TypeVar

import numpy as np
from numba import njit

#: scipy's ``NULL_IDX``: the predecessor of a state not reached
NO_PRED = -9999

_F = TypeVar("_F", bound=Callable[..., Any])


def _compiled(**options: Any) -> Callable[[_F], _F]:
    """``njit(cache=True, **options)``, or without the cache where numba finds nowhere to write it.

    numba raises RuntimeError ("cannot cache function …: no locator available") when it decorates
    a cached function while neither the package's folder nor its user cache (``NUMBA_CACHE_DIR``)
    is writable (a read-only install, a sandboxed user): importing this module, so every route
    search, would fail. Without the cache each run compiles once (about 4 s CPU) instead."""
    def wrap(func: _F) -> _F:
        try:
            return njit(cache=True, **options)(func)
        except RuntimeError as error:
            if "cannot cache" not in str(error):
                raise
            return njit(cache=False, **options)(func)
    return wrap


@_compiled(inline="always")
def _before(key: float, state: float, other_key: float, other_state: float) -> bool:
    """An entry pops before another: the lower distance, of equal ones the higher state (scipy's order)."""
    return key < other_key or (key == other_key and state > other_state)


@_compiled(inline="always")
def _sift_up(heap: np.ndarray, pos: np.ndarray, at: int, key: float, state: float) -> None:
    """Put ``(key, state)`` at row ``at`` of ``heap`` (a 4-ary heap of ``(distance, state)``) or above it,
    the entries that pop later moving down; where ``pos`` is not empty (an indexed heap, :func:`_queue`) it
    is told each moved entry's row."""
    tracked = len(pos) > 0
    while at > 0:  # the hole moves up past the entries that pop later
        up = (at - 1) >> 2
        if not _before(key, state, heap[up, 0], heap[up, 1]):
            break
        heap[at, 0] = heap[up, 0]
        heap[at, 1] = heap[up, 1]
        if tracked:
            pos[np.int64(heap[at, 1])] = at
        at = up
    heap[at, 0] = key
    heap[at, 1] = state
    if tracked:
        pos[np.int64(state)] = at


@_compiled(inline="always")
def _unqueue(heap: np.ndarray, pos: np.ndarray, length: int) -> None:
    """Drop the heap's first entry (``length`` entries before): its last one sifts down from the top; where
    ``pos`` is not empty (an indexed heap, :func:`_queue`) it is told each moved entry's row."""
    tracked = len(pos) > 0
    last = length - 1
    key = heap[last, 0]
    state = heap[last, 1]
    at = 0
    while True:
        first = 4 * at + 1
        if first >= last:
            break
        best = first
        for c in range(first + 1, min(first + 4, last)):
            if _before(heap[c, 0], heap[c, 1], heap[best, 0], heap[best, 1]):
                best = c
        if not _before(heap[best, 0], heap[best, 1], key, state):
            break
        heap[at, 0] = heap[best, 0]
        heap[at, 1] = heap[best, 1]
        if tracked:
            pos[np.int64(heap[at, 1])] = at
        at = best
    heap[at, 0] = key
    heap[at, 1] = state
    if tracked:
        pos[np.int64(state)] = at


@_compiled(inline="always")
def _push(heap: np.ndarray, pos: np.ndarray, length: int, key: float, state: float) -> np.ndarray:
    """``heap`` (entries ``(distance, state)``, rows ``0 … length − 1`` a 4-ary heap; ``pos`` its index, or
    empty: the turn bound's search keeps none, its stale entries skipped when popped, most of its states
    going through its stack, not its heap: an index measured no faster there, session 41) with one more
    entry (grown by doubling when full: the returned array is the heap)."""
    if length == len(heap):
        heap = np.concatenate((heap, np.empty_like(heap)))
    _sift_up(heap, pos, length, key, state)
    return heap


@_compiled(inline="always")
def _queue(heap: np.ndarray, pos: np.ndarray, length: int, state: int | np.integer, key: float) -> int:
    """``state`` queued at ``key`` in the indexed heap (rows ``0 … length − 1``, room for one more); its
    length after.

    An indexed heap holds a state once: where it is queued already (``pos`` names a row within the
    heap that holds it: ``pos`` need not be set beforehand, rows are checked), its entry moves up to
    the new key, which is never above the old (a strictly lower distance, the same bound added: the
    float sum is monotone). scipy's queue (and these searches before session 41) pushed a new entry
    and skipped the old one when popped: the valid entries pop in the same order, (key, −state)
    being total, so the states scanned and the sums made are the same, with no stale entry to sift
    through (Campo Grande's 36 captured searches: the plain searches ~26 % less CPU, session 41)."""
    p = pos[state]
    if 0 <= p < length and heap[p, 1] == state:
        _sift_up(heap, pos, p, key, np.float64(state))
        return length
    _sift_up(heap, pos, length, key, np.float64(state))
    return length + 1


@_compiled(inline="always")
def _reduced_weight(w: float, h_to: float, h_from: float, eps: float) -> float:
    """A*'s reduced weight as ``routing._reduced`` writes it into the matrix: ``w + (h_to − h_from)``, raised
    to ``eps`` where below it (a NaN stays NaN, as there)."""
    w = w + (h_to - h_from)
    if w < eps:
        return eps
    return w


@_compiled(inline="always")
def _relax(dist: np.ndarray, pred: np.ndarray, heap: np.ndarray, pos: np.ndarray, length: int, col: int, nv: float,
           v: int | np.integer, limit: float, ties: bool, h_col: float) -> int:
    """Offer state ``col`` the distance ``nv`` from ``v``; the heap's length after (``heap``, indexed by
    ``pos``, :func:`_queue`, has room for one more entry: the caller made it, so that no array is
    passed back — a returned heap cost a reference count a relaxation, see :func:`_room`).

    As scipy: taken only when strictly cheaper and not above the limit. With ``ties`` (A* keyed by
    ``g + h``, ``h_col`` the state's bound): taken when strictly cheaper and ``nv + h_col`` not above
    the limit; where ``nv`` equals the state's distance, ``v`` becomes its predecessor when it comes
    first in scipy's order (lower distance, then higher number) — found at relaxation, even after
    the state was scanned, where scipy's queue found it by popping ``v`` first. That is scipy's
    choice only while no two consecutive edges cost 0 in float: the turn and hub edges cost at
    least ``eps``, which ``nv`` keeps while distances are below about 1.7e7 (module docstring)."""
    if ties:
        if dist[col] > nv:
            key = nv + h_col
            if key <= limit:
                dist[col] = nv
                pred[col] = v
                length = _queue(heap, pos, length, col, key)
        elif dist[col] == nv:
            p = pred[col]
            if p >= 0 and (dist[v] < dist[p] or (dist[v] == dist[p] and v > p)):
                pred[col] = v
    elif nv <= limit and dist[col] > nv:
        dist[col] = nv
        if len(pred):
            pred[col] = v
        length = _queue(heap, pos, length, col, nv)
    return length


@_compiled(inline="always")
def _room(heap: np.ndarray, need: int) -> np.ndarray:
    """``heap`` with room for ``need`` entries (doubled until they fit; the same array where they do).

    A state's row is relaxed into the heap made room for before it: a heap grown inside each
    relaxation and passed back cost a reference count each, about half of the compiled searches'
    time (the plain search's window, session 37; the heading search's 36 captured Campo Grande
    calls, session 41)."""
    if need <= len(heap):
        return heap
    size = len(heap)
    while size < need:
        size *= 2
    return np.concatenate((heap, np.empty((size - len(heap), 2))))


@_compiled()
def _search(n: int, k: int, cheap: np.ndarray, cheap_cost: np.ndarray, hub_cost: float, region: np.ndarray,
            local: np.ndarray, n_lat: int, lat_kind: np.ndarray, allowed: np.ndarray, offset: np.ndarray,
            dirs_ptr: np.ndarray, dirs: np.ndarray, table: np.ndarray, plain: np.ndarray, w_kind: np.ndarray,
            e_ptr: np.ndarray,
            e_bin: np.ndarray, e_col: np.ndarray, e_val: np.ndarray, h: np.ndarray, astar: bool, ties: bool,
            eps: float, seeds: np.ndarray, limit: float, dist: np.ndarray, pred: np.ndarray,
            turns: np.ndarray, pos: np.ndarray, budget: int) -> np.ndarray:
    """The distances in ``dist`` (and ``pred`` filled, when it has room), each state's row made as it is
    popped, the search started (or resumed) from the ``seeds`` at their distances in ``dist``; the
    arguments are :class:`Expanded`'s fields and :func:`expanded_steps`' (its docstring); ``pos``
    (one int32 a state, unset) the heap's index (:func:`_queue`). It pauses after popping ``budget``
    entries (−1: never) and returns the states still queued (empty when it ran to the end)."""
    nk = n * k
    n_dir = lat_kind.shape[1]
    use_table = len(table) > 0
    n_cheap = len(cheap)
    # the heap's entries (key, state): a state is exact in a float64 (it is below 2⁵³), and an
    # entry's two halves share a cache line
    has_turns = len(turns) > 0  # a per-state bound added to h (``ties`` only): :func:`expanded_dijkstra`'s ``turns``
    heap = np.empty((max(4096, len(seeds)), 2))
    length = 0
    for index in range(len(seeds)):  # keyed as a push keys them: g (+ h with ties), within the limit
        seed = seeds[index]
        at = seed // k if seed < nk else ((seed - nk) // k if seed < 2 * nk else seed - 2 * nk)  # its vertex
        if ties and has_turns:  # g + (h + T), summed as a push sums it (the stale test compares them)
            first = dist[seed] + (h[at] + turns[seed])
        else:
            first = dist[seed] + h[at] if ties else dist[seed]
        if first <= limit:
            length = _queue(heap, pos, length, seed, first)
    popped = 0
    while length > 0:
        if popped == budget:  # paused between two pops: the queued states are where it goes on
            return heap[:length, 1].astype(np.int64)
        popped += 1
        key = heap[0, 0]
        v = np.int64(heap[0, 1])
        _unqueue(heap, pos, length)
        length -= 1
        if v < nk:
            u = v // k
        elif v < 2 * nk:
            u = (v - nk) // k
        else:
            u = v - 2 * nk
        hu = h[u] if astar or ties else 0.0
        dv = dist[v]
        # the indexed heap keeps no entry made stale by a later decrease (:func:`_queue`); kept as the
        # guard it was (with ties the key is g + h, summed as here: equal for every entry popped)
        hv = hu + turns[v] if has_turns else hu
        if (dv + hv < key) if ties else (dv < key):
            continue
        if v < nk:  # arrival arr(u, i): its cheap turns, then the hub
            heap = _room(heap, length + n_cheap + 1)
            i = v - u * k
            base = nk + u * k
            for j in range(n_cheap + 1):
                if j < n_cheap:
                    b = i + cheap[j]
                    if b >= k:
                        b -= k
                    col = base + b
                    w = cheap_cost[j]
                else:
                    col = 2 * nk + u
                    w = hub_cost
                if astar:
                    w = _reduced_weight(w, hu, hu, eps)
                hc = hu + turns[col] if has_turns else hu
                length = _relax(dist, pred, heap, pos, length, col, dv + w, v, limit, ties, hc)
        elif v < 2 * nk:  # departure dep(u, b): its lattice moves of bin b, then its other edges of bin b
            b = v - nk - u * k
            heap = _room(heap, length + dirs_ptr[b + 1] - dirs_ptr[b] + e_ptr[u + 1] - e_ptr[u])
            gu = region[u]
            if gu < n_lat:
                for t in range(dirs_ptr[b], dirs_ptr[b + 1]):
                    d = dirs[t]
                    kd = lat_kind[gu, d]
                    if not allowed[kd]:
                        continue
                    lw = local[gu + offset[d]]
                    if lw < 0:
                        continue
                    w = table[np.int64(w_kind[gu, d]) * n_dir + d] if use_table else np.float64(plain[gu, d])
                    if astar:
                        w = _reduced_weight(w, h[lw], hu, eps)
                    hc = h[lw] if ties else 0.0
                    if has_turns:
                        hc += turns[lw * k + b]
                    length = _relax(dist, pred, heap, pos, length, lw * k + b, dv + w, v, limit, ties, hc)
            for t in range(e_ptr[u], e_ptr[u + 1]):
                if e_bin[t] != b:
                    continue
                col = e_col[t]
                w = e_val[t]
                if astar:
                    w = _reduced_weight(w, h[col // k], hu, eps)
                hc = h[col // k] if ties else 0.0
                if has_turns:
                    hc += turns[col]
                length = _relax(dist, pred, heap, pos, length, col, dv + w, v, limit, ties, hc)
        else:  # the hub: every departure, free
            heap = _room(heap, length + k)
            w = _reduced_weight(eps, hu, hu, eps) if astar else eps
            for col in range(nk + u * k, nk + u * k + k):
                hc = hu + turns[col] if has_turns else hu
                length = _relax(dist, pred, heap, pos, length, col, dv + w, v, limit, ties, hc)
    return np.empty(0, dtype=np.int64)


@_compiled(inline="always")
def _offer(T: np.ndarray, x: int | np.integer, nv: float, key: float, heap: np.ndarray, pos: np.ndarray, length: int,
           stack: np.ndarray, top: int) -> tuple[np.ndarray, int, np.ndarray, int]:
    """Offer state ``x`` the turn cost ``nv`` (at least ``key``, the one being scanned): where lower than
    its own, taken, and queued: on the stack where it equals ``key`` (a free edge: scanned before the
    heap's next entry, which is no lower), else in the heap."""
    if T[x] > nv:
        T[x] = nv
        if nv == key:
            if top == len(stack):
                stack = np.concatenate((stack, np.empty_like(stack)))
            stack[top] = x
            top += 1
        else:
            heap = _push(heap, pos, length, nv, np.float64(x))
            length += 1
    return heap, length, stack, top


@_compiled()
def _turns_back(n: int, k: int, cheap: np.ndarray, cheap_cost: np.ndarray, hub_cost: float, region: np.ndarray,
                local: np.ndarray, n_lat: int, lat_kind: np.ndarray, allowed: np.ndarray, offset: np.ndarray,
                dirs_ptr: np.ndarray, dirs: np.ndarray, r_ptr: np.ndarray, r_src: np.ndarray, r_bin: np.ndarray,
                ends: np.ndarray, cap: np.ndarray, budget: int, T: np.ndarray) -> float:
    """Dijkstra backwards on the heading-expanded graph over ``n`` vertices (``region``, ``local``: all of
    them numbered), its turn penalties the only weights (moves and other edges cost 0, a turn of q
    bins ``cheap_cost``, an arrival to its hub ``hub_cost``, the hub to a departure 0): ``T`` of each
    state up to ``cap`` of its vertex (a state above it is neither kept nor searched on), from the
    arrivals ``ends`` at 0. A state's in-edges: an arrival ``arr(w, b)``'s from ``dep(u, b)`` for
    each allowed lattice move u → w of bin b (u = w − the direction's step) and each other edge into
    w of bin b (``r_*``, by head); a departure ``dep(v, b)``'s from ``arr(v, b − q)`` for the cheap
    turns and from ``hub(v)``; the hub's from every arrival. The states a free edge reaches at the
    cost being scanned go on a stack, not the heap (most of them: every move is free).

    It stops after scanning ``budget`` states and returns the cost it had reached (∞ where it ran to
    the end): every state not scanned by then has T at least that."""
    nk = n * k
    heap = np.empty((4096, 2))
    no_index = np.empty(0, dtype=np.int32)  # the heap keeps no index (:func:`_push`)
    length = 0
    stack = np.empty(4096, dtype=np.int64)
    top = 0
    for index in range(len(ends)):
        e = ends[index]
        if cap[e // k] >= 0.0 and T[e] > 0.0:
            T[e] = 0.0
            heap = _push(heap, no_index, length, 0.0, np.float64(e))
            length += 1
    scanned = 0
    while length > 0:
        key = heap[0, 0]
        y0 = np.int64(heap[0, 1])
        _unqueue(heap, no_index, length)
        length -= 1
        if T[y0] < key:
            continue
        stack[0] = y0
        top = 1
        while top > 0:  # y0, then every state reached from it at the same cost
            if scanned == budget:
                return key
            scanned += 1
            top -= 1
            y = stack[top]
            if y < nk:  # arr(w, b): the departures that move into it, free
                w = y // k
                b = y - w * k
                gw = region[w]
                if gw < n_lat:
                    for t in range(dirs_ptr[b], dirs_ptr[b + 1]):
                        d = dirs[t]
                        u = gw - offset[d]
                        if u < 0 or u >= n_lat or not allowed[lat_kind[u, d]]:
                            continue
                        lu = local[u]
                        if lu < 0 or key > cap[lu]:
                            continue
                        heap, length, stack, top = _offer(T, nk + lu * k + b, key, key, heap, no_index, length,
                                                          stack, top)
                for t in range(r_ptr[w], r_ptr[w + 1]):
                    if r_bin[t] != b or key > cap[r_src[t]]:
                        continue
                    heap, length, stack, top = _offer(T, nk + r_src[t] * k + b, key, key, heap, no_index, length,
                                                      stack, top)
            elif y < 2 * nk:  # dep(v, b): the arrivals that turn to it, and the hub (free)
                v = (y - nk) // k
                b = y - nk - v * k
                for j in range(len(cheap)):
                    i = b - cheap[j]
                    if i < 0:
                        i += k
                    nv = key + cheap_cost[j]
                    if nv <= cap[v]:
                        heap, length, stack, top = _offer(T, v * k + i, nv, key, heap, no_index, length, stack, top)
                heap, length, stack, top = _offer(T, 2 * nk + v, key, key, heap, no_index, length, stack, top)
            else:  # hub(v): every arrival, at the hub's cost
                v = y - 2 * nk
                nv = key + hub_cost
                if nv <= cap[v]:
                    for i in range(k):
                        heap, length, stack, top = _offer(T, v * k + i, nv, key, heap, no_index, length, stack, top)
    return np.inf


def turns_to_go(graph: Expanded, ends: np.ndarray, r_ptr: np.ndarray, r_src: np.ndarray, r_bin: np.ndarray,
                limit: float | np.ndarray, turn_cost: np.ndarray, hub_cost: float,
                budget: int = -1) -> np.ndarray:
    """Per state of ``graph`` (its ``local`` numbering every vertex of ``region``), the least turn cost of a
    path to one of the arrivals ``ends`` through states within ``limit`` (one for all, or per vertex;
    :func:`_turns_back`), clamped at the limit of the state's vertex (a state not reached within it
    has every such path's turns above it). ``r_*``: the other edges by head (local numbers), their
    tails and bins; ``turn_cost`` (per cheap turn of ``graph``) and ``hub_cost``: the turns' costs
    without the search's floor ε (lower, so T stays a lower bound and consistent on the search's
    costs; with them the free moves and turns cost 0 and go by the stack, not the heap). With a
    ``budget`` (≥ 0) the search stops after scanning that many states, and every T is clamped at the
    cost it had reached, τ: ``min(T, τ)`` is consistent too, a lower bound found in bounded time.

    A limit per vertex makes a corridor: ``routing._turns_to_go`` gives each vertex the turns a
    route through it may make and still cost at most C; that keeps ``D + T`` consistent and below
    every such route's cost to go (its docstring's proof), while the search stays inside the states
    a route within C can reach.

    Raises
    ------
    ValueError
        Where the compiled search would read or write out of its arrays (numba checks no bounds):
        ends not among the arrivals, edges by head not one run per vertex (``r_ptr``) or not as many
        tails and bins as it counts, a tail not among the vertices or a bin not among the k, turn
        costs not one per cheap turn, or a limit per vertex not one per vertex.
    """
    g = graph
    size = g.n * (2 * g.k + 1)
    ends = np.asarray(ends, dtype=np.int64)
    r_ptr = np.asarray(r_ptr, dtype=np.int64)
    r_src = np.asarray(r_src, dtype=np.int64)
    r_bin = np.asarray(r_bin, dtype=np.int64)
    turn_cost = np.ascontiguousarray(turn_cost, dtype=np.float64)
    if len(ends) and not (0 <= ends.min() and ends.max() < g.n * g.k) or len(r_ptr) != g.n + 1:
        raise ValueError("the ends (arrivals) or the edges by head are not of this graph's states and vertices")
    if not (r_ptr[0] == 0 and (np.diff(r_ptr) >= 0).all() and len(r_src) == len(r_bin) == r_ptr[-1]):
        raise ValueError(f"the edges by head count {r_ptr[-1]} edges from {r_ptr[0]}, with {len(r_src)} tails "
                         f"and {len(r_bin)} bins")
    if len(r_src) and not (0 <= r_src.min() and r_src.max() < g.n and 0 <= r_bin.min() and r_bin.max() < g.k):
        raise ValueError(f"an edge's tail is not among the {g.n} vertices or its bin not among the {g.k}")
    if len(turn_cost) != len(g.cheap):
        raise ValueError(f"{len(turn_cost)} turn costs for the graph's {len(g.cheap)} cheap turns")
    cap = np.ascontiguousarray(np.broadcast_to(np.asarray(limit, dtype=np.float64), (g.n,)))
    T = np.full(size, np.inf)
    reached = _turns_back(g.n, g.k, g.cheap, turn_cost, hub_cost, g.region, g.local, g.n_lat, g.lat_kind,
                          g.allowed, g.offset, g.dirs_ptr, g.dirs, r_ptr, r_src, r_bin, ends, cap, int(budget), T)
    if reached < np.inf:
        cap = np.minimum(cap, reached)
    # the clamp: each state at most its vertex's limit (arrivals and departures k a vertex, then the hubs)
    nk = g.n * g.k
    for part in (T[:nk].reshape(g.n, g.k), T[nk:2 * nk].reshape(g.n, g.k)):
        np.minimum(part, cap[:, None], out=part)
    np.minimum(T[2 * nk:], cap, out=T[2 * nk:])
    return T


@_compiled()
def _plain_seeded(dist: np.ndarray, pred: np.ndarray, pos: np.ndarray, seeds: np.ndarray, seed_dist: np.ndarray,
                  limit: float) -> tuple[np.ndarray, int]:
    """The heap of a plain search's start (indexed by ``pos``, :func:`_queue`): each seed at its distance
    (scipy's joined source's row, or the one start at 0), relaxed in order; a seed's predecessor is
    none (−9999)."""
    heap = np.empty((max(4096, len(seeds)), 2))
    length = 0
    for i in range(len(seeds)):
        length = _relax(dist, pred, heap, pos, length, seeds[i], seed_dist[i], -1, limit, False, 0.0)
    if len(pred):
        for i in range(len(seeds)):
            pred[seeds[i]] = -9999
    return heap, length


@_compiled()
def _plain_scan(n_lat: int, lat_kind: np.ndarray, allowed: np.ndarray, offset: np.ndarray, table: np.ndarray,
                plain: np.ndarray, w_kind: np.ndarray, e_ptr: np.ndarray, e_col: np.ndarray, e_val: np.ndarray,
                dist: np.ndarray, pred: np.ndarray, pos: np.ndarray, heap: np.ndarray, length: int, limit: float,
                stop: int) -> tuple[np.ndarray, int, bool]:
    """Scan the vertices a plain search pops, until the heap is empty, its first key is above ``limit``
    (pushed before the limit was lowered: none of a search with this limit from the start), or
    ``stop`` is scanned (then True); a vertex's row is its lattice moves (directions ascending), then
    its other edges (:class:`Plain`'s fields): scipy's search on ``PathGraph._csr``'s matrix, step for
    step."""
    n_dir = lat_kind.shape[1]
    use_table = len(table) > 0
    has_pred = len(pred) > 0
    while length > 0:
        key = heap[0, 0]
        if key > limit:
            break
        u = np.int64(heap[0, 1])
        _unqueue(heap, pos, length)
        length -= 1
        du = dist[u]
        # room for the row's entries first, so that a relaxation passes no array back (:func:`_relax`'s
        # returned heap cost a reference count each: twice the time of this search on a window)
        # (doubled until the whole row fits: a vertex may have more edges than the heap has rows)
        need = length + n_dir + e_ptr[u + 1] - e_ptr[u]
        if need > len(heap):
            size = len(heap)
            while size < need:
                size *= 2
            heap = np.concatenate((heap, np.empty((size - len(heap), 2))))
        if u < n_lat:
            for d in range(n_dir):
                if not allowed[lat_kind[u, d]]:
                    continue
                col = u + offset[d]
                nv = du + (table[np.int64(w_kind[u, d]) * n_dir + d] if use_table else np.float64(plain[u, d]))
                if nv <= limit and dist[col] > nv:  # scipy's relaxation (:func:`_relax` without ties)
                    dist[col] = nv
                    if has_pred:
                        pred[col] = u
                    length = _queue(heap, pos, length, col, nv)
        for t in range(e_ptr[u], e_ptr[u + 1]):
            col = e_col[t]
            nv = du + e_val[t]
            if nv <= limit and dist[col] > nv:
                dist[col] = nv
                if has_pred:
                    pred[col] = u
                length = _queue(heap, pos, length, col, nv)
        if u == stop:
            return heap, length, True
    return heap, length, False


def _heap_index(n: int) -> np.ndarray:
    """The indexed heap's ``pos`` for ``n`` states (:func:`_queue`), unset: 32 bits a state where they
    number them (a search compiles once per set of argument types), else 64. Left unset, its pages are
    written only where states are queued (a search reaches a corridor of its region's states)."""
    return np.empty(n, dtype=np.int32 if n < 2**31 else np.int64)


class Plain(NamedTuple):
    """What the plain (turn-free) search reads of a G′ over ``n`` vertices: the lattice's tables, each
    move read as the search reaches its vertex, and the other edges (streets, stitches, long bridges)
    by tail, in :meth:`~osm_expand.engine.roads.path_graph.PathGraph._csr`'s row order. No matrix of
    the window is written (Campo Grande: its windows' matrices were 8.2 s of the run's CPU and most
    of a road year's memory, session 36)."""

    n: int  #: G′ vertices
    n_lat: int  #: lattice vertices (they come first)
    lat_kind: np.ndarray  #: (n_lat, D) uint8 the lattice edges' kinds
    allowed: np.ndarray  #: (256,) bool, the kinds a route may use
    offset: np.ndarray  #: int64 (D,), a direction's step in vertex numbers
    table: np.ndarray  #: float64 weight by ``kind · D + direction`` (empty: read ``plain``)
    plain: np.ndarray  #: float32 (n_lat, D) the lattice weights, where there is no table (else (1, 1))
    w_kind: np.ndarray  #: uint8 (n_lat, D) the kinds ``table`` is read by (else (1, 1))
    e_ptr: np.ndarray  #: int64 (n + 1,), each vertex's other edges in the arrays below
    e_col: np.ndarray  #: int64, their heads
    e_val: np.ndarray  #: float64 weights


class PlainSearch:
    """scipy's ``dijkstra(matrix, indices=seed, limit=limit)`` on the plain G′ ``graph`` describes (one
    seed at distance 0), or on that matrix joined to one more source whose row reaches each seed at
    its ``seed_dist`` (``routing._via_exits``), run in parts: :meth:`run` up to a vertex, then on with
    a limit chosen from what it found (the route search's: its limit is the first bound, which
    needs the plain route). Each part scans in scipy's order, so after :meth:`cut` to the last limit
    the distances and predecessors are those of scipy's search with that limit from the start, ties
    included (the pop order and the strict relaxation of the module docstring): a vertex within it
    is reached only from vertices within it, scanned in the same order.

    Raises
    ------
    ValueError
        A seed not among the vertices, seeds and distances of other lengths, or more vertices than
        the predecessors' 32 bits number (numba checks no bounds).
    """

    def __init__(self, graph: Plain, seeds: np.ndarray, seed_dist: np.ndarray | None = None, limit: float = np.inf,
                 predecessors: bool = False) -> None:
        seeds = np.asarray(seeds, dtype=np.int64).reshape(-1)
        at = np.zeros(len(seeds)) if seed_dist is None else np.asarray(seed_dist, dtype=np.float64).reshape(-1)
        if len(at) != len(seeds):
            raise ValueError(f"{len(seeds)} seeds but {len(at)} distances")
        if len(seeds) and not (0 <= seeds.min() and seeds.max() < graph.n):
            raise ValueError(f"a seed is not among the {graph.n} vertices")
        if predecessors and graph.n >= 2**31:
            raise ValueError(f"{graph.n} vertices: more than the predecessors' 32 bits number")
        self.graph = graph
        self.dist = np.full(graph.n, np.inf)  #: (n,) the distances found (∞: not reached)
        self.pred = np.full(graph.n if predecessors else 0, NO_PRED, dtype=np.int32)  #: (n,) or empty
        self._pos = _heap_index(graph.n)
        self._heap, self._length = _plain_seeded(self.dist, self.pred, self._pos, seeds, at, float(limit))
        self._limit = float(limit)  #: the lowest limit yet: what lies above it was never pushed

    def run(self, limit: float | None = None, stop: int = -1) -> bool:
        """Scan on, up to ``limit`` (None: the last one), until ``stop`` is scanned (then True; −1:
        none) or nothing is left.

        Raises
        ------
        ValueError
            ``limit`` above the last one: the entries the last limit kept out were never pushed, so
            the search would miss them silently.
        """
        limit = self._limit if limit is None else float(limit)
        if limit > self._limit:
            raise ValueError(f"a plain search's limit may only fall: {limit} after {self._limit}")
        self._limit = limit
        g = self.graph
        self._heap, self._length, stopped = _plain_scan(
            g.n_lat, g.lat_kind, g.allowed, g.offset, g.table, g.plain, g.w_kind, g.e_ptr, g.e_col, g.e_val,
            self.dist, self.pred, self._pos, self._heap, self._length, float(limit), int(stop))
        return bool(stopped)

    def cut(self, limit: float) -> None:
        """Forget what lies above ``limit`` (∞ and −9999): reached only before the limit was lowered."""
        above = self.dist > limit
        self.dist[above] = np.inf
        if len(self.pred):
            self.pred[above] = NO_PRED


def plain_dijkstra(graph: Plain, seeds: np.ndarray, seed_dist: np.ndarray | None = None, limit: float = np.inf,
                   return_predecessors: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:class:`PlainSearch` in one part: scipy's ``dijkstra`` on the plain G′ from ``seeds`` (joined at
    ``seed_dist``) up to ``limit``.

    Returns
    -------
    dist, pred
        Per vertex (∞ and −9999 where not reached; pred empty unless asked; a seed's −9999).
    """
    search = PlainSearch(graph, seeds, seed_dist, limit, return_predecessors)
    search.run(limit)
    return search.dist, search.pred


class Expanded(NamedTuple):
    """What the search reads of a heading-expanded graph over ``n`` vertices with ``k`` bins, beside
    the rows it makes itself: the turns, the lattice's tables (moves read as the search reaches their
    vertex) and the other edges (streets, stitches, long bridges) by vertex."""

    n: int  #: vertices (local numbers 0 … n − 1)
    k: int  #: heading bins
    cheap: np.ndarray  #: int64, the turns of q bins cheaper than S_p, q ascending (an arrival's row)
    cheap_cost: np.ndarray  #: their weights
    hub_cost: float  #: ``arr(v, i) → hub(v)``
    eps: float  #: the hub's free departures (and A*'s least reduced weight)
    region: np.ndarray  #: int64 (n,), each local vertex's G′ number (lattice vertices first)
    local: np.ndarray  #: int32 (V′,) each G′ vertex's local number, −1 outside
    n_lat: int  #: lattice vertices of G′ (they come first)
    lat_kind: np.ndarray  #: (n_lat, D) uint8 the lattice edges' kinds
    allowed: np.ndarray  #: (256,) bool, the kinds a route may use
    offset: np.ndarray  #: int64 (D,), a direction's step in G′ numbers
    dirs_ptr: np.ndarray  #: int64 (k + 1,), where each bin's directions start in ``dirs``
    dirs: np.ndarray  #: int64 (D,) the directions by bin, ascending within one
    table: np.ndarray  #: float64 weight by ``kind · D + direction`` (empty: read ``plain``)
    plain: np.ndarray  #: float32 (n_lat, D) the lattice weights, where there is no table (else (1, 1))
    w_kind: np.ndarray  #: uint8 (n_lat, D) the kinds ``table`` is read by (the weights' own; else (1, 1))
    e_ptr: np.ndarray  #: int64 (n + 1,), each vertex's other edges in the arrays below
    e_bin: np.ndarray  #: int64, their heading bins (a vertex's in row order: bin, then edge)
    e_col: np.ndarray  #: int64, ``arr(w, b)``
    e_val: np.ndarray  #: float64 weights


class Resume(NamedTuple):
    """A search to go on with (:func:`expanded_dijkstra`'s ``resume``): the distances and predecessors
    of the last search on the same states with the same limit and bound, whose graph has grown
    since, and the states to scan again (those with an edge into what was added). Or with a lower
    limit and vertices left out, where every state of those lies above it (``routing._goes_on``):
    then only the states within the new limit end as a search from scratch gives them. Or a search
    paused (:func:`expanded_steps`' ``budget``), its seeds the states it left queued."""

    dist: np.ndarray  #: per state, the last search's (taken over and changed in place)
    pred: np.ndarray  #: per state, the last search's (empty where none were asked for)
    seeds: np.ndarray  #: int64, states scanned again first (at their distances in ``dist``)


def expanded_dijkstra(graph: Expanded, start: int, limit: float, h: np.ndarray | None = None,
                      return_predecessors: bool = False, ties: bool = False,
                      resume: Resume | None = None, turns: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`expanded_steps` run to the end: the distances and predecessors (its docstring)."""
    dist, pred, _ = expanded_steps(graph, start, limit, h, return_predecessors, ties, resume, turns)
    return dist, pred


def expanded_steps(graph: Expanded, start: int, limit: float, h: np.ndarray | None = None,
                   return_predecessors: bool = False, ties: bool = False, resume: Resume | None = None,
                   turns: np.ndarray | None = None, budget: int = -1) -> tuple[np.ndarray, np.ndarray, Resume | None]:
    """scipy's ``dijkstra(expanded, indices=start, limit=limit)`` on the heading-expanded graph
    ``graph`` describes, with (given ``h``, per vertex) A*'s reduced weights
    ``max(w + h(col) − h(row), eps)`` (``routing._reduced``).

    With ``ties`` (``h`` given, consistent) it is A* on the graph's own weights instead: states
    scanned by ``g + h`` up to ``limit``, their distances the very sums scipy's Dijkstra makes
    (``dist[u] + w``, the least over the in-neighbours scanned), and each state's predecessor taken
    by scipy's rule among the in-neighbours that attain its distance (the least distance, then the
    highest number). A state x on a route found below the limit has every such in-neighbour u
    scanned (``g(u) + h(u) ≤ g(u) + w + h(x) = g(x) + h(x)``), so its distance and predecessor are
    those scipy's Dijkstra with the limit on ``g`` gives: the same route, with fewer states
    searched. Elsewhere a distance is an upper bound of scipy's, or ∞ where ``g + h`` exceeds the
    limit.

    With ``resume`` the search goes on from a last one over the same states (numbered alike, the
    same ``limit`` and ``h``) whose graph has only grown since (edges added, none removed or made
    dearer): the last distances are upper bounds now, exact on what was there, and a cheaper path
    passes an added edge, so the states with an edge added (``resume.seeds``) are scanned again,
    and every state whose distance falls is pushed again and scanned again (label-correcting). The
    distances end as the search from scratch gives them: each the least sum ``dist[u] + w`` over its
    in-neighbours scanned, the same floats whatever the order (after a fall of the limit, the states
    within it: :class:`Resume`). The predecessors too, with ``ties``
    (its rule is applied at every relaxation and depends on the final distances and the numbers
    only); without ``ties`` a predecessor is the first in-neighbour of that distance to relax it,
    which depends on the order: only the distances are the search's from scratch there.

    With ``turns`` (``ties`` only, per state, ≥ 0) a state's bound is ``h`` of its vertex plus its
    ``turns``, and all of the above holds where that sum is consistent on the search's own costs
    (``h(x) + T(x) ≤ c(x, y) + h(y) + T(y)`` on every edge, c the move's or turn's weight with the
    floor ε): the precondition is on the sum, not on ``turns`` alone. A ``turns`` consistent on the
    turn penalties alone (``T(x) ≤ t(x, y) + T(y)``, t the edge's turn cost, 0 for a move) with a
    consistent ``h`` gives one; the corridor's T of ``routing._turns_to_go`` (clamped at
    ``C′ − d_s − D`` per vertex) is not consistent alone, only ``D + T`` is, with ``h`` the same D
    its limits were made with (``routing``'s ``lower = d_s + D``).

    With a ``budget`` (≥ 0) it pauses after popping that many entries and returns where it stands:
    the distances and predecessors so far (a distance an upper bound of its end, as each only
    falls) and the :class:`Resume` that goes on from there, its seeds the states still queued. Those
    are queued again at the keys they had (the pop order, by key then the higher state, is total),
    so a search paused and gone on with scans the same states in the same order as one run whole:
    the same distances and predecessors to the bit. The exits' search of a route's window pauses
    so, to stop where what it found already settles the next window (``routing._tiled_search``).

    Returns
    -------
    dist, pred
        Per state, as scipy returns them (∞ and −9999 where not reached; pred empty unless asked).
    paused
        Where it paused (``budget`` entries popped and states left queued): the search to go on
        with; None where it ran to the end.

    Raises
    ------
    ValueError
        Where the compiled search would read or write out of its arrays (numba checks no bounds: a
        start of −1 would wrap round silently, one past the states write beyond them): a start not
        among the states, with ``ties`` a start not a hub (its key reads ``h`` of the hub's vertex),
        an ``h`` not of one value per vertex, or predecessors asked for more states than their
        32 bits number (2³¹).
    """
    g = graph
    if ties and (h is None or not return_predecessors):
        raise ValueError("the tie rule needs the bound h and the predecessors")
    nk = g.n * g.k
    size = g.n * (2 * g.k + 1)
    if not 0 <= start < size:
        raise ValueError(f"the start state {start} is not among the {size} states")
    if ties and start < 2 * nk:
        raise ValueError(f"with ties the start must be a hub (states {2 * nk} … {size - 1}), not {start}")
    if turns is None:
        turns = np.zeros(0)
    elif not ties or len(turns) != size:
        raise ValueError("the turns' bound is added to h of a search with ties, one per state")
    if h is not None and len(h) != g.n:
        raise ValueError(f"h holds {len(h)} values, not one per vertex ({g.n})")
    if return_predecessors and size >= 2**31:
        raise ValueError(f"{size} states: more than the predecessors' 32 bits number")
    if resume is None:
        pred = np.full(size if return_predecessors else 0, NO_PRED, dtype=np.int32)
        dist = np.full(size, np.inf)
        dist[start] = 0.0
        seeds = np.array([start], dtype=np.int64)
    else:
        dist, pred, seeds = resume
        if len(dist) != size or len(pred) != (size if return_predecessors else 0):
            raise ValueError(f"the search resumed holds {len(dist)} distances and {len(pred)} predecessors, "
                             f"not those of {size} states")
        seeds = np.asarray(seeds, dtype=np.int64)
        if len(seeds) and not (0 <= seeds.min() and seeds.max() < size):
            raise ValueError(f"a state to scan again is not among the {size} states")
    astar = h is not None and not ties
    hh = np.ascontiguousarray(h, dtype=np.float64) if h is not None else np.zeros(1)
    left = _search(g.n, g.k, g.cheap, g.cheap_cost, g.hub_cost, g.region, g.local, g.n_lat, g.lat_kind, g.allowed,
                   g.offset, g.dirs_ptr, g.dirs, g.table, g.plain, g.w_kind, g.e_ptr, g.e_bin, g.e_col, g.e_val, hh,
                   astar, ties, g.eps, seeds, float(limit), dist, pred,
                   np.ascontiguousarray(turns, dtype=np.float64), _heap_index(size), int(budget))
    return dist, pred, (Resume(dist, pred, left) if len(left) else None)
