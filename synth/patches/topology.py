"""The district's topology: cut ends trimmed, pieces joined or dropped, dead ends and loops brought to its
town's neighbourhoods' shares (:class:`_Aim`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree

from osm_expand.model import Origin, StreetNetwork, network_from_lines
from osm_expand.model.components import component_labels
from osm_expand.model.topology import (
    dangling_chain,
    dangling_chains,
    segment_degree,
    segment_neighbours,
    without_segments,
)
from synth.patches.options import PatchOptions
from synth.patches.quilt import _Board, _meet, _network, _Quilt


@dataclass(frozen=True)
class _Aim:
    """What the district's topology aims at: its town's neighbourhoods' median dead-end share (of
    junctions and dead ends) and 2-core share (of street length)."""

    dead_end_share: float
    two_core_share: float
    #: the town's median cul-de-sac (m, from its dead end back to its junction): the length kept stubs
    #: come nearest first (0: shortest first)
    cul_de_sac: float = 0.0

    def off_core_room(self, net: StreetNetwork, anchored: np.ndarray) -> float:
        """Metres of ``net`` that may still lie off its 2-core (on dead-end trees) for its 2-core share
        to stay at or above the aim's; ``anchored`` nodes (roads out, ends the joining step takes, cut
        ends still open) are never pruned, as the yardstick never prunes open ends."""
        total = net.total_length()
        return (1.0 - self.two_core_share) * total - (total - _core_length(net, anchored))


#: A cut street this many junction spacings long or more may stay as a cul-de-sac (see :func:`_trim`).
STUB_LENGTH = 0.3


def _outer_edge(region: shapely.Geometry) -> shapely.Geometry:
    """The site's edge to the country: the outer rings of the region. A hole in it (a mapped building and
    its margin, taken land) is no way out: a street that the clip ended there is a cut street like
    any other, trimmed or kept as a cul-de-sac, not a road out."""
    rings = [poly.exterior for poly in shapely.get_parts(region) if poly.geom_type == "Polygon"]
    return shapely.MultiLineString(rings) if rings else shapely.boundary(region)


def _roads_out(edge: shapely.Geometry, opts: PatchOptions) -> shapely.Geometry | None:
    """Where the district's topology reads a street cut at the site's ``edge`` as a road out, running on
    (:attr:`PatchOptions.roads_out_open`), or None: nowhere, every cut street a dead end."""
    return edge if opts.roads_out_open else None


def _stub_budget(net: StreetNetwork, quilt: _Quilt, aim: _Aim | None, old: shapely.Geometry,
                 reach: float, edge: shapely.Geometry | None) -> tuple[int, float]:
    """How many cut streets may stay as cul-de-sacs, and how many metres they may hold together, so
    that the district's dead-end share comes to its town's neighbourhoods' and its 2-core share stays
    at or above theirs (:class:`_Aim`): the dead ends it has besides its cut ends, those on its ``edge``
    and those within ``reach`` of the town (the joining step takes them), are fewer."""
    if aim is None or not 0.0 < aim.dead_end_share < 1.0 or not len(net.xy):
        return 0, 0.0
    share = aim.dead_end_share
    degree = segment_degree(net.streets, len(net.xy))
    cut = np.zeros(len(net.xy), dtype=bool)
    loose = np.array(quilt.cut_xy).reshape(-1, 2)
    if len(loose):
        dist, idx = cKDTree(net.xy).query(loose)
        cut[idx[dist < 1e-6]] = True
    ends = np.flatnonzero((degree == 1) & ~cut)
    anchored = cut.copy()
    if len(ends):
        out = _leaves_out(net.xy[ends], old, reach, edge)
        anchored[ends[out]] = True
        ends = ends[~out]
    room = max(aim.off_core_room(net, anchored), 0.0)
    return max(int(share / (1.0 - share) * int((degree >= 3).sum())) - len(ends), 0), room


def _leaves_out(xy: np.ndarray, old: shapely.Geometry, reach: float, edge: shapely.Geometry | None) -> np.ndarray:
    """Which of the ends at ``xy`` leave the district: within ``reach`` of the town (the joining step
    joins them) or on its ``edge`` (roads out); the others are its cul-de-sacs."""
    out = np.zeros(len(xy), dtype=bool)
    if len(xy) and not old.is_empty:
        out |= shapely.distance(old, shapely.points(xy)) <= reach
    if len(xy) and edge is not None:
        out |= shapely.distance(edge, shapely.points(xy)) < ON_EDGE
    return out


def _cul_de_sac_length(town: StreetNetwork) -> float:
    """The median length (m) of the town's cul-de-sacs as mapped: from each dead end of its own
    streets back to the nearest junction (0 when it has none)."""
    mapped = [st for st in town.streets if st.origin == Origin.SOURCE]
    degree = segment_degree(mapped, len(town.xy))
    chains = dangling_chains(mapped, np.flatnonzero(degree == 1).tolist())
    lengths = [_chain_length(town, c) for c in chains.values()]
    return float(np.median(lengths)) if lengths else 0.0


def _core_length(net: StreetNetwork, anchored: np.ndarray) -> float:
    """Metres of ``net`` on its 2-core: what is left after pruning dead ends (never an ``anchored``
    node) and the ends that leaves, until none is left (the yardstick's 2-core share, in metres)."""
    seg = np.array([(a, b) for st in net.streets for a, b in zip(st.nodes[:-1], st.nodes[1:])], dtype=np.intp)
    if not len(seg):
        return 0.0
    alive = np.ones(len(seg), dtype=bool)
    while True:
        degree = np.bincount(seg[alive].ravel(), minlength=len(net.xy))
        leaf = (degree == 1) & ~anchored
        cut = alive & (leaf[seg[:, 0]] | leaf[seg[:, 1]])
        if not cut.any():
            break
        alive &= ~cut
    return float(np.hypot(*(net.xy[seg[alive, 0]] - net.xy[seg[alive, 1]]).T).sum())


def _trim(net: StreetNetwork, quilt: _Quilt, edge: shapely.Geometry, keep_out: float, *, keep: int = 0,
          stub: float = 0.0, room: float = float("inf"), like: float = 0.0) -> StreetNetwork:
    """Cut ends still open are trimmed back to their last junction, except a street of ``keep_out``
    metres or more that leaves the district at the site's ``edge`` (a road out into the country), and
    up to ``keep`` cut streets of ``stub`` metres or more ending inside the district, which stay as
    cul-de-sacs (a district whose every cut end was closed or trimmed has fewer dead ends than its
    town's neighbourhoods; a stub left where the edge cut it would stop at the field's margin),
    those nearest ``like`` metres long first (the town's own cul-de-sacs; a district of 30 m nubs has
    the town's dead-end share but not its edge lengths), and ``room`` metres of them at most (the
    length its 2-core may lose).

    A junction whose other streets were all trimmed becomes an end itself and is trimmed in turn:
    only the town's own dead ends stay dead ends.
    """
    loose = np.array(quilt.cut_xy).reshape(-1, 2)
    if not len(loose) or not len(net.xy):
        return net
    dist, idx = cKDTree(net.xy).query(loose)
    degree = segment_degree(net.streets, len(net.xy))
    leaves = {int(i): p for i, d, p in zip(idx, dist, loose) if d < 1e-6 and degree[i] == 1}
    streets = net.streets
    while leaves:
        drop: set[tuple[int, int]] = set()
        chains = dangling_chains(streets, leaves)
        length = {leaf: _chain_length(net, chain) for leaf, chain in chains.items()}
        for leaf, chain in sorted(chains.items(), key=lambda c: (abs(length[c[0]] - like), c[0])):
            out_of_town = shapely.distance(edge, shapely.Point(leaves[leaf])) < ON_EDGE
            if out_of_town and length[leaf] >= keep_out:
                continue
            if keep > 0 and stub <= length[leaf] <= room and not out_of_town:
                keep -= 1
                room -= length[leaf]
                continue
            drop |= chain
        if not drop:
            break
        before = segment_degree(streets, len(net.xy))
        streets = without_segments(streets, drop)
        after = segment_degree(streets, len(net.xy))
        leaves = {int(n): net.xy[n] for n in np.flatnonzero((after == 1) & (before > 1))}
    return net.replace(streets=streets)


def _keep_joinable(net: StreetNetwork, old: shapely.Geometry, spacing: float, opts: PatchOptions) -> StreetNetwork:
    """Drop fragments too short to be streets, and pieces far from both the rest and the town."""
    if not net.streets:
        return net
    length = {k: float(np.hypot(*np.diff(net.street_xy(s), axis=0).T).sum()) for k, s in enumerate(net.streets)}
    parts = [(sum(length[k] for k in streets), streets) for streets in _pieces(net)]
    parts.sort(key=lambda p: -p[0])
    keep: list[int] = list(parts[0][1])
    kept = [shapely.MultiLineString([net.street_xy(net.streets[k]) for k in keep])]
    for total, streets in parts[1:]:
        if total < opts.min_fragment * spacing:
            continue
        geom = shapely.MultiLineString([net.street_xy(net.streets[k]) for k in streets])
        near_rest = min(shapely.distance(geom, g) for g in kept) <= opts.link_reach * spacing
        near_town = not old.is_empty and shapely.distance(geom, old) <= opts.link_reach * spacing
        if near_rest or near_town:
            keep += streets
            kept.append(geom)
    return net.replace(streets=tuple(net.streets[k] for k in sorted(keep)))


def _pieces(net: StreetNetwork) -> list[list[int]]:
    """The network's connected pieces, each as the sorted indices of its streets, in the order their first
    nodes come along the streets; a segment two streets share counts for the later street only.

    That is what the ``networkx`` graph this replaced gave (its components in the order of their first
    node, a doubled edge keeping the later street's attribute), so the pieces and their order, and with
    them the district, stay the same; done with :func:`~osm_expand.model.components.component_labels`,
    without a graph object per district (and without importing ``networkx``).
    """
    pairs = [(a, b, k) for k, s in enumerate(net.streets) for a, b in zip(s.nodes[:-1], s.nodes[1:])]
    a, b, owner = np.array(pairs, dtype=np.intp).reshape(-1, 3).T
    label = component_labels(len(net.xy), a, b)
    first = np.full(int(label.max()) + 1, len(a) * 2, dtype=np.intp)
    np.minimum.at(first, label[np.column_stack([a, b]).ravel()], np.arange(2 * len(a)))
    key = np.minimum(a, b) * len(net.xy) + np.maximum(a, b)
    _, back = np.unique(key[::-1], return_index=True)
    last = len(key) - 1 - back  # each segment's last street
    piece, street = first[label[a[last]]], owner[last]
    order = np.lexsort((street, piece))
    piece, street = piece[order], street[order]
    fresh = np.ones(len(piece), dtype=bool)
    fresh[1:] = (piece[1:] != piece[:-1]) | (street[1:] != street[:-1])
    piece, street = piece[fresh], street[fresh]
    cuts = np.flatnonzero(piece[1:] != piece[:-1]) + 1
    return [part.tolist() for part in np.split(street, cuts)]


def _connect_pieces(net: StreetNetwork, old: shapely.Geometry, occupied: shapely.Geometry,
                    reach: float) -> StreetNetwork:
    """Join each smaller piece of the district to the largest, by the shortest straight street (of at
    most ``reach`` metres) between their nodes that touches no street, nothing occupied and no other
    link on the way; pieces it cannot reach stay as they are."""
    if len(net.streets) < 2:
        return net
    from osm_expand.model.components import component_labels

    ends = np.array([(a, b) for s in net.streets for a, b in zip(s.nodes[:-1], s.nodes[1:])], dtype=np.intp)
    label = component_labels(len(net.xy), ends[:, 0], ends[:, 1])
    used = np.unique(ends)
    sizes = np.bincount(label[used], minlength=int(label.max()) + 1)
    main = int(np.argmax(sizes))
    lines = [net.street_xy(st) for st in net.streets]
    quilt = _Quilt(xy=list(lines))
    board = _Board(quilt, occupied, old)
    links: list[np.ndarray] = []
    joined = {main}
    for piece in np.argsort(-sizes, kind="stable").tolist():
        if piece in joined or sizes[piece] == 0:
            continue
        mine = used[label[used] == piece]
        rest = used[np.isin(label[used], list(joined))]
        dist, near = cKDTree(net.xy[rest]).query(net.xy[mine], k=min(3, len(rest)))
        dist, near = np.atleast_2d(dist.T).T, np.atleast_2d(near.T).T
        order = np.argsort(dist, axis=None, kind="stable")
        for flat in order[:24].tolist():
            i, j = np.unravel_index(flat, dist.shape)
            if not dist[i, j] <= reach:
                break
            path = np.array([net.xy[mine[i]], net.xy[rest[near[i, j]]]])
            if board.clear(path):
                board.added.append(shapely.LineString(path))
                links.append(path)
                joined.add(piece)
                break
    if not links:
        return net
    attrs = [{"highway": st.highway, "hierarchy": st.hierarchy, "origin": Origin.GROWN} for st in net.streets]
    attrs += [{"highway": "residential", "hierarchy": max((st.hierarchy for st in net.streets), default=0),
               "origin": Origin.GROWN}] * len(links)
    return network_from_lines(lines + links, attrs)


def _without_scraps(net: StreetNetwork, least: float) -> StreetNetwork:
    """The district less the pieces that the joining of pieces left apart from the largest and that hold
    under ``least`` metres of street: a piece apart is a neighbourhood of its own across a barrier only
    when it is one (Monaco, seed 2: 0.2 km of streets beside 10 km, a second piece on the map)."""
    if len(net.streets) < 2:
        return net
    from osm_expand.model.components import component_labels

    seg = np.array([(a, b) for st in net.streets for a, b in zip(st.nodes[:-1], st.nodes[1:])], dtype=np.intp)
    label = component_labels(len(net.xy), seg[:, 0], seg[:, 1])
    length = np.bincount(label[seg[:, 0]], weights=np.hypot(*(net.xy[seg[:, 0]] - net.xy[seg[:, 1]]).T),
                         minlength=int(label.max()) + 1)
    keep = (length >= least) | (np.arange(len(length)) == int(np.argmax(length)))
    return net.replace(streets=tuple(st for st in net.streets if keep[label[st.nodes[0]]]))


def _fewer_dead_ends(net: StreetNetwork, old: shapely.Geometry, occupied: shapely.Geometry, spacing: float,
                     opts: PatchOptions, aim: _Aim, edge: shapely.Geometry | None = None) -> StreetNetwork:
    """Bring the district's dead-end share down to its town's neighbourhoods' median, and its 2-core
    share up to theirs (``aim``).

    Copied patches bring the town's cul-de-sacs, and clipping and trimming
    leave more; a neighbourhood has as many as its town's. Dead ends within
    ``tee_reach`` of the town are left to the joining step, and a road out
    that ends on the district's ``edge`` leaves it (the yardstick reads it
    as a street running on, as it does a real neighbourhood's streets cut by
    its disc) and is no cul-de-sac of the district. The others, in
    order of their chain's length (shortest first), first run on to the
    first street ahead within ``tee_reach`` in a tee (at a fair angle,
    crossing nothing); while the share is still too high, those whose chain
    is shorter than a spacing go. A district whose dead-end share is right
    can still hang too much of its length on dead-end trees (the town's
    long cul-de-sacs copied whole, Monaco's hairpins): while its 2-core
    share is short of the aim, the longest chains run on to a tee too, as
    long as its dead ends stay at ``dead_end_floor`` of the aimed share.
    """
    share = aim.dead_end_share
    reach = opts.tee_reach * spacing
    ends, junctions = _dead_ends(net, old, reach, edge)
    leaves = np.flatnonzero(segment_degree(net.streets, len(net.xy)) == 1)
    anchored = np.zeros(len(net.xy), dtype=bool)
    anchored[leaves[_leaves_out(net.xy[leaves], old, reach, edge)]] = True
    room = aim.off_core_room(net, anchored)
    over = _excess(len(ends), junctions, share) > 0
    if not over and room >= 0:
        return net
    chains = dangling_chains(net.streets, {int(e): net.xy[e] for e in ends})
    length = {e: _chain_length(net, chains[e]) for e in chains}
    # too many dead ends: the shortest chains first; only too little on loops: the longest
    order = sorted(chains, key=lambda e: (length[e], e) if over else (-length[e], e))
    ratio = share / (1.0 - share) if share < 1.0 else float("inf")
    quilt = _Quilt(xy=[net.street_xy(st) for st in net.streets], highway=[st.highway for st in net.streets],
                   level=[st.hierarchy for st in net.streets])
    board = _Board(quilt, occupied, old)
    where = {n: k for k, st in enumerate(net.streets) for n in (st.nodes[0], st.nodes[-1])}
    made = 0
    for e in order:
        if _excess(len(ends) - made, junctions + made, share) <= 0 and (
                room >= 0 or len(ends) - made - 1 < opts.dead_end_floor * ratio * (junctions + made + 1)):
            break
        st = net.streets[where[e]]
        inner = st.nodes[1] if st.nodes[0] == e else st.nodes[-2]
        p = net.xy[e]
        d = (p - net.xy[inner]) / max(float(np.hypot(*(p - net.xy[inner]))), 1e-12)
        ray = shapely.LineString([p + d * 1e-3, p + d * reach])
        hits = [(_meet(ray, quilt.xy[j], p, d, opts.tee_angle), j)
                for j in board.tree.query(ray, predicate="intersects").tolist() if j != where[e]]
        met = [(m, j) for m, j in hits if m is not None]
        ahead = min(met, key=lambda h: float(np.hypot(*(h[0][0] - p)))) if met else None
        if ahead is None:
            continue
        (at, fair), j = ahead
        if fair and board.clear(np.array([p, at])):
            board.added.append(shapely.LineString([p, at]))
            quilt.add(np.array([p, at]), st.highway, st.hierarchy)
            quilt.splits.setdefault(j, []).append(at)
            made += 1
            room += length[e]
    if made:
        net = _network(quilt)
    ends, junctions = _dead_ends(net, old, reach, edge)
    excess = _excess(len(ends), junctions, share)
    if excess > 0:
        chains = dangling_chains(net.streets, {int(e): net.xy[e] for e in ends})
        drop: set[tuple[int, int]] = set()
        for e in sorted(chains, key=lambda e: (_chain_length(net, chains[e]), e)):
            if excess <= 0 or _chain_length(net, chains[e]) >= spacing:
                break
            drop |= chains[e]
            excess -= 1
        net = net.replace(streets=without_segments(net.streets, drop)) if drop else net
    return _shorter_trees(net, old, reach, edge, aim, opts.dead_end_floor)


def _shorter_trees(net: StreetNetwork, old: shapely.Geometry, reach: float, edge: shapely.Geometry | None,
                   aim: _Aim, floor: float) -> StreetNetwork:
    """Prune cul-de-sacs that met nothing while the district's 2-core share is short of ``aim``'s and
    its dead ends stay at ``floor`` of those the aimed share allows: each time the shortest that
    makes up the shortfall, else the longest (the least street length lost for the 2-core gained)."""
    ratio = aim.dead_end_share / (1.0 - aim.dead_end_share) if aim.dead_end_share < 1.0 else float("inf")
    for _ in range(len(net.streets)):
        ends, junctions = _dead_ends(net, old, reach, edge)
        if not len(ends) or len(ends) - 1 < floor * ratio * junctions:
            break
        leaves = np.flatnonzero(segment_degree(net.streets, len(net.xy)) == 1)
        anchored = np.zeros(len(net.xy), dtype=bool)
        anchored[leaves[_leaves_out(net.xy[leaves], old, reach, edge)]] = True
        room = aim.off_core_room(net, anchored)
        if room >= 0:
            break
        chains = dangling_chains(net.streets, {int(e): net.xy[e] for e in ends})
        length = {e: _chain_length(net, c) for e, c in chains.items()}
        enough = [e for e in sorted(chains) if length[e] >= -room]
        e = min(enough, key=lambda e: length[e]) if enough else max(sorted(chains), key=lambda e: length[e])
        net = net.replace(streets=without_segments(net.streets, chains[e]))
    return net


#: The joining step links the district to the town within this many spacings (``osm_expand.joins``: two):
#: a cul-de-sac made nearer would be joined.
JOIN_REACH = 2.0


def _more_dead_ends(net: StreetNetwork, tees: list[tuple[np.ndarray, np.ndarray]], old: shapely.Geometry,
                    edge: shapely.Geometry | None, spacing: float, opts: PatchOptions, aim: _Aim) -> StreetNetwork:
    """Bring the district's dead-end share up towards its town's neighbourhoods' median (``aim``).

    The seams close almost every cut street (in a tee onto the street ahead,
    or into a neighbour's), so a small district can end with no cul-de-sac
    at all and every metre of it on a loop, where its town's neighbourhoods
    have a tenth to a quarter of their nodes at dead ends. While the share
    is short of ``share``, a tee onto the district's own streets is taken
    back, so that its cut street stays a cul-de-sac: only where the
    district stays one network without it, where the cul-de-sac is at
    least :data:`STUB_LENGTH` spacings long, and farther than
    :data:`JOIN_REACH` spacings from the town (the joining step would join
    it) and off the district's edge (there it would be a road out);
    the cul-de-sac nearest the town's median length first, and only while
    the district's 2-core share stays at or above the neighbourhoods' median.
    """
    share = aim.dead_end_share
    if not tees or not len(net.xy) or not 0.0 < share < 1.0:
        return net
    ratio, reach = share / (1.0 - share), opts.tee_reach * spacing
    tree = cKDTree(net.xy)
    cut_end, foot = np.array([t[0] for t in tees]), np.array([t[1] for t in tees])
    da, a = tree.query(cut_end)
    db, b = tree.query(foot)
    ok = (da < 1e-6) & (db < 1e-6) & (a != b)
    if edge is not None:
        ok &= shapely.distance(edge, shapely.points(cut_end)) >= ON_EDGE
    if not old.is_empty:
        ok &= shapely.distance(old, shapely.points(cut_end)) > JOIN_REACH * spacing
    # each tee as its segment (smaller node first) -> the cut end it leaves open
    open_end = {(int(min(i, j)), int(max(i, j))): int(i) for i, j in zip(a[ok], b[ok])}
    while open_end:
        ends, junctions = _dead_ends(net, old, reach, edge)
        if len(ends) + 1 > ratio * (junctions - 1) + 0.5:  # one more would overshoot more than it helps
            break
        neighbours = segment_neighbours(net.streets)
        bridges = _bridges(neighbours)
        degree = segment_degree(net.streets, len(net.xy))
        leaves = np.flatnonzero(degree == 1)
        anchored = np.zeros(len(net.xy), dtype=bool)
        anchored[leaves[_leaves_out(net.xy[leaves], old, reach, edge)]] = True
        room = aim.off_core_room(net, anchored)
        best = None
        for seg, end in sorted(open_end.items()):
            if seg in bridges or seg[1] not in neighbours.get(seg[0], ()) or degree[end] != 2:
                continue
            # the chain the cut end would leave, walked as if the tee were gone
            chain = dangling_chain(neighbours, end, without=seg)
            length = _chain_length(net, chain if chain is not None else set())
            if STUB_LENGTH * spacing <= length <= room and (
                    best is None or abs(length - aim.cul_de_sac) < abs(best[0] - aim.cul_de_sac)):
                best = (length, seg)
        if best is None:
            break
        _, seg = best
        del open_end[seg]
        net = net.replace(streets=without_segments(net.streets, {seg}))
    return net


def _bridges(neighbours: dict[int, list[int]]) -> set[tuple[int, int]]:
    """The segments (smaller node first) whose loss would split their piece of the network given as
    ``neighbours`` (:func:`~osm_expand.model.topology.segment_neighbours`): the bridges of the simple
    graph it makes (a segment two streets share is one edge, as ``networkx.bridges`` counts it).

    Tarjan's low links over an explicit stack: the same set as ``networkx.bridges`` on that graph, whose
    chain decomposition took a third of the district's topology steps on a 10,000-street town.
    """
    order: dict[int, int] = {}
    low: dict[int, int] = {}
    out: set[tuple[int, int]] = set()
    adjacent = {u: list(dict.fromkeys(n for n in near if n != u)) for u, near in neighbours.items()}
    for root in adjacent:
        if root in order:
            continue
        order[root] = low[root] = len(order)
        stack = [(root, -1, iter(adjacent[root]))]
        while stack:
            u, parent, rest = stack[-1]
            for v in rest:
                if v == parent:
                    continue
                if v in order:
                    low[u] = min(low[u], order[v])
                else:
                    order[v] = low[v] = len(order)
                    stack.append((v, u, iter(adjacent[v])))
                    break
            else:
                stack.pop()
                if parent >= 0:
                    low[parent] = min(low[parent], low[u])
                    if low[u] > order[parent]:
                        out.add((min(u, parent), max(u, parent)))
    return out


def _dead_ends(net: StreetNetwork, old: shapely.Geometry, reach: float, edge: shapely.Geometry | None = None
               ) -> tuple[np.ndarray, int]:
    """The district's dead ends farther than ``reach`` from the town and not on its ``edge`` (roads out),
    and its junction count."""
    degree = segment_degree(net.streets, len(net.xy))
    ends = np.flatnonzero(degree == 1)
    ends = ends[~_leaves_out(net.xy[ends], old, reach, edge)]
    return ends, int((degree >= 3).sum())


def _excess(dead: int, junctions: int, share: float) -> int:
    """Dead ends beyond ``share`` of dead ends and junctions together."""
    allowed = share / (1.0 - share) * junctions if share < 1.0 else float("inf")
    return int(np.ceil(dead - allowed))


def _chain_length(net: StreetNetwork, chain: set[tuple[int, int]]) -> float:
    return sum(float(np.hypot(*(net.xy[a] - net.xy[b]))) for a, b in chain)


#: An end this close to the district's edge (m) lies on it: a road out, as :func:`_trim` keeps them.
ON_EDGE = 1.0
