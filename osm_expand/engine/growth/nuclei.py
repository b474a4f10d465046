"""Nuclei of city growth and where minor streets grow next (seed 003 §3.3.2, §3.2.2).

Each year the engine grows minor streets from G(t) places (003 Algorithm 1,
GROWMINORROADS). Which ones:

* **Candidates Z** (:func:`candidate_points`): the crossings that have not
  spawned streets yet, plus, on every segment of length ≥ 2ℓ,
  ⌊length / 1.25ℓ⌋ equidistant temporary points (ℓ: the pathfinding lattice
  spacing, 20 m in 003 §3.2.2).
* **Nuclei Q** (:func:`find_nuclei`, :func:`new_junction_nuclei`): places
  that attract growth, each with a strength in (0, 1): the town centre (the
  highest-degree junction of the real major roads, strength 1), the other
  major-road junctions, the district's joins to the town, bridge ends, and
  later the junctions of new major roads together with a few random
  candidates "to account for chance". Strength fades towards the map edge
  ("to prevent artifacts near map borders").
* **Rank** (:func:`rank_candidates`): RANK(z) = |z − q_N| · (1 − STRENGTH(q_N))
  with q_N the nucleus *nearest* to z (003 §3.3.2, literally). The first
  G(t) candidates by rank grow. Not the minimum of d·(1 − s) over all
  nuclei: the centre has strength 1, so that minimum would be 0 for every
  candidate on the map. Read literally the rank is 0 in the centre's whole
  Voronoi cell; ties are broken by the distance to q_N and then by the
  candidate's index, so the centre's cell fills from the centre outwards
  before growth elsewhere, and other cells fill nearest-first weighted by
  their nucleus's strength.

Everything is arrays in metres: no city object is needed.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from osm_expand.errors import InputError

__all__ = [
    "Candidates", "Nucleus", "NucleiOptions", "NucleusKind", "candidate_points", "candidate_rank",
    "edge_attenuation", "find_nuclei", "new_junction_nuclei", "rank_candidates",
]


class NucleusKind(StrEnum):
    """Why a place attracts growth (003 §3.2.2, §3.3.2)."""

    CENTRE = "centre"              #: the highest-degree junction of the real major roads
    JUNCTION = "junction"          #: another junction of the real major roads
    JOIN = "join"                  #: where the grown district joins the town
    BRIDGE = "bridge"              #: a bridge end
    NEW_JUNCTION = "new_junction"  #: a junction of a major road the engine built
    CHANCE = "chance"              #: a random candidate, "to account for chance"


#: When two nuclei are merged, the one of the kind listed first survives.
_PRIORITY = (NucleusKind.CENTRE, NucleusKind.NEW_JUNCTION, NucleusKind.BRIDGE, NucleusKind.JOIN,
             NucleusKind.JUNCTION, NucleusKind.CHANCE)


@dataclass(frozen=True)
class Nucleus:
    """A nucleus of city growth: position (m), strength in [0, 1], kind."""

    xy: tuple[float, float]
    strength: float
    kind: NucleusKind


@dataclass(frozen=True)
class NucleiOptions:
    """Strengths and distances for the nuclei (003 §3.3.2 gives only the centre's strength, 1)."""

    #: Major-road nodes of at least this degree are junctions. 003 §3.2.2 says "degree ≥ 2", but its
    #: segment graph has shape nodes of degree 2 all along every road; "intersections" (§3.1) are ≥ 3.
    junction_min_degree: int = 3
    #: Strength of a major-road junction: half the centre's, so that the centre's own neighbourhood
    #: fills first but every junction grows a settlement (003 Fig. 2c).
    junction_strength: float = 0.5
    #: Strength of a join of the new district to the town: as a junction (it is one).
    join_strength: float = 0.5
    #: Strength of a bridge end: a little above a junction; 003 §3.2.2 makes bridges and harbours
    #: nuclei because trade changes mode there (ports and bridge towns).
    bridge_strength: float = 0.6
    #: Strength of a new major-road junction (003 §3.4: new roads drive the shape of the city).
    new_junction_strength: float = 0.5
    #: Strength of a chance nucleus: weaker than a real junction.
    chance_strength: float = 0.3
    #: Random candidates added per new major-road junction (003 §3.3.2 "a few … to account for chance").
    chance_per_new_junction: int = 1
    #: Nuclei closer than this to the map edge, as a share of the map's shorter side, are weakened
    #: by a smoothstep to 0 at the edge (003 §3.3.2 "attenuate … as they approach the map's borders").
    edge_margin_fraction: float = 0.1
    #: Nuclei closer than this (m) merge, the stronger kind surviving: the two carriageways of a
    #: dual road or the nodes of one complex junction are one place (ℓ = 20 m, 003 §3.2.2).
    merge_distance_m: float = 20.0

    def __post_init__(self) -> None:
        for key in ("junction_strength", "join_strength", "bridge_strength", "new_junction_strength",
                    "chance_strength"):
            v = getattr(self, key)
            if not 0.0 <= v <= 1.0:
                raise InputError(f"nuclei option {key}: must lie in [0, 1], got {v!r}")
        for key in ("junction_min_degree", "chance_per_new_junction"):
            if getattr(self, key) < 0:
                raise InputError(f"nuclei option {key}: must be ≥ 0, got {getattr(self, key)!r}")
        if not 0.0 <= self.edge_margin_fraction <= 0.5:
            raise InputError("nuclei option edge_margin_fraction: must lie in [0, 0.5], "
                             f"got {self.edge_margin_fraction!r}")
        if self.merge_distance_m < 0:
            raise InputError(f"nuclei option merge_distance_m: must be ≥ 0, got {self.merge_distance_m!r}")


@dataclass(frozen=True)
class Candidates:
    """The candidate set Z: where minor streets may start (003 §3.3.2).

    Attributes
    ----------
    xy : ndarray, shape (K, 2)
        Positions (m).
    node : ndarray of int, shape (K,)
        The crossing, or -1 for a temporary point on a segment.
    segment : ndarray of int, shape (K,)
        The segment a temporary point lies on, or -1 for a crossing.
    t : ndarray, shape (K,)
        Position along ``segment`` from its first end (0..1); 0 for crossings.
    """

    xy: NDArray[np.float64]
    node: NDArray[np.int64]
    segment: NDArray[np.int64]
    t: NDArray[np.float64]

    def __len__(self) -> int:
        return len(self.xy)

    def take(self, index: ArrayLike) -> Candidates:
        """The candidates at ``index`` (int array), in that order."""
        i = np.asarray(index, dtype=np.int64)
        return Candidates(self.xy[i], self.node[i], self.segment[i], self.t[i])


def _graph_arrays(graph_or_arrays: Any) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    if isinstance(graph_or_arrays, tuple):
        xy, edges = graph_or_arrays
    else:
        xy, edges = graph_or_arrays.xy, graph_or_arrays.edges
    return (np.asarray(xy, dtype=np.float64).reshape(-1, 2), np.asarray(edges, dtype=np.int64).reshape(-1, 2))


def candidate_points(graph_or_arrays: Any, *, spawned_mask: ArrayLike, ell: float = 20.0,
                     max_degree: int | None = None, temporary_points: bool = True,
                     segment_mask: ArrayLike | None = None,
                     exclude_points: ArrayLike | None = None, exclude_radius: float | None = None) -> Candidates:
    """The candidate set Z of 003 §3.3.2.

    Z holds every node that has not spawned streets yet, and on every
    segment with LENGTH(s) ≥ 2ℓ, ⌊LENGTH(s) / (1.25ℓ)⌋ equidistant temporary
    points (at i / (n + 1) of the segment, i = 1..n).

    Parameters
    ----------
    graph_or_arrays : StreetGraph or (xy, edges)
        Anything with ``xy`` (N, 2) node positions (m) and ``edges`` (E, 2)
        segment ends, or that pair of arrays.
    spawned_mask : array_like of bool, shape (N,)
        Nodes that have already spawned streets (or should never start one,
        e.g. shape points of curved roads); these are not candidates.
    ell : float
        ℓ, the pathfinding lattice spacing (m); 003 §3.2.2 uses 20 m.
    max_degree : int, optional
        Nodes of at least this degree are left out (nothing can grow there).
    temporary_points : bool
        Add the temporary points at all (False: crossings only; pass the era
        pattern's ``segment_starts``: world-space grids grow from crossings).
    segment_mask : array_like of bool, shape (E,), optional
        Segments that may carry temporary points (e.g. not bridges). Default all.
    exclude_points : array_like, shape (F, 2), optional
        Temporary points within ``exclude_radius`` of these are left out: the
        places where growth failed before (``GrowthStep.failed_xy``), which
        would otherwise top the ranking every year and stall growth.
    exclude_radius : float, optional
        Default ℓ / 2 (m): temporary points on one segment are at least 0.77ℓ apart.

    Returns
    -------
    Candidates
        Nodes first (by id), then temporary points by segment and position.

    Examples
    --------
    >>> z = candidate_points((np.array([[0., 0.], [100., 0.]]), np.array([[0, 1]])),
    ...                      spawned_mask=np.array([True, False]), ell=20.0)
    >>> z.node.tolist(), z.xy[:, 0].tolist()
    ([1, -1, -1, -1, -1], [100.0, 20.0, 40.0, 60.0, 80.0])
    """
    if not ell > 0:
        raise InputError(f"candidate_points: ell must be > 0 m, got {ell!r}")
    xy, edges = _graph_arrays(graph_or_arrays)
    spawned = np.asarray(spawned_mask, dtype=bool).reshape(-1)
    if len(spawned) != len(xy):
        raise InputError(f"candidate_points: spawned_mask has {len(spawned)} values for {len(xy)} nodes")
    degree = np.bincount(edges.reshape(-1), minlength=len(xy))
    ok = ~spawned & (degree > 0)
    if max_degree is not None:
        ok &= degree < max_degree
    nodes = np.flatnonzero(ok)
    length = np.hypot(*(xy[edges[:, 1]] - xy[edges[:, 0]]).T) if len(edges) else np.zeros(0)
    count = np.where(length >= 2.0 * ell, np.floor(length / (1.25 * ell)), 0).astype(np.int64)
    if segment_mask is not None:
        count[~np.asarray(segment_mask, dtype=bool).reshape(-1)] = 0
    if not temporary_points:
        count[:] = 0
    seg = np.repeat(np.arange(len(edges)), count)
    i = np.arange(len(seg)) - np.repeat(np.cumsum(count) - count, count) + 1
    t = i / (count[seg] + 1.0)
    a, b = xy[edges[seg, 0]], xy[edges[seg, 1]]
    temp = a + t[:, None] * (b - a)
    if exclude_points is not None and len(temp):
        f = np.asarray(exclude_points, dtype=np.float64).reshape(-1, 2)
        if len(f):
            radius = 0.5 * ell if exclude_radius is None else exclude_radius
            free = cKDTree(f).query(temp, k=1)[0] > radius
            seg, t, temp = seg[free], t[free], temp[free]
    return Candidates(
        xy=np.concatenate([xy[nodes], temp]),
        node=np.concatenate([nodes, np.full(len(seg), -1, dtype=np.int64)]),
        segment=np.concatenate([np.full(len(nodes), -1, dtype=np.int64), seg]),
        t=np.concatenate([np.zeros(len(nodes)), t]),
    )


def _nuclei_arrays(nuclei: Sequence[Nucleus]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    xy = np.array([n.xy for n in nuclei], dtype=np.float64).reshape(-1, 2)
    strength = np.array([n.strength for n in nuclei], dtype=np.float64)
    return xy, strength


def candidate_rank(candidates_xy: ArrayLike,
                   nuclei: Sequence[Nucleus]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """RANK(z) = |z − q_N| · (1 − STRENGTH(q_N)), q_N the nearest nucleus (003 §3.3.2).

    Parameters
    ----------
    candidates_xy : array_like, shape (K, 2)
        Candidate positions (m).
    nuclei : sequence of Nucleus
        At least one.

    Returns
    -------
    rank : ndarray, shape (K,)
        The rank (m); lower grows first.
    distance : ndarray, shape (K,)
        Distance (m) to the nearest nucleus (the tie-breaker).
    """
    if not nuclei:
        raise InputError("rank_candidates: no nuclei of growth")
    z = np.asarray(candidates_xy, dtype=np.float64).reshape(-1, 2)
    qxy, strength = _nuclei_arrays(nuclei)
    if len(z) == 0:
        return np.zeros(0), np.zeros(0)
    dist, nearest = cKDTree(qxy).query(z, k=1)
    return dist * (1.0 - strength[nearest]), dist


def rank_candidates(candidates_xy: ArrayLike, nuclei: Sequence[Nucleus], *, take: int) -> NDArray[np.int64]:
    """The ``take`` = G(t) candidates that grow this year, best first (003 §3.3.2).

    Sorted by :func:`candidate_rank`, ties by the distance to the nearest
    nucleus, then by index (stable, so the same input gives the same order).

    Parameters
    ----------
    candidates_xy : array_like, shape (K, 2)
        Candidate positions (m), e.g. ``candidate_points(...).xy``.
    nuclei : sequence of Nucleus
    take : int
        G(t), the number of starts this year.

    Returns
    -------
    ndarray of int, shape (min(take, K),)
        Indices into the candidates.
    """
    if take < 0:
        raise InputError(f"rank_candidates: take must be ≥ 0, got {take!r}")
    rank, dist = candidate_rank(candidates_xy, nuclei)
    order = np.lexsort((np.arange(len(rank)), dist, rank))
    return order[:take].astype(np.int64)


def edge_attenuation(xy: ArrayLike, bounds: tuple[float, float, float, float], fraction: float) -> NDArray[np.float64]:
    """Strength factor in [0, 1] by the distance to the map edge (003 §3.3.2).

    smoothstep(d / m) with d the distance (m) to the nearest side of
    ``bounds`` = (xmin, ymin, xmax, ymax) and m = ``fraction`` × the shorter
    side: 0 on the edge (and outside), 1 from m inwards.
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    xmin, ymin, xmax, ymax = bounds
    margin = fraction * min(xmax - xmin, ymax - ymin)
    if margin <= 0:
        return np.ones(len(p))
    d = np.minimum.reduce([p[:, 0] - xmin, xmax - p[:, 0], p[:, 1] - ymin, ymax - p[:, 1]])
    x = np.clip(d / margin, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _merge(xy: NDArray[np.float64], strength: NDArray[np.float64], kind: list[NucleusKind],
           distance: float) -> list[Nucleus]:
    """Greedy merge: the strongest nucleus (by kind priority, then strength, then order) keeps its place."""
    n = len(xy)
    if n == 0:
        return []
    prio = np.array([_PRIORITY.index(k) for k in kind])
    order = np.lexsort((np.arange(n), -strength, prio))
    keep = np.ones(n, dtype=bool)
    if distance > 0 and n > 1:
        tree = cKDTree(xy)
        alive = np.ones(n, dtype=bool)
        for i in order.tolist():
            if not alive[i]:
                keep[i] = False
                continue
            for j in tree.query_ball_point(xy[i], distance):
                if j != i:
                    alive[j] = False
    return [Nucleus((float(xy[i, 0]), float(xy[i, 1])), float(strength[i]), kind[i])
            for i in order.tolist() if keep[i]]


def find_nuclei(major_xy: ArrayLike, major_edges: ArrayLike, *, bounds: tuple[float, float, float, float],
                join_points: ArrayLike | None = None, bridge_ends: ArrayLike | None = None,
                centre: ArrayLike | None = None, options: NucleiOptions = NucleiOptions()) -> list[Nucleus]:
    """The initial nuclei of growth (003 §3.2.2, §3.3.2) from the real major roads.

    Parameters
    ----------
    major_xy : array_like, shape (N, 2)
        Node positions (m) of the major-road segment table.
    major_edges : array_like of int, shape (E, 2)
        Major-road segments as node-id pairs (only major roads: degrees are
        counted over these).
    bounds : (xmin, ymin, xmax, ymax)
        The map (m), for the edge attenuation.
    join_points : array_like, shape (J, 2), optional
        Where the grown district joins the town.
    bridge_ends : array_like, shape (B, 2), optional
        Ends of bridges (003 §3.2.2: nodes "from which bridges and harbours emanate").
    centre : array_like, shape (2,), optional
        Force the town centre here instead of the highest-degree junction.
    options : NucleiOptions

    Returns
    -------
    list of Nucleus
        The centre first (strength 1, never attenuated), then the others by
        kind priority and strength; nuclei within ``merge_distance_m`` of a
        stronger one are dropped.

    Notes
    -----
    The centre is the major-road junction of highest degree; among equals,
    the one nearest the middle of ``bounds`` (an OSM extract is usually cut
    around the town). Without major roads it is the middle of ``bounds``.
    """
    xy = np.asarray(major_xy, dtype=np.float64).reshape(-1, 2)
    edges = np.asarray(major_edges, dtype=np.int64).reshape(-1, 2)
    degree = np.bincount(edges.reshape(-1), minlength=len(xy)) if len(edges) else np.zeros(len(xy), dtype=np.int64)
    middle = np.array([(bounds[0] + bounds[2]) / 2, (bounds[1] + bounds[3]) / 2])
    if centre is not None:
        centre_xy = np.asarray(centre, dtype=np.float64).reshape(2)
    elif degree.size and degree.max() > 0:
        to_middle = np.hypot(*(xy - middle).T)
        centre_xy = xy[np.lexsort((np.arange(len(xy)), to_middle, -degree))[0]]
    else:
        centre_xy = middle
    junctions = xy[degree >= max(options.junction_min_degree, 1)]
    groups = [
        (junctions, options.junction_strength, NucleusKind.JUNCTION),
        (join_points, options.join_strength, NucleusKind.JOIN),
        (bridge_ends, options.bridge_strength, NucleusKind.BRIDGE),
    ]
    pts, strength, kind = [centre_xy[None, :]], [np.ones(1)], [NucleusKind.CENTRE]
    for p, s, k in groups:
        p = np.zeros((0, 2)) if p is None else np.asarray(p, dtype=np.float64).reshape(-1, 2)
        pts.append(p)
        strength.append(s * edge_attenuation(p, bounds, options.edge_margin_fraction))
        kind += [k] * len(p)
    return _merge(np.concatenate(pts), np.concatenate(strength), kind, options.merge_distance_m)


def new_junction_nuclei(new_junctions: ArrayLike, *, bounds: tuple[float, float, float, float],
                        candidates_xy: ArrayLike | None = None, rng: np.random.Generator | None = None,
                        existing: Sequence[Nucleus] = (), options: NucleiOptions = NucleiOptions()) -> list[Nucleus]:
    """Nuclei for the junctions of newly built major roads, plus chance ones (003 §3.3.2).

    "Later, when nuclei of city growth corresponding to intersections of the
    new major roads are built, additional nuclei are placed at positions
    randomly selected from Z to account for chance": for every new junction,
    ``chance_per_new_junction`` candidates drawn uniformly from Z.

    Parameters
    ----------
    new_junctions : array_like, shape (J, 2)
        Junctions (m) the engine's new major roads made this year.
    bounds : (xmin, ymin, xmax, ymax)
        The map (m), for the edge attenuation.
    candidates_xy : array_like, shape (K, 2), optional
        The current candidate set Z; needed when chance nuclei are drawn.
    rng : numpy.random.Generator, optional
        Needed when chance nuclei are drawn.
    existing : sequence of Nucleus
        Nuclei already in place: new ones within ``merge_distance_m`` of one
        of them are dropped.
    options : NucleiOptions

    Returns
    -------
    list of Nucleus
        Only the new nuclei; append them to the engine's list.
    """
    j = np.asarray(new_junctions, dtype=np.float64).reshape(-1, 2)
    n_chance = options.chance_per_new_junction * len(j)
    chance = np.zeros((0, 2))
    if n_chance:
        z = np.zeros((0, 2)) if candidates_xy is None else np.asarray(candidates_xy, dtype=np.float64).reshape(-1, 2)
        if len(z):
            if rng is None:
                raise InputError("new_junction_nuclei: chance nuclei need a random generator (rng)")
            chance = z[rng.choice(len(z), size=min(n_chance, len(z)), replace=False)]
    pts = np.concatenate([j, chance])
    strength = np.concatenate([
        options.new_junction_strength * edge_attenuation(j, bounds, options.edge_margin_fraction),
        options.chance_strength * edge_attenuation(chance, bounds, options.edge_margin_fraction)])
    kind = [NucleusKind.NEW_JUNCTION] * len(j) + [NucleusKind.CHANCE] * len(chance)
    if existing and len(pts) and options.merge_distance_m > 0:
        old_xy, _ = _nuclei_arrays(existing)
        far = cKDTree(old_xy).query(pts, k=1)[0] > options.merge_distance_m
        pts, strength, kind = pts[far], strength[far], [k for k, f in zip(kind, far) if f]
    return _merge(pts, strength, kind, options.merge_distance_m)
