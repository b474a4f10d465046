"""Junction bookkeeping shared by every simplification pass.

A *junction* is a node that two or more distinct streets share. After
:func:`split_self_touching` no street visits a node twice (a ring only
repeats its first node at the end), so this single definition also covers
the thesis's "twice in one street".
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from itertools import chain

import numpy as np

from osm_expand.model.geometry import polyline_length
from osm_expand.model.network import Street, StreetNetwork, segment_nodes


def flat_nodes(streets: Sequence[Street | None]) -> tuple[np.ndarray, np.ndarray]:
    """Every street's nodes in one array, and the index of the street each belongs to (None: skipped)."""
    sizes = np.fromiter((len(s.nodes) if s is not None else 0 for s in streets), dtype=np.int64, count=len(streets))
    nodes = np.fromiter(chain.from_iterable(s.nodes for s in streets if s is not None), dtype=np.int64,
                        count=int(sizes.sum()))
    return nodes, np.repeat(np.arange(len(streets), dtype=np.int64), sizes)


def street_counts(streets: Sequence[Street], n_nodes: int, *, flat: tuple[np.ndarray, np.ndarray] | None = None
                  ) -> np.ndarray:
    """How many distinct streets reference each node (``flat``: :func:`flat_nodes` of ``streets`` if the
    caller has it)."""
    if not streets:
        return np.zeros(n_nodes, dtype=np.int32)
    nodes, owner = flat if flat is not None else flat_nodes(streets)
    pairs = np.sort(owner * n_nodes + nodes)
    first = np.ones(len(pairs), dtype=bool)  # each (street, node) once
    first[1:] = pairs[1:] != pairs[:-1]
    # a sort, not np.unique: its hash table is ten times slower on a country's million keys
    return np.bincount(pairs[first] % n_nodes, minlength=n_nodes).astype(np.int32)


#: Segments a junction of a simplified network can take: two streets passing through.
MAX_DEGREE = 4


def segment_degree(streets: Sequence[Street], n_nodes: int) -> np.ndarray:
    """Segments meeting at each node: a street passing through counts 2, one ending there 1.

    Each segment (:func:`~osm_expand.model.network.segment_nodes`, one flat array of the streets' nodes) counts once
    at either end: the segments' ends listed one by one took 0.3 s of Campo Grande's run (cProfile; 55 asks; its
    3,600 streets as read: 2.0 -> 0.8 ms an ask). A street of one node has no segment and counts nothing.
    """
    _, u, v = segment_nodes(streets)
    length = max(n_nodes, int(max(u.max(), v.max())) + 1) if len(u) else n_nodes
    return np.bincount(u, minlength=length) + np.bincount(v, minlength=length)


def junction_mask(streets: Sequence[Street], n_nodes: int, *, flat: tuple[np.ndarray, np.ndarray] | None = None
                  ) -> np.ndarray:
    return street_counts(streets, n_nodes, flat=flat) >= 2


def clean_nodes(nodes: Iterable[int]) -> tuple[int, ...] | None:
    """Drop repeated consecutive nodes; None when nothing street-like is left."""
    out: list[int] = []
    for n in nodes:
        if not out or out[-1] != n:
            out.append(n)
    if len(out) < 2 or (out[0] == out[-1] and len(out) < 4):
        return None
    return tuple(out)


def split_self_touching(street: Street) -> list[Street]:
    """Cut a street at every node it visits more than once.

    The pieces visit each node once, except that a piece may be a ring; a
    back-and-forth spike (a-b-a) disappears.
    """
    if isinstance(street.nodes, tuple) and len(street.nodes) >= 2 and len(set(street.nodes)) == len(street.nodes):
        return [street]  # the common case, and the street unchanged: no copy (blocks run this every year)
    nodes = clean_nodes(street.nodes)
    if nodes is None:
        return []
    seen: dict[int, int] = {}
    for n in nodes:
        seen[n] = seen.get(n, 0) + 1
    closed = nodes[0] == nodes[-1]
    repeated = {n for n, c in seen.items() if c > 1 and not (closed and n == nodes[0] and c == 2)}
    if not repeated:
        return [street.with_nodes(nodes)]
    cuts = [0] + [i for i in range(1, len(nodes) - 1) if nodes[i] in repeated] + [len(nodes) - 1]
    pieces = []
    for a, b in zip(cuts, cuts[1:]):
        piece = clean_nodes(nodes[a:b + 1])
        if piece is not None:
            pieces.append(street.with_nodes(piece))
    return pieces


def spaced_points(pts: np.ndarray, step: float, fixed: np.ndarray | None = None) -> list[int]:
    """Indices of a polyline's points to keep so that no step is shorter than ``step``.

    The ends and the ``fixed`` points (junctions) always stay; any other
    point stays only when it is ``step`` or more from the last point kept and
    from the next point that must stay.
    """
    n = len(pts)
    must = np.zeros(n, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool).copy()
    must[[0, n - 1]] = True
    next_must = np.minimum.accumulate(np.where(must, np.arange(n), n)[::-1])[::-1].tolist()
    xy, must = np.asarray(pts, dtype=float).tolist(), must.tolist()  # Python floats: a point at a time
    keep = [0]
    for i in range(1, n - 1):
        if must[i]:
            keep.append(i)
            continue
        (x, y), (kx, ky), (nx, ny) = xy[i], xy[keep[-1]], xy[next_must[i + 1]]
        if math.hypot(x - kx, y - ky) >= step and math.hypot(nx - x, ny - y) >= step:
            keep.append(i)
    return keep + [n - 1] if n > 1 else keep


def junction_stops(street: Street, junction: np.ndarray) -> list[int]:
    """Positions of the street's real junctions (its ends only when they are junctions)."""
    return [i for i, n in enumerate(street.nodes) if junction[n]]


def piece_table(streets: Sequence[Street], junction: np.ndarray, *,
                flat: tuple[np.ndarray, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Every junction-to-junction piece of every street, vectorised.

    Columns: ``street``, positions ``a`` and ``b`` along it, end nodes ``u``, ``v``. ``flat``:
    :func:`flat_nodes` of ``streets``, when the caller has it (the blocks read the nodes too).
    """
    if not streets:
        empty = np.zeros(0, dtype=np.int64)
        return {"street": empty, "a": empty, "b": empty, "u": empty, "v": empty}
    nodes, owner = flat if flat is not None else flat_nodes(streets)
    offsets = np.concatenate([[0], np.cumsum(np.bincount(owner, minlength=len(streets)))])
    bound = junction[nodes].copy()
    bound[offsets[:-1]] = True
    bound[offsets[1:] - 1] = True
    idx = np.flatnonzero(bound)
    same = owner[idx[1:]] == owner[idx[:-1]]
    a_glob, b_glob = idx[:-1][same], idx[1:][same]
    k = owner[a_glob]
    return {"street": k, "a": a_glob - offsets[k], "b": b_glob - offsets[k],
            "u": nodes[a_glob], "v": nodes[b_glob]}


def lengths(xy: np.ndarray, nodes: Sequence[int]) -> float:
    """Length (m) of the polyline through ``nodes``."""
    return polyline_length(xy[np.asarray(nodes, dtype=np.intp)])


def point_along(xy: np.ndarray, nodes: Sequence[int], dist: float) -> tuple[np.ndarray, int]:
    """The point ``dist`` metres along the polyline through ``nodes`` (its end if shorter),
    and the index of the segment it lies on."""
    pts = xy[np.asarray(nodes, dtype=np.intp)]
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    j = int(np.clip(np.searchsorted(cum, dist) - 1, 0, len(pts) - 2))
    if dist >= cum[-1]:
        return pts[-1], len(pts) - 2
    t = (dist - cum[j]) / max(cum[j + 1] - cum[j], 1e-12)
    return pts[j] + t * (pts[j + 1] - pts[j]), j


def heading(xy: np.ndarray, nodes: Sequence[int], from_start: bool, reach: float) -> np.ndarray:
    """Unit vector pointing from a street end into the street.

    Taken towards the point ``reach`` metres along the street (or its far end)
    so that a jittery first shape segment does not decide a merge.
    """
    seq = nodes if from_start else nodes[::-1]
    v = point_along(xy, seq, reach)[0] - xy[seq[0]]
    norm = float(np.hypot(*v))
    return v / norm if norm > 0 else v


def headings(xy: np.ndarray, streets: Sequence[Street], street: np.ndarray, from_start: np.ndarray,
             reach: float, width: int = 16) -> np.ndarray:
    """:func:`heading` of many street ends at once, (E, 2), bit for bit the same.

    Each end's first ``width`` nodes are walked column by column with the
    same arithmetic, in the same order, as :func:`point_along`; the rare end
    whose first ``width`` nodes stay within ``reach`` of it is left to
    :func:`heading`.
    """
    out = np.zeros((len(street), 2))
    if not len(street):
        return out
    nodes, owner = flat_nodes(streets)
    sizes = np.bincount(owner, minlength=len(streets))
    begin = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    size = sizes[street]
    k = int(min(width, size.max()))
    step = np.minimum(np.arange(k)[None, :], size[:, None] - 1)  # the last node repeats past a street's end
    pos = np.where(from_start[:, None], begin[street][:, None] + step, (begin + sizes - 1)[street][:, None] - step)
    pts = xy[nodes[pos]]
    cum = np.zeros((len(street), k))
    if k > 1:
        cum[:, 1:] = np.cumsum(np.hypot(*np.moveaxis(np.diff(pts, axis=1), 2, 0)), axis=1)
    total = cum[:, -1]
    vector = (size >= 2) & ((size <= k) | (total > reach))
    for e in np.flatnonzero(~vector).tolist():
        out[e] = heading(xy, streets[street[e]].nodes, bool(from_start[e]), reach)
    rows = np.flatnonzero(vector)
    j = np.clip((cum[rows] < reach).sum(axis=1) - 1, 0, size[rows] - 2)
    c0, c1 = cum[rows, j], cum[rows, j + 1]
    t = (reach - c0) / np.maximum(c1 - c0, 1e-12)
    point = pts[rows, j] + t[:, None] * (pts[rows, j + 1] - pts[rows, j])
    point = np.where((reach >= total[rows])[:, None], pts[rows, k - 1], point)
    v = point - pts[rows, 0]
    norm = np.hypot(*v.T)
    nz = norm > 0
    v[nz] = v[nz] / norm[nz, None]
    out[rows] = v
    return out


def end_angles(ha: np.ndarray, hb: np.ndarray) -> np.ndarray:
    """Angles (degrees) between paired unit headings, (E, 2) each: 180 is straight on.

    The dot products go through ``@`` one pair at a time, as a scalar ``ha @ hb``
    does (BLAS may fuse its multiply-add), so each angle is bit for bit the scalar one.
    """
    dots = (ha[:, None, :] @ hb[:, :, None])[:, 0, 0]
    return np.degrees(np.arccos(np.clip(dots, -1.0, 1.0)))


def summary(net: StreetNetwork) -> dict[str, int]:
    """Counts that every pass reports."""
    counts = street_counts(net.streets, len(net.xy))
    return {
        "street_nodes": int((counts > 0).sum()),
        "junctions": int((counts >= 2).sum()),
        "streets": len(net.streets),
    }


def append_nodes(net: StreetNetwork, new_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Arrays with ``new_xy`` appended as synthetic nodes (OSM id 0); returns the first new index."""
    first = len(net.xy)
    if len(new_xy) == 0:
        return net.xy, net.node_ids, first
    xy = np.vstack([net.xy, np.asarray(new_xy, dtype=float).reshape(-1, 2)])
    ids = np.concatenate([net.node_ids, np.zeros(len(new_xy), dtype=np.int64)])
    return xy, ids, first


def replace_nodes(streets: Sequence[Street], remap: dict[int, int]) -> tuple[Street, ...]:
    """Streets with nodes renamed by ``remap``, cleaned and cut where they now touch themselves."""
    out: list[Street] = []
    for s in streets:
        if not any(n in remap for n in s.nodes):
            out.append(s)
            continue
        nodes = clean_nodes(remap.get(n, n) for n in s.nodes)
        if nodes is not None:
            out.extend(split_self_touching(s.with_nodes(nodes)))
    return tuple(out)


def without_segments(streets: Sequence[Street], drop: set[tuple[int, int]]) -> tuple[Street, ...]:
    """Streets with the segments ``drop`` (node pairs, either order) removed; a street is cut where one goes."""
    out: list[Street] = []
    for s in streets:
        run: list[int] = [s.nodes[0]]
        for a, b in zip(s.nodes[:-1], s.nodes[1:]):
            if (a, b) in drop or (b, a) in drop:
                if len(run) >= 2:
                    out.append(s.with_nodes(run))
                run = [b]
            else:
                run.append(b)
        if len(run) >= 2:
            out.append(s.with_nodes(run) if len(run) != len(s.nodes) else s)
    return tuple(out)


def segment_neighbours(streets: Sequence[Street]) -> dict[int, list[int]]:
    """Per node, the nodes one segment away, once per segment and in the streets' order (a segment two
    streets share counts twice): what :func:`dangling_chains` walks, made once by a caller that walks
    many chains of one network (:func:`dangling_chain`)."""
    neighbours: dict[int, list[int]] = {}
    for s in streets:
        for a, b in zip(s.nodes[:-1], s.nodes[1:]):
            neighbours.setdefault(a, []).append(b)
            neighbours.setdefault(b, []).append(a)
    return neighbours


def dangling_chain(neighbours: dict[int, list[int]], leaf: int,
                   without: tuple[int, int] | None = None) -> set[tuple[int, int]] | None:
    """The segments from ``leaf`` back to the nearest junction (see :func:`dangling_chains`), walking
    ``neighbours`` (:func:`segment_neighbours`) as if the segment ``without`` (node pair, either order)
    were gone, as :func:`without_segments` would take it away; None when ``leaf`` is then no leaf.

    Taking one segment out of the map while walking, instead of making the streets without it and their
    map again, makes each of many candidate removals cost only its chain's length.
    """
    gone = frozenset(without) if without is not None else frozenset()

    def around(node: int) -> list[int]:
        near = neighbours.get(node, [])
        if node in gone:
            return [n for n in near if frozenset((node, n)) != gone]
        return near

    if len(around(leaf)) != 1:
        return None
    chain: set[tuple[int, int]] = set()
    prev, cur = None, leaf
    while True:
        nxt = [n for n in around(cur) if n != prev]
        if not nxt:
            break
        chain.add((min(cur, nxt[0]), max(cur, nxt[0])))
        prev, cur = cur, nxt[0]
        if len(around(cur)) != 2:
            break
    return chain


def dangling_chains(streets: Sequence[Street], leaves: Iterable[int]) -> dict[int, set[tuple[int, int]]]:
    """Per leaf (a node with one segment), the segments back to the nearest junction.

    Walks through nodes with two segments; stops at a node with three or
    more (kept) or at another leaf (the whole isolated chain goes). Segments
    are node pairs, smaller node first.
    """
    neighbours = segment_neighbours(streets)
    chains: dict[int, set[tuple[int, int]]] = {}
    for leaf in leaves:
        chain = dangling_chain(neighbours, leaf)
        if chain is not None:
            chains[leaf] = chain
    return chains
