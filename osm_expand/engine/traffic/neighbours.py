"""Neighbouring cities: where the real town's major roads and waters leave the map.

Seed 003 feeds its traffic simulation with a list of notional, unsimulated
neighbouring cities ``nc`` beyond the map border (§3.1, figure 3a); every
pair of them trades over *trade routes* (§3.4, see :mod:`.trade`). For a
real town the neighbours are read off the map: a motorway, trunk, primary or
secondary road that leaves the map leads to a neighbour (a major segment
crossing the bounds, or a major road's dead end within ``exit_margin`` of
them), and so does a river or sea that crosses the bounds (a water
neighbour, reached by ship over 003's water lattice). Exits closer than
``cluster_radius`` to each other (the two carriageways of one road, a fork
at the border) are one neighbour. Each neighbour is placed
``neighbour_distance`` beyond the bounds in the exit direction, and keeps the
point where it enters the map and the road node it attaches to. A town
with more than ``max_neighbours`` (003's c_max = 10) keeps the most
important: motorways first, then trunk, primary, navigable water, secondary.

With fewer than ``min_neighbours`` (3, as 000 A.3.1 asks: "at least two
paths and three neighbours") the 003 §3.5 heuristic generates them:
``c = c_min + Binomial(c_max − c_min, p)`` with ``p`` chosen so that the
mean is ``c_mean`` (003: c_min = 4 < μ = 7 < c_max = 10, i.e. 4 + B(6, ½)),
on rays from the map centre at angles ``i·2π/c + φ + θ_i`` with
``φ ~ U(0, 2π)`` and ``θ_i ~ U(−π/2c, π/2c)``. The real exits are kept:
each replaces the ray nearest to it in angle, so the town keeps its real
roads and the set still has ``c`` members.

:func:`neighbour_pairs` gives 003's pair set ``y`` sorted by the angle
``C_u X C_v``; :func:`initial_pairs` its sublist ``y'`` for building an
initial road network between generated neighbours (003 §3.5).
"""
from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from osm_expand.errors import InputError
from osm_expand.model import highways

__all__ = [
    "NeighbourKind",
    "NeighbourOptions",
    "Neighbours",
    "initial_pairs",
    "neighbour_cities",
    "neighbour_pairs",
]

Bounds = tuple[float, float, float, float]

#: A point of the bounds within this distance (m) of water is wet (rounding of clipped polygons).
_WATER_TOLERANCE = 1.0


class NeighbourKind(enum.StrEnum):
    """How a neighbouring city is reached (003 §3.2.2: land or water lattice vertex)."""

    ROAD = "road"
    WATER = "water"


@dataclass(frozen=True)
class NeighbourOptions:
    #: Highway classes whose map exits lead to a neighbouring city (the issue's
    #: "motorway/trunk/primary/secondary"); ``*_link`` ramps are not exits.
    exit_classes: tuple[str, ...] = highways.MAJOR
    #: A major road's dead end this close (m) to the bounds, inside or out,
    #: leaves the map; a segment crossing the bounds attaches at its outer node when that
    #: is this close beyond them (else at its inner node). Clipped extracts
    #: end ways at the first node past the box or one short of it; 50 m
    #: covers one shape-point step.
    exit_margin: float = 50.0
    #: Exits closer than this (m) are one neighbour: dual carriageways and the
    #: arms of a junction at the border lie 10–60 m apart; roads 200 m apart
    #: (Monaco's Boulevard d'Italie and du Larvotto) go to different places.
    cluster_radius: float = 100.0
    #: Neighbours sit this far (m) beyond the bounds in the exit direction.
    #: 003 puts them on the lattice edge (its ``entry``); only their angle
    #: around the centre matters (pair order), so any town-scale distance works.
    neighbour_distance: float = 5000.0
    #: The road's own heading at its end is the exit direction when its
    #: component along the outward normal of the nearest side is at least this
    #: (cosine); a road running along the border exits along the normal.
    min_outward: float = 0.25
    #: Water crossing the bounds over less than this (m) is a stream, not a
    #: way for ships: no water neighbour.
    min_water_width: float = 20.0
    #: At most this many neighbours come from the map (003 §3.5's c_max): the
    #: pair count grows as K², and a town's minor exits lead to villages
    #: whose trade through it is small. The most important exits stay.
    max_neighbours: int = 10
    #: Where a water neighbour ranks among the exit classes when
    #: ``max_neighbours`` bites (index into ``exit_classes``; 2.5: a navigable
    #: river counts between a primary and a secondary road).
    water_rank: float = 2.5
    #: Fewer neighbours than this start the 003 §3.5 fallback (000 A.3.1:
    #: at least three neighbours for one intersection).
    min_neighbours: int = 3
    #: 003 §3.5: c_min, the fewest generated neighbours.
    c_min: int = 4
    #: 003 §3.5: c_max, the most generated neighbours.
    c_max: int = 10
    #: 003 §3.5: the mean of c; Binomial(c_max − c_min, p) with
    #: p = (c_mean − c_min) / (c_max − c_min) (½ for 4, 7, 10).
    c_mean: float = 7.0

    def __post_init__(self) -> None:
        for key in ("exit_margin", "cluster_radius", "neighbour_distance", "min_water_width"):
            if not getattr(self, key) >= 0:
                raise InputError(f"neighbours.{key} must be ≥ 0, got {getattr(self, key)}")
        if self.max_neighbours < self.min_neighbours:
            raise InputError(f"neighbours: max_neighbours ({self.max_neighbours}) is below "
                             f"min_neighbours ({self.min_neighbours})")
        if not (0 < self.c_min < self.c_mean < self.c_max):
            raise InputError(f"neighbours: need 0 < c_min < c_mean < c_max, "
                             f"got {self.c_min}, {self.c_mean}, {self.c_max}")
        if not -1.0 <= self.min_outward <= 1.0:
            raise InputError(f"neighbours.min_outward is a cosine in [-1, 1], got {self.min_outward}")


@dataclass(frozen=True, eq=False)
class Neighbours:
    """The neighbouring cities ``nc`` of one town, sorted by angle around the centre.

    Attributes
    ----------
    xy : (K, 2) float64
        Positions in metres, ``neighbour_distance`` beyond the bounds.
    entry_xy : (K, 2) float64
        Where each enters the map: on the bounds (003's lattice-edge vertex).
    kind : (K,) str
        :class:`NeighbourKind` values (``"road"`` or ``"water"``).
    exit_node : (K,) int64
        The road node the neighbour attaches to (an end of a major road at
        the border), or -1: water neighbours and generated directions, which
        the initialisation (003 §3.2.2) must connect with a new road.
    generated : (K,) bool
        True for directions made up by the 003 §3.5 fallback.
    centre : (2,) float64
        The map centre ``X`` the angles are measured around.
    """

    xy: NDArray[np.float64]
    entry_xy: NDArray[np.float64]
    kind: NDArray[np.str_]
    exit_node: NDArray[np.int64]
    generated: NDArray[np.bool_]
    centre: NDArray[np.float64]

    def __len__(self) -> int:
        return len(self.xy)

    @property
    def fallback(self) -> bool:
        """Whether the 003 §3.5 fallback made up any direction."""
        return bool(self.generated.any())


# --------------------------------------------------------------------------- geometry helpers

def _check_bounds(bounds: Bounds) -> NDArray[np.float64]:
    b = np.asarray(bounds, dtype=np.float64)
    if b.shape != (4,) or not np.all(np.isfinite(b)) or not (b[2] > b[0] and b[3] > b[1]):
        raise InputError(f"bounds must be (x0, y0, x1, y1) with x1 > x0 and y1 > y0, got {bounds}")
    return b


def _inset(points: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (m) of each point inside the box to its nearest side; ≤ 0 outside."""
    return np.minimum.reduce([points[:, 0] - b[0], b[2] - points[:, 0],
                              points[:, 1] - b[1], b[3] - points[:, 1]])


def _outward_normal(points: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit outward normal of the box side nearest to each point (signed distances)."""
    gaps = np.stack([points[:, 0] - b[0], b[2] - points[:, 0],
                     points[:, 1] - b[1], b[3] - points[:, 1]], axis=1)
    side = np.argmin(gaps, axis=1)
    normals = np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]])
    return normals[side]


def _onto_bounds(points: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Each point moved to the nearest point of the box outline."""
    p = np.clip(points, b[:2], b[2:])
    gaps = np.stack([p[:, 0] - b[0], b[2] - p[:, 0], p[:, 1] - b[1], b[3] - p[:, 1]], axis=1)
    side = np.argmin(gaps, axis=1)
    out = p.copy()
    out[side == 0, 0] = b[0]
    out[side == 1, 0] = b[2]
    out[side == 2, 1] = b[1]
    out[side == 3, 1] = b[3]
    return out


def _ray_to_bounds(start: NDArray[np.float64], direction: NDArray[np.float64],
                   b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Where rays from ``start`` ((2,) or (K, 2), inside the box) along ``direction`` (K, 2) leave it."""
    start = np.broadcast_to(start, direction.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(direction[:, 0] > 0, (b[2] - start[:, 0]) / direction[:, 0],
                      np.where(direction[:, 0] < 0, (b[0] - start[:, 0]) / direction[:, 0], np.inf))
        ty = np.where(direction[:, 1] > 0, (b[3] - start[:, 1]) / direction[:, 1],
                      np.where(direction[:, 1] < 0, (b[1] - start[:, 1]) / direction[:, 1], np.inf))
    return start + np.minimum(tx, ty)[:, None] * direction


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    n = np.hypot(v[:, 0], v[:, 1])
    return v / np.where(n > 0, n, 1.0)[:, None]


def _clusters(points: NDArray[np.float64], radius: float) -> NDArray[np.intp]:
    """Single-linkage cluster label of each point (points closer than ``radius`` chain)."""
    if len(points) == 0:
        return np.zeros(0, dtype=np.intp)
    pairs = cKDTree(points).query_pairs(radius, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points),) * 2)
    return connected_components(graph, directed=False)[1]


# --------------------------------------------------------------------------- exits

@dataclass(frozen=True)
class _Exits:
    entry_xy: NDArray[np.float64]
    direction: NDArray[np.float64]
    exit_node: NDArray[np.int64]
    kind: NDArray[np.str_]
    rank: NDArray[np.float64]  # importance: lower is kept first when there are too many

    def take(self, index: NDArray[np.intp]) -> _Exits:
        return _Exits(self.entry_xy[index], self.direction[index], self.exit_node[index],
                      self.kind[index], self.rank[index])


def _no_exits() -> _Exits:
    return _Exits(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, dtype="<U5"),
                  np.zeros(0))


def _road_exits(xy: NDArray[np.float64], edges: NDArray[np.intp], highway: NDArray[np.str_],
                b: NDArray[np.float64], options: NeighbourOptions) -> _Exits:
    """Where major roads leave the map, one per cluster of nearby exits.

    Two kinds of exit: a major segment with one end inside the box and the
    other on or beyond it (entry: where it crosses the outline; it attaches
    at its outer node when that lies within ``exit_margin`` of the box, as a
    clipped extract's last node does, else at its inner node), and a major
    road's dead end within ``exit_margin`` of the outline, inside or out
    (a road cut just short of the box, or running along just outside it).
    """
    major = np.isin(highway, np.asarray(options.exit_classes, dtype=str))
    medges = edges[major]
    rank_of = {c: k for k, c in enumerate(options.exit_classes)}
    seg_rank = np.array([rank_of[c] for c in highway[major]], dtype=float)
    inset = _inset(xy, b)
    inside = inset > 0
    # crossing segments
    cross = inside[medges[:, 0]] != inside[medges[:, 1]]
    first_in = inside[medges[cross, 0]]
    inner = np.where(first_in, medges[cross, 0], medges[cross, 1])
    outer = np.where(first_in, medges[cross, 1], medges[cross, 0])
    step = xy[outer] - xy[inner]
    cross_entry = _ray_to_bounds(xy[inner], step, b)
    cross_node = np.where(inset[outer] >= -options.exit_margin, outer, inner)
    cross_heading = _unit(step)
    # dead ends at the border (inside or out)
    degree = np.bincount(medges.ravel(), minlength=len(xy))
    ends = medges.ravel()
    slot = np.flatnonzero((degree[ends] == 1) & (np.abs(inset[ends]) <= options.exit_margin))
    dead = ends[slot]
    dead_heading = _unit(xy[dead] - xy[ends[slot ^ 1]])  # flat pairs: slot ^ 1 is the other end
    node = np.r_[cross_node, dead].astype(np.int64)
    if len(node) == 0:
        return _no_exits()
    entry = np.r_[cross_entry, _onto_bounds(xy[dead], b)]
    heading = np.r_[cross_heading, dead_heading]
    rank = np.r_[seg_rank[cross], seg_rank[slot // 2]]
    normal = _outward_normal(entry, b)
    outward = (heading * normal).sum(axis=1) >= options.min_outward
    direction = np.where(outward[:, None], heading, normal)
    # one neighbour per cluster, attached at its most important road (class order, then node id)
    label = _clusters(entry, options.cluster_radius)
    order = np.lexsort((node, rank, label))
    first = order[np.r_[True, np.diff(label[order]) != 0]]
    mean_dir = np.zeros((label.max() + 1, 2))
    np.add.at(mean_dir, label, direction)
    dirs = _unit(mean_dir[label[first]])
    dirs = np.where((np.hypot(dirs[:, 0], dirs[:, 1]) > 0)[:, None], dirs, direction[first])
    return _Exits(entry[first], dirs, node[first],
                  np.full(len(first), NeighbourKind.ROAD.value, dtype="<U5"), rank[first])


def _water_exits(water: Sequence[shapely.Geometry], b: NDArray[np.float64],
                 options: NeighbourOptions) -> _Exits:
    """Midpoints of the stretches of the bounds that lie in water, one per wide enough stretch.

    The outline is sampled every ``min_water_width / 4`` (at most 5 m); a
    sample is wet within ``_WATER_TOLERANCE`` of the water, so sea polygons
    clipped to the box (whose edge *is* the outline, up to rounding) count.
    """
    empty = _no_exits()
    geoms = [g for g in water if g is not None and not g.is_empty]
    if not geoms:
        return empty
    outline = shapely.box(*b).exterior
    perimeter = outline.length
    step = min(5.0, max(0.5, options.min_water_width / 4))
    n = int(np.ceil(perimeter / step))
    along = np.arange(n) * (perimeter / n)
    wet_geom = shapely.union_all(geoms)
    shapely.prepare(wet_geom)
    wet = shapely.dwithin(wet_geom, shapely.line_interpolate_point(outline, along), _WATER_TOLERANCE)
    if not wet.any() or wet.all():
        return empty  # dry border, or a map that is all water at its edge: no direction to take
    shift = int(np.argmin(wet))  # start the cyclic scan on a dry sample
    rolled = np.roll(wet, -shift).astype(np.int8)
    edges = np.diff(np.r_[0, rolled, 0])
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    width = (stops - starts) * (perimeter / n)
    keep = width >= options.min_water_width
    if not keep.any():
        return empty
    middle = np.mod((starts[keep] + stops[keep] - 1) / 2 + shift, n) * (perimeter / n)
    mid = shapely.get_coordinates(shapely.line_interpolate_point(outline, middle))
    width = width[keep]
    label = _clusters(mid, options.cluster_radius)
    order = np.lexsort((-width, label))  # the widest stretch of each cluster speaks for it
    first = order[np.r_[True, np.diff(label[order]) != 0]]
    entry = _onto_bounds(mid[first], b)
    return _Exits(entry, _outward_normal(entry, b), np.full(len(first), -1, np.int64),
                  np.full(len(first), NeighbourKind.WATER.value, dtype="<U5"),
                  np.full(len(first), options.water_rank))


# --------------------------------------------------------------------------- fallback

def _angle(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.mod(np.arctan2(v[:, 1], v[:, 0]), 2 * np.pi)


def _fallback(exits: _Exits, centre: NDArray[np.float64], b: NDArray[np.float64],
              rng: np.random.Generator, options: NeighbourOptions) -> tuple[_Exits, NDArray[np.bool_]]:
    """003 §3.5: c rays from the centre; each real exit replaces the ray nearest to it in angle."""
    n = options.c_max - options.c_min
    c = options.c_min + int(rng.binomial(n, (options.c_mean - options.c_min) / n))
    phi = rng.uniform(0.0, 2 * np.pi)
    theta = rng.uniform(-np.pi / (2 * c), np.pi / (2 * c), size=c)
    ray_angle = np.mod(np.arange(c) * 2 * np.pi / c + phi + theta, 2 * np.pi)
    ray_dir = np.stack([np.cos(ray_angle), np.sin(ray_angle)], axis=1)
    # greedy assignment of real exits to rays, closest angular gap first (stable order)
    exit_angle = _angle(exits.entry_xy - centre)
    gap = np.abs(np.angle(np.exp(1j * (exit_angle[:, None] - ray_angle[None, :]))))
    taken_ray = np.zeros(c, dtype=bool)
    placed = np.zeros(len(exit_angle), dtype=bool)
    for flat in np.argsort(gap, axis=None, kind="stable"):
        i, j = divmod(int(flat), c)
        if not placed[i] and not taken_ray[j]:
            placed[i] = taken_ray[j] = True
    keep = ~taken_ray
    entry = _ray_to_bounds(centre, ray_dir[keep], b)
    k = int(keep.sum())
    merged = _Exits(
        np.concatenate([exits.entry_xy, entry]),
        np.concatenate([exits.direction, ray_dir[keep]]),
        np.concatenate([exits.exit_node, np.full(k, -1, np.int64)]),
        np.concatenate([exits.kind, np.full(k, NeighbourKind.ROAD.value, dtype="<U5")]),
        np.concatenate([exits.rank, np.full(k, np.inf)]),
    )
    return merged, np.r_[np.zeros(len(exit_angle), bool), np.ones(k, bool)]


# --------------------------------------------------------------------------- public API

def neighbour_cities(xy: NDArray[np.float64], edges: NDArray[np.integer], highway: Sequence[str] | NDArray[np.str_],
                     bounds: Bounds, rng: np.random.Generator, *,
                     water: Sequence[shapely.Geometry] = (),
                     centre: tuple[float, float] | None = None,
                     options: NeighbourOptions = NeighbourOptions()) -> Neighbours:
    """The neighbouring cities of a real town (003 §3.1 ``nc``; §3.5 fallback).

    Parameters
    ----------
    xy : (N, 2) float64
        Node positions in metres.
    edges : (E, 2) int
        Segment end node indices into ``xy``.
    highway : (E,) str
        Highway class of each segment (OSM ``highway=*``).
    bounds : (x0, y0, x1, y1)
        The map box in metres.
    rng : numpy.random.Generator
        Used only by the fallback (c, φ and θ_i of 003 §3.5).
    water : sequence of shapely geometries, optional
        Water areas and sea (metres); where they cross the bounds over at
        least ``min_water_width`` a water neighbour enters.
    centre : (x, y), optional
        003's map centre ``X`` for angles and fallback rays; default the
        centre of ``bounds``. Must lie inside the bounds.
    options : NeighbourOptions

    Returns
    -------
    Neighbours
        Sorted by angle around the centre (counter-clockwise from east).

    Raises
    ------
    InputError
        Malformed bounds, arrays of the wrong shape, an edge pointing at a
        missing node, or a centre outside the bounds.
    """
    b = _check_bounds(bounds)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    edges = np.asarray(edges, dtype=np.intp).reshape(-1, 2)
    classes = np.asarray(highway, dtype=str).reshape(-1)
    if len(classes) != len(edges):
        raise InputError(f"neighbours: {len(edges)} edges but {len(classes)} highway classes")
    if len(edges) and (edges.min() < 0 or edges.max() >= len(xy)):
        raise InputError("neighbours: an edge refers to a node that does not exist")
    x = np.array([(b[0] + b[2]) / 2, (b[1] + b[3]) / 2]) if centre is None else np.asarray(centre, float)
    if _inset(x[None, :], b)[0] <= 0:
        raise InputError(f"neighbours: centre {tuple(x)} is not inside the bounds {tuple(b)}")
    road = _road_exits(xy, edges, classes, b, options)
    wet = _water_exits(water, b, options)
    exits = _Exits(*(np.concatenate([getattr(road, f), getattr(wet, f)])
                     for f in ("entry_xy", "direction", "exit_node", "kind", "rank")))
    if len(exits.rank) > options.max_neighbours:
        exits = exits.take(np.sort(np.argsort(exits.rank, kind="stable")[:options.max_neighbours]))
    generated = np.zeros(len(exits.entry_xy), dtype=bool)
    if len(exits.entry_xy) < options.min_neighbours:
        exits, generated = _fallback(exits, x, b, rng, options)
    position = exits.entry_xy + options.neighbour_distance * exits.direction
    order = np.lexsort((exits.exit_node, _angle(position - x)))
    return Neighbours(position[order], exits.entry_xy[order], exits.kind[order],
                      exits.exit_node[order], generated[order], x)


def neighbour_pairs(neighbours: Neighbours) -> NDArray[np.intp]:
    """003 §3.5's pair set ``y``: all pairs ``u < v``, smallest angle ``C_u X C_v`` first.

    Parameters
    ----------
    neighbours : Neighbours

    Returns
    -------
    (P, 2) intp
        Index pairs into ``neighbours`` (``P = K(K−1)/2``), sorted by the
        angle at the centre, ties by index (stable).
    """
    k = len(neighbours)
    u, v = np.triu_indices(k, 1)
    a = _angle(neighbours.xy - neighbours.centre)
    gap = np.abs(np.angle(np.exp(1j * (a[u] - a[v]))))
    order = np.argsort(gap, kind="stable")
    return np.stack([u[order], v[order]], axis=1).astype(np.intp)


def initial_pairs(neighbours: Neighbours, rng: np.random.Generator) -> NDArray[np.intp]:
    """003 §3.5's sublist ``y'``: the pairs the initial road network is built along.

    Pairs are removed from ``y`` smallest angle first "until the removal of a
    further pair would result in a disconnected initial road network" (read
    literally: the first pair whose removal would disconnect the neighbours
    stops the removal); the rest is shuffled with ``rng``.

    Parameters
    ----------
    neighbours : Neighbours
    rng : numpy.random.Generator

    Returns
    -------
    (P', 2) intp
        Index pairs into ``neighbours`` in the order their roads are built.
    """
    pairs = neighbour_pairs(neighbours)
    k = len(neighbours)
    alive = np.ones(len(pairs), dtype=bool)
    for i in range(len(pairs)):
        alive[i] = False
        p = pairs[alive]
        graph = coo_matrix((np.ones(len(p)), (p[:, 0], p[:, 1])), shape=(k, k))
        if k > 1 and connected_components(graph, directed=False)[0] > 1:
            alive[i] = True
            break
    kept = pairs[alive]
    return kept[rng.permutation(len(kept))]
