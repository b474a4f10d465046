"""Grow new streets in a region from a town's example (004 §4.3.2).

The example's junction cloud is copied into the region (translated onto its
centre, optionally rotated), keeping only the junctions that land inside it
and outside the obstacles (water, the old town). Old-town junctions with free
slots can be added as *border* junctions: targets of any level, so the new
district connects to the town. The random walk then draws the streets, and
:mod:`synth.shape` gives them dead ends and curved shapes like the example's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from simplify.example import Example
from synth.shape import add_dead_ends, shaped_streets
from synth.walk import ANY_LEVEL, NodeCloud, WalkOptions, WalkResult, random_walk


@dataclass(frozen=True)
class GrowResult:
    cloud: NodeCloud
    walk: WalkResult
    source: np.ndarray  # per cloud junction: the example junction it copies (-1 for a border junction)
    streets: list[tuple[int, np.ndarray]]  # (level, polyline) with shapes and dead ends restored

    def polylines(self) -> list[tuple[int, np.ndarray]]:
        return self.streets


def place(example: Example, region, obstacles=None, rotation_deg: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Copy the example's junctions onto the region's centre; the ones that fit, and their source ids."""
    xy = example.xy - example.xy.mean(axis=0)
    a = np.radians(rotation_deg)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    centre = np.array(shapely.centroid(region).coords[0])
    placed = xy @ rot.T + centre
    pts = shapely.points(placed)
    keep = shapely.contains(region, pts)
    if obstacles is not None:
        keep &= ~shapely.intersects(obstacles, pts)
    return placed[keep], np.flatnonzero(keep)


def grow(example: Example, region, obstacles=None, border_xy: np.ndarray | None = None,
         border_slots: np.ndarray | None = None, seed: int = 0, rotation_deg: float = 0.0,
         options: WalkOptions | None = None, shapes: bool = True) -> GrowResult:
    """Streets for ``region`` that look like the example's; same seed, same streets."""
    xy, source = place(example, region, obstacles, rotation_deg)
    cloud = _cloud(example, xy, source, border_xy, border_slots)
    walk = random_walk(cloud, seed=seed, options=options or WalkOptions(complete=True), obstacles=obstacles)
    n_border = 0 if border_xy is None else len(border_xy)
    rng = np.random.default_rng([seed, 1])
    if shapes:
        points, stubs = add_dead_ends(example, cloud.xy, walk.streets, region, obstacles, rng)
        streets = shaped_streets(example, points, walk.streets + stubs, obstacles, rng)
    else:
        streets = [(level, cloud.xy[path]) for level, path in walk.streets]
    return GrowResult(cloud=cloud, walk=walk, source=np.concatenate([source, np.full(n_border, -1)]),
                      streets=streets)


def _cloud(ex: Example, xy, source, border_xy, border_slots) -> NodeCloud:
    fields = {name: getattr(ex, name)[source] for name in
              ("level", "length_mean", "length_std", "angle_mean", "angle_std")}
    cap = ex.record_cap[source]
    if border_xy is not None and len(border_xy):
        n = len(border_xy)
        slots = np.ones(n, dtype=np.int64) if border_slots is None else np.asarray(border_slots)
        xy = np.vstack([xy, border_xy])
        fields["level"] = np.vstack([fields["level"], np.column_stack([np.full(n, ANY_LEVEL), np.full(n, -1)])])
        for name in ("length_mean", "length_std", "angle_mean", "angle_std"):
            fields[name] = np.vstack([fields[name], np.full((n, 2), np.nan)])
        cap = np.vstack([cap, np.column_stack([np.minimum(slots, 2), np.zeros(n, dtype=np.int64)])])
    return NodeCloud(xy=xy, cap=cap, **fields)
