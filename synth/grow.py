"""Grow new streets in a region from a town's example (004 §4.3.2).

The example's junction cloud is copied into the region (its densest part on
the region's centre, optionally rotated; further copies fill what the first
left empty), keeping only the junctions that land inside it and outside the
obstacles (water, the old town). Old-town junctions with free
slots can be added as *border* junctions: targets of any level, so the new
district connects to the town. The random walk then draws the streets, and
:mod:`synth.shape` gives them dead ends and curved shapes like the example's.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.spatial import cKDTree

from osm_expand.model import match_points
from simplify.example import Example
from synth.shape import add_dead_ends, shaped_streets
from synth.walk import ANY_LEVEL, NodeCloud, WalkOptions, WalkResult, random_walk


@dataclass(frozen=True)
class GrowResult:
    cloud: NodeCloud
    walk: WalkResult
    streets: list[tuple[int, np.ndarray]]  # (level, polyline) with shapes and dead ends restored

    def polylines(self) -> list[tuple[int, np.ndarray]]:
        return self.streets


def _density_order(xy: np.ndarray, radius: float) -> np.ndarray:
    """Junctions, most junctions within ``radius`` first: the parts of the town worth copying."""
    counts = cKDTree(xy).query_ball_point(xy, radius, return_length=True)
    return np.argsort(-counts, kind="stable")


#: A copy's junction is kept only this many typical spacings from the junctions already placed.
SEAM_GAP = 0.8
#: The region counts as covered when no free point is further than this many spacings from a junction.
COVERED = 1.5
#: At most this many copies of the example fill one region.
MAX_COPIES = 64


def place(example: Example, region, obstacles=None, rotation_deg: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Copies of the example's junctions that fill the region; their positions and example ids.

    The first copy puts the example's densest part on the region's centre.
    While some free point of the region is more than :data:`COVERED` typical
    spacings from every placed junction, another copy goes into the largest
    such hole, centred on the next densest part of the example not used yet,
    and keeps the junctions inside the hole that are at least
    :data:`SEAM_GAP` spacings from those already placed. A town smaller than
    the region is so tiled rather than dropped in as one island.
    """
    radius = float(np.sqrt(shapely.area(region) / np.pi))
    spacing = example.spacing
    order = _density_order(example.xy, radius)
    a = np.radians(rotation_deg)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    free = _free_points(region, obstacles, spacing / 2)
    gap = np.full(len(free), np.inf)  # free point → nearest placed junction
    from_copied = np.full(len(example.xy), np.inf)  # example junction → nearest centre copied so far
    placed: list[np.ndarray] = []
    ids: list[np.ndarray] = []
    hole, hole_radius = np.array(shapely.centroid(region).coords[0]), radius
    for copy in range(MAX_COPIES):
        far = from_copied >= hole_radius
        source = int(order[np.argmax(far[order])]) if far.any() else int(order[copy % len(order)])
        from_copied = np.minimum(from_copied, np.hypot(*(example.xy - example.xy[source]).T))
        xy = (example.xy - example.xy[source]) @ rot.T + hole
        keep = (np.hypot(*(xy - hole).T) <= hole_radius + spacing / 2) & _inside(region, obstacles, xy)
        if placed:
            keep &= cKDTree(np.vstack(placed)).query(xy)[0] >= SEAM_GAP * spacing
        if keep.any():
            placed.append(xy[keep])
            ids.append(np.flatnonzero(keep))
            if len(free):
                gap = np.minimum(gap, cKDTree(xy[keep]).query(free)[0])
        if not len(free) or not placed or gap.max() <= COVERED * spacing:
            break
        hole, hole_radius = free[int(np.argmax(gap))], float(gap.max())
    if not placed:
        return np.empty((0, 2)), np.empty(0, dtype=np.int64)
    return np.vstack(placed), np.concatenate(ids)


def _inside(region, obstacles, xy: np.ndarray) -> np.ndarray:
    keep = shapely.contains_xy(region, xy[:, 0], xy[:, 1])
    if obstacles is not None and not obstacles.is_empty:
        shapely.prepare(obstacles)
        keep &= ~shapely.intersects_xy(obstacles, xy[:, 0], xy[:, 1])
    return keep


def _free_points(region, obstacles, step: float) -> np.ndarray:
    """A grid of points ``step`` apart over the region, outside the obstacles."""
    x0, y0, x1, y1 = region.bounds
    gx, gy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    return pts[_inside(region, obstacles, pts)]


def grow(example: Example, region: shapely.Geometry, *, obstacles: shapely.Geometry | None = None,
         border_xy: np.ndarray | None = None, border_slots: np.ndarray | None = None,
         seed: int | np.random.Generator = 0, rotation_deg: float = 0.0, options: WalkOptions | None = None,
         shapes: bool = True, old_streets: Sequence[np.ndarray] = ()) -> GrowResult:
    """Streets for ``region`` that look like the example's; same seed, same streets.

    Parameters
    ----------
    example : Example
        What the town's streets are like (:func:`simplify.example.build_example`).
    region : shapely geometry
        Where to grow (metres).
    obstacles : shapely geometry, optional
        What no street may touch: water, the old town's blocks, unbuildable land.
    border_xy : (b, 2) float array, optional
        Nodes of the town near the region that new streets may end on
        (targets of every level); their exact coordinates come back in the
        polylines of the streets that end there.
    border_slots : (b,) int array, optional
        Free segments at each border node (default 1).
    seed : int or numpy Generator
        Same seed, same streets.
    rotation_deg : float
        Turn the copied junction cloud by this much (degrees, counter-clockwise).
    options : WalkOptions
        Default: the walk with the completion steps growth needs.
    shapes : bool
        Give streets the example's shapes and dead ends back.
    old_streets : sequence of (n, 2) float arrays
        The town's streets near the region: never crossed; where one passes
        through a border node, new streets may meet it there.

    Returns
    -------
    GrowResult
        The cloud, the walk and the streets as (level, polyline) pairs.
    """
    walk_rng, shape_rng = np.random.default_rng(seed).spawn(2)
    xy, source = place(example, region, obstacles, rotation_deg)
    cloud = _cloud(example, xy, source, border_xy, border_slots)
    fixed = _fixed_segments(old_streets, cloud.xy[len(xy):], len(xy))
    walk = random_walk(cloud, seed=walk_rng, options=options or WalkOptions(complete=True), obstacles=obstacles,
                       fixed=fixed)
    rng = shape_rng
    if shapes:
        assert walk.drawn is not None  # random_walk always returns its index
        points, stubs = add_dead_ends(example, cloud.xy, walk.streets, region, obstacles, rng,
                                      walk.drawn, walk.segment)
        streets = shaped_streets(example, points, walk.streets + stubs, obstacles, rng, walk.drawn, walk.segment,
                                 region)
    else:
        streets = [(level, cloud.xy[path]) for level, path in walk.streets]
    return GrowResult(cloud=cloud, walk=walk, streets=streets)


def _fixed_segments(old_streets, border_xy: np.ndarray, first_border: int):
    """Old streets as segments; ends at a border node carry its cloud id, others unique negatives."""
    out, fresh = [], -1
    for line in old_streets:
        line = np.asarray(line, dtype=float)
        border = match_points(line, border_xy)
        loose = border < 0
        names = border + first_border
        names[loose] = np.arange(fresh, fresh - int(loose.sum()), -1)
        fresh -= int(loose.sum())
        out += [(line[i], line[i + 1], int(names[i]), int(names[i + 1])) for i in range(len(line) - 1)]
    return out


def _cloud(ex: Example, xy, source, border_xy, border_slots) -> NodeCloud:
    """The placed copies, then the border junctions: one record each, of any level."""
    cloud = NodeCloud.from_example(ex, take=source, xy=xy)
    if border_xy is None or not len(border_xy):
        return cloud
    n = len(border_xy)
    slots = np.ones(n, dtype=np.int64) if border_slots is None else np.asarray(border_slots)
    nan = np.full((n, 2), np.nan)
    border = NodeCloud(xy=np.asarray(border_xy, dtype=float),
                       level=np.column_stack([np.full(n, ANY_LEVEL), np.full(n, -1)]),
                       length_mean=nan, length_std=nan, angle_mean=nan, angle_std=nan,
                       cap=np.column_stack([np.minimum(slots, 2), np.zeros(n, dtype=np.int64)]))
    return cloud.stacked(border)
