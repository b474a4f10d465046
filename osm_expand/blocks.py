"""City blocks: the faces of the street graph, found by wall following (004 §4.3).

Every junction-to-junction piece of a street is an edge with its full shape.
Walking an edge and, at each junction, turning onto the next edge clockwise
from the one just arrived on (always keeping the wall on the left) goes once
around a face; doing this from both directions of every edge finds every
face exactly once. Faces traced counter-clockwise are blocks; the clockwise
ones are the outer boundaries of connected pieces of the network.

Works on the town as mapped: dead-end streets (cul-de-sac trees) bound no
block, so the walk runs on the graph's 2-core, and a street touching itself
is cut where it does. Each block remembers the street under every edge of
its outline (``Block.street_ids``), which is the frontage lots need.

Kept as blocks: valid polygons of at least ``min_area`` and at most
``max_area`` square metres with at most ``max_edges`` edges (004 discards
"blocks with too many faces"). Bridges and tunnels make the graph
non-planar, so faces can overlap; of two partly overlapping faces the
larger goes, and a face around a separate piece of network gets it as a
hole, which leaves the blocks disjoint.

Known limitation: a face whose ring is not simple (a bridge crosses it, or
two streets cross on one layer without a shared node, a mapping error) is
left out, and then does not become a hole in the block around it.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely

from osm_expand.measures import two_core
from osm_expand.model import Block, Origin, Street, StreetNetwork
from osm_expand.model.topology import flat_nodes, junction_mask, piece_table, split_self_touching


@dataclass(frozen=True)
class BlockOptions:
    min_area: float = 100.0  #: m²: slivers between near-parallel streets are not blocks
    max_area: float = 2_000_000.0  #: m²: bigger faces are fields and forests between villages
    max_edges: int = 60  #: junction-to-junction edges around a face (004: too many is no block)


@dataclass(frozen=True)
class _Pieces:
    """Junction-to-junction pieces of the 2-core: end nodes, polylines and street ids.

    The polylines are one array, ``points[offsets[i]:offsets[i + 1]]`` for piece ``i``: gathered
    by one index array rather than a Python list of 12,000 arrays a year (Campo Grande).
    """

    u: np.ndarray
    v: np.ndarray
    points: np.ndarray  #: (M, 2) every piece's points, piece after piece
    offsets: np.ndarray  #: (n + 1,) where each piece's points start in ``points``
    street_id: np.ndarray

    def __len__(self) -> int:
        return len(self.u)


def _pieces(net: StreetNetwork) -> _Pieces:
    streets, flat = _cut_where_self_touching(net.streets)
    nodes, owner = flat  # once for the junctions, the pieces and their points
    table = piece_table(streets, junction_mask(streets, len(net.xy), flat=flat), flat=flat)
    keep = two_core(table["u"], table["v"], len(net.xy))  # pieces on a cycle or between cycles
    street_start = np.concatenate([[0], np.cumsum(np.bincount(owner, minlength=len(streets)))])
    k, a, b = table["street"][keep], table["a"][keep], table["b"][keep]
    sizes = b - a + 1
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    index = np.repeat(street_start[k] + a - offsets[:-1], sizes) + np.arange(int(offsets[-1]))
    ids = np.array([streets[i].id for i in k.tolist()], dtype=np.int64)
    return _Pieces(u=table["u"][keep], v=table["v"][keep], points=net.xy[nodes[index]], offsets=offsets,
                   street_id=ids)


def _cut_where_self_touching(streets: Sequence[Street]) -> tuple[list[Street], tuple[np.ndarray, np.ndarray]]:
    """:func:`split_self_touching` of every street, and :func:`flat_nodes` of the result.

    The streets that visit no node twice come back as they are (split_self_touching's own
    first test): they are found in one sort of every (street, node) pair, and only the few
    others are split street by street (a Python call a street was 0.96 of the pieces' 1.59 s
    over Campo Grande's 20 blocks calls under cProfile). The same streets, in the same order.
    """
    nodes, owner = flat = flat_nodes(streets)
    n = len(streets)
    sizes = np.bincount(owner, minlength=n)
    if len(nodes):
        order = np.lexsort((nodes, owner))
        repeat = (owner[order][1:] == owner[order][:-1]) & (nodes[order][1:] == nodes[order][:-1])
        twice = np.zeros(n, dtype=bool)
        twice[owner[order][1:][repeat]] = True
    else:
        twice = np.zeros(n, dtype=bool)
    odd = twice | (sizes < 2)
    odd |= np.fromiter((type(s.nodes) is not tuple for s in streets), dtype=bool, count=n)
    if not odd.any():
        return list(streets), flat
    cut = np.flatnonzero(odd)
    split = [split_self_touching(streets[k]) for k in cut.tolist()]  # the rings, roundabouts, spikes
    count = np.ones(n, dtype=np.int64)
    count[cut] = [len(p) for p in split]
    first = np.cumsum(count) - count  # each street's first piece in the result
    out: list[Street] = list(streets)
    for k, pieces in zip(cut[::-1].tolist(), split[::-1]):  # from the end: the places before stay put
        out[k:k + 1] = pieces
    # the result's flat nodes: the untouched streets' from ``flat``, the pieces' made here, merged by the
    # street they came from (a stable sort: a street is one or the other)
    pieces = [p for ps in split for p in ps]
    piece_nodes, piece_owner = flat_nodes(pieces)
    piece_street = np.repeat(cut, count[cut])  # the street each piece came from
    piece_at = first[piece_street] + np.arange(len(pieces)) - np.repeat(np.cumsum(count[cut]) - count[cut],
                                                                          count[cut])
    keep = ~odd[owner]
    order = np.argsort(np.concatenate([owner[keep], piece_street[piece_owner]]), kind="stable")
    return out, (np.concatenate([nodes[keep], piece_nodes])[order],
                 np.concatenate([first[owner[keep]], piece_at[piece_owner]])[order])


def faces(net: StreetNetwork) -> list[tuple[np.ndarray, int, np.ndarray]]:
    """Every face of the street graph's 2-core.

    Returns
    -------
    list of (ring, edges, street_ids)
        ``ring`` a closed (k + 1, 2) array (counter-clockwise if the face is
        bounded), ``edges`` the number of junction-to-junction pieces around
        it, ``street_ids`` the (k,) street id under each ring edge.
    """
    found = _face_arrays(net)
    if found is None:
        return []
    return list(zip(found.rings(), found.edges, found.street_ids()))


@dataclass(frozen=True)
class _Faces:
    """Every face of the 2-core as flat arrays: face ``f``'s closed ring is ``closed[ring_at[f]:ring_at[f + 1]]``
    and the street ids under its edges ``ids[id_at[f]:id_at[f + 1]]`` (one fewer than its points)."""

    closed: np.ndarray  #: (P + F, 2) every ring's points, each ring closed (its first point again after its last)
    ring_at: np.ndarray  #: (F + 1,)
    ids: np.ndarray  #: (P,)
    id_at: np.ndarray  #: (F + 1,)
    edges: list[int]  #: junction-to-junction pieces around each face

    def rings(self) -> list[np.ndarray]:
        at = self.ring_at.tolist()
        return [self.closed[a:b] for a, b in zip(at[:-1], at[1:])]  # views, as np.split gives, a third of its cost

    def street_ids(self) -> list[np.ndarray]:
        at = self.id_at.tolist()
        return [self.ids[a:b] for a, b in zip(at[:-1], at[1:])]

    def signed_areas(self) -> np.ndarray:
        """(F,) each ring's signed area (m², positive counter-clockwise), exactly :func:`_signed_area`'s sign.

        The shoelace sums of all rings at once; where a sum is so near zero
        that the order of the additions could change its sign, the ring's
        own :func:`_signed_area` decides, so the blocks are those of the
        ring-by-ring test.
        """
        x, y = self.closed[:, 0], self.closed[:, 1]
        cross = np.append(x[:-1] * y[1:] - x[1:] * y[:-1], 0.0)  # the step from each point to the next
        size = np.abs(np.append(x[:-1] * y[1:], 0.0)) + np.abs(np.append(x[1:] * y[:-1], 0.0))
        last = self.ring_at[1:] - 1  # each ring's last point steps into the next ring: not an edge
        cross[last], size[last] = 0.0, 0.0
        start = self.ring_at[:-1]
        area = 0.5 * np.add.reduceat(cross, start) if len(start) else np.zeros(0)
        scale = np.add.reduceat(size, start) if len(start) else np.zeros(0)
        unsure = np.flatnonzero(np.abs(area) <= 1e-9 * scale)
        for f in unsure.tolist():
            area[f] = _signed_area(self.closed[self.ring_at[f]:self.ring_at[f + 1]])
        return area


def _face_arrays(net: StreetNetwork) -> _Faces | None:
    """:func:`faces` as flat arrays (None: no face); :func:`blocks` reads these, to loop in Python only over
    the faces that may be blocks."""
    pc = _pieces(net)
    if len(pc) == 0:
        return None
    sequence, cycle_start = _face_cycles(pc)
    # half-edge h = 2i runs along piece i, h = 2i + 1 back; each contributes its points but the last
    offsets, points = pc.offsets, pc.points
    sizes = np.diff(offsets)
    piece, backward = sequence // 2, (sequence % 2).astype(bool)
    steps = sizes[piece] - 1
    first = np.where(backward, offsets[piece + 1] - 1, offsets[piece])
    within = np.arange(int(steps.sum())) - np.repeat(np.cumsum(steps) - steps, steps)
    index = np.repeat(first, steps) + np.where(np.repeat(backward, steps), -within, within)
    ring_points = points[index]
    ring_ids = np.repeat(pc.street_id[piece], steps)
    bounds = np.concatenate([[0], np.cumsum(steps)[cycle_start[1:] - 1], [len(index)]])
    # every ring closed at once (its first point again after its last), then cut into faces
    closed = ring_points[np.insert(np.arange(len(index)), bounds[1:], bounds[:-1])]
    edges = np.diff(np.append(cycle_start, len(sequence))).tolist()
    return _Faces(closed=closed, ring_at=bounds + np.arange(len(bounds)), ids=ring_ids, id_at=bounds, edges=edges)


def _face_cycles(pc: _Pieces) -> tuple[np.ndarray, np.ndarray]:
    """The half-edges in the order the faces walk them, and where each face starts in that order.

    The next half-edge after ``h`` is the one leaving ``h``'s head next
    clockwise from the way back (``h ^ 1``): a permutation, whose cycles are
    the faces, taken in the order of their smallest half-edge.
    """
    n = len(pc)
    start = np.empty(2 * n, dtype=np.int64)
    start[0::2], start[1::2] = pc.u, pc.v
    head, tail = pc.offsets[:-1], pc.offsets[1:] - 1  # each piece's first and last point
    first_step = np.concatenate([pc.points[head + 1] - pc.points[head], pc.points[tail - 1] - pc.points[tail]])
    order = np.concatenate([np.arange(0, 2 * n, 2), np.arange(1, 2 * n, 2)])
    angle = np.empty(2 * n)
    angle[order] = np.arctan2(first_step[:, 1], first_step[:, 0])
    around = np.lexsort((angle, start))  # per node, leaving half-edges counter-clockwise
    rank = np.empty(2 * n, dtype=np.int64)
    rank[around] = np.arange(2 * n)
    node_first = np.searchsorted(start[around], start)  # where each half-edge's tail starts in ``around``
    degree = np.bincount(start)[start]
    twin = np.arange(2 * n) ^ 1
    tail = node_first[twin]
    following = around[tail + (rank[twin] - tail - 1) % degree[twin]]
    if np.array_equal(np.sort(following), np.arange(2 * n)):
        return _cycles(following)
    nxt = following.tolist()  # not a permutation (never seen): walk it as it is
    used = [False] * (2 * n)
    sequence: list[int] = []
    cycle_start: list[int] = []
    for h0 in range(2 * n):
        if used[h0]:
            continue
        cycle_start.append(len(sequence))
        h = h0
        while not used[h]:
            used[h] = True
            sequence.append(h)
            h = nxt[h]
    return np.array(sequence, dtype=np.int64), np.array(cycle_start, dtype=np.int64)


def _cycles(nxt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cycles of the permutation ``nxt``, each from its least element, in the order of those:
    :func:`_face_cycles`' walk in vectorised rounds (the walk in Python was 3 s of Campo Grande's
    30 years). Each element learns its cycle's least by doubling windows along the cycle (when
    no window's least changes from one round to the next, every one is the cycle's), then its
    place by list ranking (pointer jumping) on the cycle cut before its least."""
    m = len(nxt)
    least, step = np.arange(m), nxt.copy()
    while True:  # least[h]: the least of the 2^k elements from h on
        wider = np.minimum(least, least[step])
        if np.array_equal(wider, least):
            break
        least, step = wider, step[step]
    end = nxt == least  # the element before the cycle's least ends the walk
    left = np.where(end, 0, 1)  # steps left to the end
    jump = np.where(end, np.arange(m), nxt)
    while not np.array_equal(jump, jump[jump]):
        left, jump = left + left[jump], jump[jump]
    place = np.bincount(least, minlength=m)[least] - 1 - left
    sequence = np.lexsort((place, least)).astype(np.int64)
    return sequence, np.flatnonzero(place[sequence] == 0).astype(np.int64)


@dataclass
class FaceMemo:
    """What :func:`blocks` learned about last call's faces, to skip it for faces that did not change.

    A year of the engine changes a few faces of thousands; a face is known
    by its ring's exact coordinates, so a face that is still there gets back
    its polygon (or its invalidity) and the faces it overlaps or nests with,
    and only new faces are tested against the rest. The blocks are the same
    as without the memo.
    """

    polygons: dict[bytes, shapely.Polygon | None] = field(default_factory=dict)  #: ring → polygon (None: invalid)
    pairs: set[tuple[bytes, bytes]] = field(default_factory=set)  #: faces that overlap, contain or lie within


def blocks(net: StreetNetwork, options: BlockOptions | None = None, *, origin: Origin = Origin.SOURCE,
           year: int | None = None, memo: FaceMemo | None = None,
           stamp: Callable[[tuple[int, ...]], tuple[Origin, int | None]] | None = None) -> list[Block]:
    """The plausible, pairwise disjoint blocks of a network, from its streets' real shapes.

    Parameters
    ----------
    net : StreetNetwork
        Any network: the town as mapped (dead ends and all) or a simplified one.
    options : BlockOptions
    origin, year
        Stamped on every block.
    stamp : callable, optional
        ``stamp(street_ids) -> (origin, year)`` of each block instead (the
        engine's: from the streets around it), so that a block is made once
        rather than made and then replaced.
    memo : FaceMemo, optional
        Kept by a caller that asks again after small changes (the engine,
        every year): read, then updated to this network's faces.

    Returns
    -------
    list of Block
        Numbered 0, 1, ... in the order the faces were found.
    """
    opts = options or BlockOptions()
    known = memo if memo is not None else FaceMemo()
    found = _face_arrays(net) or _Faces(closed=np.zeros((0, 2)), ring_at=np.zeros(1, dtype=np.int64),
                                        ids=np.zeros(0, dtype=np.int64), id_at=np.zeros(1, dtype=np.int64), edges=[])
    # counter-clockwise rings of at least three edges: the only faces that may be blocks (the memo holds only
    # rings that passed this test, and a ring is its key, so a remembered ring passes it again)
    may = np.flatnonzero((np.diff(found.ring_at) >= 4) & (found.signed_areas() > 0))
    ring_at, id_at = found.ring_at.tolist(), found.id_at.tolist()
    remembered, closed, face_edges = known.polygons, found.closed, found.edges
    faces_may = may.tolist()
    raw = np.ascontiguousarray(closed, dtype=np.float64).tobytes()  # each ring's key cut from one buffer: its
    step = 2 * 8  # points' bytes, as ``closed[a:b].tobytes()`` gives them, without a numpy slice a face
    face_keys = [raw[step * ring_at[f]:step * ring_at[f + 1]] for f in faces_may]
    made = [remembered.get(key, _UNKNOWN) for key in face_keys]
    todo = [i for i, poly in enumerate(made) if poly is _UNKNOWN]
    for i, poly in zip(todo, _valid_polygons(found, may[todo])):  # the faces the memo has not seen, at once
        made[i] = poly
    seen = dict(zip(face_keys, made))  # a key twice (duplicated ways): the last face's, as one by one
    # a face walking a street twice or crossing a bridge (None) is left out; the rest are gathered by
    # index, not appended one by one (a grown town's 5,000 faces a year)
    valid = [i for i, poly in enumerate(made) if poly is not None]
    bounded = [made[i] for i in valid]
    keys = [face_keys[i] for i in valid]
    kept_faces = [faces_may[i] for i in valid]
    unique = len(set(keys)) == len(keys)  # two faces on one ring (duplicated ways): ask about every face
    pairs = _settled_pairs(bounded, keys, known if unique else FaceMemo())
    if memo is not None:
        memo.polygons = seen if unique else {}
        memo.pairs = {(keys[i], keys[j]) for i, j in pairs.tolist()} if unique else set()
    # holes first (a sliver inside a block is still a hole in it), plausibility after
    disjoint = _disjoint(bounded, pairs)
    area = shapely.area(np.array([p for _, p in disjoint], dtype=object)).tolist() if disjoint else []
    kept = [(k, p) for (k, p), a in zip(disjoint, area)
            if face_edges[kept_faces[k]] <= opts.max_edges and opts.min_area <= a <= opts.max_area]
    out = []
    holes = shapely.get_num_interior_rings(np.array([p for _, p in kept], dtype=object)).tolist() if kept else []
    all_ids = found.ids.tolist()
    for i, ((k, p), holed) in enumerate(zip(kept, holes)):  # holes counted at once: p.interiors is slow
        f = kept_faces[k]
        a, b = id_at[f], id_at[f + 1]  # the ids' slice, cut only for the blocks kept
        ids = tuple(all_ids[a:b]) if not holed else tuple(_edge_streets(p, bounded[k], found.ids[a:b]).tolist())
        how, when = (origin, year) if stamp is None else stamp(ids)
        out.append(Block(polygon=p, street_ids=ids, id=i, origin=how, year=when))
    return out


#: A face the memo has not seen (its remembered value may be None: an invalid face).
_UNKNOWN = object()


def _valid_polygons(found: _Faces, faces: np.ndarray) -> list[shapely.Polygon | None]:
    """The polygons of faces ``faces`` (indices into ``found``), None where one is not valid: made and tested
    in one call each (one by one, 0.8 s of a 10,000-street town's first blocks), the same polygons."""
    if not len(faces):
        return []
    start = found.ring_at[faces]
    size = found.ring_at[faces + 1] - start
    index = np.repeat(start - (np.cumsum(size) - size), size) + np.arange(int(size.sum()))
    polys = shapely.polygons(shapely.linearrings(found.closed[index], indices=np.repeat(np.arange(len(faces)), size)))
    return [p if ok else None for p, ok in zip(polys.tolist(), shapely.is_valid(polys).tolist())]


def _edge_streets(poly: shapely.Polygon, face: shapely.Polygon, ids: np.ndarray) -> np.ndarray:
    """Street ids under the exterior edges of ``poly`` (a face with holes cut), looked up by the face's edges."""
    coords = np.asarray(face.exterior.coords)
    lookup = {}
    for (a, b), k in zip(zip(map(tuple, coords[:-1].tolist()), map(tuple, coords[1:].tolist())), ids.tolist()):
        lookup[(a, b)] = lookup[(b, a)] = k
    ext = np.asarray(poly.exterior.coords)
    return np.array([lookup.get((a, b), -1)
                     for a, b in zip(map(tuple, ext[:-1].tolist()), map(tuple, ext[1:].tolist()))],
                    dtype=np.int64)


def polygons(items: list[Block]) -> list[shapely.Polygon]:
    """The blocks' polygons."""
    return [b.polygon for b in items]


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1]))


def _settled_pairs(polys: list[shapely.Polygon], keys: list[bytes], memo: FaceMemo) -> np.ndarray:
    """Pairs (i < j) of faces that overlap or nest, sorted; faces that only share edges touch.

    Pairs of faces the memo knows come from it; only the new faces are
    queried against all (each of ``contains`` and ``within`` from the new
    side covers one orientation).
    """
    if not polys:
        return np.zeros((0, 2), dtype=np.int64)
    index = {k: i for i, k in enumerate(keys)}
    new = np.array([k not in memo.polygons for k in keys], dtype=bool)
    old = [(index[a], index[b]) for a, b in memo.pairs if a in index and b in index]
    found = [np.array(old, dtype=np.int64).reshape(-1, 2)]
    if new.any():
        tree = shapely.STRtree(polys)
        asked = np.flatnonzero(new)
        # every face new (the first call): the ``within`` pairs are the ``contains`` pairs turned round, and
        # the pairs are sorted below, so that third query (a quarter of the first blocks of a large town) is left out
        for predicate in ("overlaps", "contains") if new.all() else ("overlaps", "contains", "within"):
            q, j = tree.query(np.asarray(polys, dtype=object)[asked], predicate=predicate)
            found.append(np.stack([asked[q], j], axis=1))
    pairs = np.sort(np.concatenate(found), axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    return np.unique(pairs, axis=0)


def _disjoint(polys: list[shapely.Polygon], pairs: np.ndarray) -> list[tuple[int, shapely.Polygon]]:
    """Make the faces pairwise disjoint; returns (index, polygon) of those kept.

    A face that contains another (a separate piece of network inside a
    block) gets it as a hole; of two faces that partly overlap (a bridge or
    tunnel crossing without a junction) the larger goes.
    """
    if not polys:
        return []
    polys = list(polys)
    drop: set[int] = set()
    holes: dict[int, list[int]] = {}
    for i, j in pairs.tolist():
        shared = polys[i].intersection(polys[j]).area
        if shared <= 1.0:
            continue
        small, large = (i, j) if polys[i].area <= polys[j].area else (j, i)
        if shared >= polys[small].area - 1.0:
            holes.setdefault(large, []).append(small)
        else:
            drop.add(large)
    for large, inner in holes.items():
        polys[large] = polys[large].difference(shapely.union_all([polys[k] for k in inner]))
    arr = np.array(polys, dtype=object)
    ok = ~shapely.is_empty(arr) & (shapely.get_type_id(arr) == shapely.GeometryType.POLYGON)  # at once: per
    return [(k, polys[k]) for k in np.flatnonzero(ok).tolist() if k not in drop]  # polygon, a fifth of blocks()
