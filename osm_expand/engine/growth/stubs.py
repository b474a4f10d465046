"""Streets that end in the fields: a year's stubs run on to the street ahead, or go (issue 20).

A street pattern (000 §4.2.6) grows streets until a rule stops them; a
street stopped short of anything is a stub. Real towns have dead ends, but
as many as their neighbourhoods, not a comb: a year's new streets whose end
meets nothing run on along their heading to the first street ahead within
``reach`` (a tee, at a fair angle, crossing no street, water or forbidden
land on the way); a stub that cannot, and is shorter than ``reach``, is
dropped (it never met anything), as patches trim their cut ends, round
after round, since a street that lost its branch may become a stub itself.
A longer stub stays: a street pattern grows trees that later years close
(dropping every stub beyond the town's dead-end share starved Krems'
european history to 5 km of street in 50 years, against 25 km). Except
where no later year can: a pattern without Snap and Extend (``suburban``)
never runs a street on to another, so with ``loops`` a tree hung on the
town at one point, a comb's tooth or a cluster of culs-de-sac, goes too
(:func:`_in_loops`): no later year will make it a block. With
:attr:`~osm_expand.engine.growth.minor_streets.GrowthOptions.pattern_aim`, the era's
connectedness decides further: run-ons taken back and short stubs kept while the
era is more connected than its town's neighbourhoods, culs-de-sac of a pattern
that never closes them dropped while it is less (``withhold``, ``keep``, ``drop``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree

from osm_expand.model.components import component_labels
from osm_expand.model.geometry import closest_on_segments, match_points, polyline_length, ray_meet

#: Ends closer than this (m) are the same point.
SAME = 1e-3


@dataclass(frozen=True)
class StubReport:
    """What :func:`close_stubs` did."""

    tees: int = 0  #: stubs that ran on to a street
    dropped: int = 0  #: stubs that went
    #: the stub ends that ran on, as ``(line, 0 or 1)`` of the input lines (the first end or the last)
    ran: tuple[tuple[int, int], ...] = ()
    #: the input lines dropped as stubs shorter than the reach in the first round (not those a drop left a stub)
    short: tuple[int, ...] = ()
    #: the input lines kept with an end that meets nothing (culs-de-sac at least the reach long)
    stubs: tuple[int, ...] = ()
    #: per line returned, the input line it is (or, for a link, the stub it runs on): whose attributes it takes
    source: tuple[int, ...] = ()


def close_stubs(lines: list[np.ndarray], bridges: list[bool], town: np.ndarray, town_nodes: np.ndarray,
                blocked: shapely.Geometry, *, reach: float, min_angle: float = 35.0,
                loops: bool = False, withhold: frozenset[tuple[int, int]] = frozenset(),
                keep: frozenset[int] = frozenset(), drop: frozenset[int] = frozenset()
                ) -> tuple[list[np.ndarray], list[bool], StubReport]:
    """The year's new streets with their stubs run on or dropped (module docstring).

    Parameters
    ----------
    lines : the new streets, each ``(n_i, 2)`` metres.
    bridges : per line, whether it is a bridge (bridges are left alone).
    town : (S,) LineStrings of the streets that stood before.
    town_nodes : (N, 2) their nodes: a new street ending on one is joined there.
    blocked : what a street may not touch (water, forbidden land).
    reach : metres a stub may run on.
    min_angle : degrees: a stub meets a street at this angle or more.
    loops : whether a tree hung on the town at one point (a piece closing no loop) goes too
        (:func:`_in_loops`).
    withhold : stub ends ``(line, 0 or 1)`` that do not run on: they stay as culs-de-sac, or go when shorter
        than ``reach`` (a street pattern's era aiming at its town's dead-end and 2-core shares,
        :func:`osm_expand.engine.growth.minor_streets.grow_street_pattern`).
    keep : lines that stay whatever their length (neither dropped as stubs nor their tails trimmed): culs-de-sac
        the same aim keeps.
    drop : lines that go when they end in a stub, whatever their length (the same aim, for a pattern that never
        closes its trees).

    Returns
    -------
    (lines, bridges, report): links appended after the lines; a new line a
    link lands on gets the landing point as a vertex.
    """
    lines = [np.asarray(xy, dtype=float) for xy in lines]
    unchanged = StubReport(source=tuple(range(len(lines))))
    if not lines:
        return lines, list(bridges), unchanged
    ends = _stub_ends(lines, town, town_nodes)
    if not ends:
        return lines, list(bridges), unchanged
    town_tree = shapely.STRtree(town) if len(town) else None
    links: list[np.ndarray] = []
    linked: list[int] = []
    ran: list[tuple[int, int]] = []
    for k, side in ends:
        if bridges[k] or (k, side) in withhold:
            continue
        xy = lines[k]
        p, prev = (xy[0], xy[1]) if side == 0 else (xy[-1], xy[-2])
        d = p - prev
        d = d / max(float(np.hypot(*d)), 1e-12)
        hit = _first_ahead(p, d, reach, lines, k, town, town_tree, links, min_angle)
        if hit is None:
            continue
        at, j = hit
        link = np.array([p, at])
        if blocked is not None and not blocked.is_empty and blocked.intersects(_inner(link)):
            continue
        if j >= 0:
            lines[j] = _with_vertex(lines[j], at)
        links.append(link)
        linked.append(k)
        ran.append((k, side))
    out = lines + links
    flags = np.array([bool(b) for b in bridges] + [False] * len(links), dtype=bool)
    at = np.arange(len(out))  # each line's place in ``lines + links``
    stays = np.zeros(len(out), dtype=bool)  # ``keep``'s lines: to the rounds below, as bridges are
    stays[[k for k in keep if 0 <= k < len(lines)]] = True
    short: list[int] = []
    for _ in range(MAX_ROUNDS):  # a stub dropped can leave the street it hung from a stub in turn
        now = [out[i] for i in at.tolist()]
        alone = (flags[at] | stays[at]).tolist()
        kept = _drop_stubs(now, alone, town, town_nodes, reach, frozenset(np.flatnonzero(np.isin(at, list(drop)))
                                                                          .tolist()) if drop else frozenset())
        if len(kept) == len(at):
            trimmed = _trim_tails(now, alone, town, town_nodes, reach)
            if all(t is xy for t, xy in zip(trimmed, now)):
                break
            for i, xy in zip(at.tolist(), trimmed):
                out[i] = xy
            continue
        if not short:  # the first round that drops: the stubs themselves, not what their drop left
            short = [i for i in np.setdiff1d(at, at[kept]).tolist() if i < len(lines)]
        at = at[kept]
    if loops and len(at):
        at = at[_in_loops([out[i] for i in at.tolist()], flags[at], town, town_nodes)]
    source = np.array(list(range(len(lines))) + linked, dtype=np.int64)[at]
    final = [out[i] for i in at.tolist()]
    stubs = sorted({int(at[j]) for j, _ in _stub_ends(final, town, town_nodes) if at[j] < len(lines)}) if final else []
    return ([out[i] for i in at.tolist()], flags[at].tolist(),
            StubReport(tees=len(links), dropped=len(out) - len(at), source=tuple(source.tolist()), ran=tuple(ran),
                                 short=tuple(short), stubs=tuple(stubs)))


#: Rounds of dropping stubs (each may leave new ones).
MAX_ROUNDS = 8


def _drop_stubs(lines: list[np.ndarray], bridges: list[bool], town: np.ndarray, town_nodes: np.ndarray,
                reach: float, always: frozenset[int] = frozenset()) -> np.ndarray:
    """One round: the indices of the lines kept, the stubs shorter than ``reach`` (bridges aside) and those of
    ``always`` gone."""
    if not lines:
        return np.zeros(0, dtype=np.int64)
    ends = [(k, side) for k, side in _stub_ends(lines, town, town_nodes) if not bridges[k]]
    drop = {k for k, _ in ends if k in always or polyline_length(lines[k]) < reach}
    return np.array([k for k in range(len(lines)) if k not in drop], dtype=np.int64)


def _in_loops(lines: list[np.ndarray], bridges: np.ndarray, town: np.ndarray, town_nodes: np.ndarray
              ) -> np.ndarray:
    """Indices of the lines in a piece that closes a loop, and the bridges.

    A piece is a connected set of the lines, apart from the town; with every
    point where it meets the town taken as one point T, it closes a loop when
    it has more edges than non-town points (E − V + 1 ≥ 1 with T among the
    V): joined to the town at two places, or holding a ring. A piece joined
    once and holding no ring is a tree hung on the town, and goes: a lone
    street so hung is a comb's tooth (Krems' european history's postwar
    spurs: half its junctions dead ends), a branching one a cluster of
    culs-de-sac that no later year of the pattern closes. (Keeping the
    branching trees was measured against one disc of the engine's summed
    area; judged per piece (:mod:`osm_expand.growth_fidelity`), they left
    Krems' european streets with a dead-end share of 0.149 against its
    neighbourhoods' 0.048–0.149, and 0.085 against 0.026–0.152 without
    them, the 2-core share 0.968 in 0.896–0.972.) A district needs two
    joins for the same reason
    (:attr:`~osm_expand.engine.growth.minor_streets.GrowthOptions.min_joins`).
    """
    vertices = np.concatenate(lines)
    owner = np.concatenate([np.full(len(xy), k) for k, xy in enumerate(lines)])
    key = np.round(vertices / SAME).astype(np.int64)
    node = np.unique(key, axis=0, return_inverse=True)[1].ravel()
    n = int(node.max()) + 1
    first = np.zeros(n, dtype=np.int64)
    first[node[::-1]] = np.arange(len(node))[::-1]
    xy = vertices[first]
    on_town = np.zeros(n, dtype=bool)
    if len(town_nodes):
        on_town |= match_points(xy, town_nodes, SAME) >= 0
    if len(town):
        on_town[shapely.STRtree(town).query(shapely.points(xy), predicate="dwithin", distance=SAME)[0]] = True
    same_line = (owner[1:] == owner[:-1]) & (node[1:] != node[:-1])
    u, v = node[:-1][same_line], node[1:][same_line]
    edge_line = owner[:-1][same_line]
    inner = ~on_town[u] & ~on_town[v]
    label = component_labels(n, u[inner], v[inner])  # the pieces apart from the town
    piece = np.where(on_town[u], label[v], label[u])  # each edge's piece (a town-to-town edge: its own end's)
    town_town = on_town[u] & on_town[v]
    edges = np.bincount(piece[~town_town], minlength=n)
    points = np.bincount(label[~on_town], minlength=n)
    touches = np.zeros(n, dtype=bool)
    touches[piece[(on_town[u] | on_town[v]) & ~town_town]] = True
    loop = edges - (points + touches) + 1 >= 1
    ok = loop
    keep = np.asarray(bridges, dtype=bool).copy()
    keep[np.unique(edge_line[town_town])] = True
    keep[np.unique(edge_line[~town_town][ok[piece[~town_town]]])] = True
    return np.flatnonzero(keep)


def _stub_ends(lines: list[np.ndarray], town: np.ndarray, town_nodes: np.ndarray) -> list[tuple[int, int]]:
    """(line, 0 or 1) of every end that meets nothing: no other new line's vertex, no town node, no
    town street."""
    meets = _meets(lines, town, town_nodes)
    return [(k, side) for k, at in enumerate(meets) for side, i in ((0, 0), (1, -1)) if not at[i]]


def _meets(lines: list[np.ndarray], town: np.ndarray, town_nodes: np.ndarray) -> list[np.ndarray]:
    """Per line, per vertex, whether something meets it there: another new line's vertex, a town node or a
    town street (within :data:`SAME`)."""
    if not lines:
        return []
    vertices = np.concatenate(lines)
    owner = np.concatenate([np.full(len(xy), k) for k, xy in enumerate(lines)])
    tree = cKDTree(vertices)
    pairs = tree.query_pairs(SAME, output_type="ndarray")
    other = pairs[owner[pairs[:, 0]] != owner[pairs[:, 1]]]
    meets = np.zeros(len(vertices), dtype=bool)
    meets[other.ravel()] = True
    if len(town_nodes):
        meets |= cKDTree(town_nodes).query(vertices, distance_upper_bound=SAME)[0] < SAME
    if len(town):
        meets[shapely.STRtree(town).query(shapely.points(vertices), predicate="dwithin", distance=SAME)[0]] = True
    return np.split(meets, np.cumsum([len(xy) for xy in lines])[:-1])


def _trim_tails(lines: list[np.ndarray], bridges: list[bool], town: np.ndarray, town_nodes: np.ndarray,
                reach: float) -> list[np.ndarray]:
    """The lines with each stub end's tail past the line's last junction cut there, when shorter than
    ``reach`` (bridges aside); a line returned unchanged is the same object.

    A tail is a stub like a short street: a link that tees into a new
    street just short of its free end (Krems: 0.14 m) would otherwise leave
    the remnant hanging past the tee, a dead end no neighbourhood has.
    """
    out = list(lines)
    for k, (xy, at) in enumerate(zip(lines, _meets(lines, town, town_nodes))):
        if bridges[k] or at[0] and at[-1]:
            continue
        inner = np.flatnonzero(at[1:-1]) + 1
        if not len(inner):
            continue
        step = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T))]
        lo = int(inner[0]) if not at[0] and step[inner[0]] < reach else 0
        hi = int(inner[-1]) if not at[-1] and step[-1] - step[inner[-1]] < reach else len(xy) - 1
        if lo > 0 or hi < len(xy) - 1:
            out[k] = xy[lo:hi + 1]
    return out


def _first_ahead(p: np.ndarray, d: np.ndarray, reach: float, lines: list[np.ndarray], own: int, town: np.ndarray,
                 town_tree: shapely.STRtree | None, links: list[np.ndarray], min_angle: float
                 ) -> tuple[np.ndarray, int] | None:
    """Where the ray from ``p`` along ``d`` first meets a street (new line index, or -1 for the town),
    if it does so within ``reach``, at ``min_angle`` or more, and nothing else is in the way."""
    ray = shapely.LineString([p + d * 1e-3, p + d * reach])
    best: tuple[float, np.ndarray, int, bool] | None = None
    candidates = [(j, xy) for j, xy in enumerate(lines) if j != own and shapely.intersects(ray, shapely.LineString(xy))]
    if town_tree is not None:
        candidates += [(-1, np.asarray(town[i].coords)) for i in town_tree.query(ray, predicate="intersects").tolist()]
    candidates += [(-2, xy) for xy in links if shapely.intersects(ray, shapely.LineString(xy))]
    for j, xy in candidates:
        met = ray_meet(p, d, xy, reach)
        if met is not None and (best is None or met[0] < best[0]):
            best = (met[0], met[1], j, met[2] >= min_angle)
    if best is None or not best[3] or best[2] == -2:
        return None
    return best[1], best[2]


def _inner(link: np.ndarray) -> shapely.LineString:
    """The link less a metre at each end (it may touch what it joins)."""
    line = shapely.LineString(link)
    if line.length <= 2.0:
        return shapely.LineString()
    return shapely.ops.substring(line, 1.0, line.length - 1.0)


def _with_vertex(xy: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The polyline with ``q`` (which lies on it) inserted as a vertex where it lies."""
    i = int(np.argmin(closest_on_segments(q, xy[:-1], xy[1:])[2]))
    if np.hypot(*(xy[i] - q)) < SAME or np.hypot(*(xy[i + 1] - q)) < SAME:
        return xy
    return np.vstack([xy[:i + 1], q, xy[i + 1:]])
