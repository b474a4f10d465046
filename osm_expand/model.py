"""The one street-network model every stage reads and returns.

Nodes live in a single ``(N, 2)`` float64 array of metres in a local
transverse Mercator projection; streets are ordered node-index sequences that
keep the full OSM shape between junctions. Stages never mutate a network:
they build a new one with :meth:`StreetNetwork.replace` so that every pass
stays a pure function.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from osm_expand.projection import LocalProjection


@dataclass(frozen=True, slots=True)
class Street:
    """One street: an ordered run of node indices plus its OSM attributes.

    ``nodes`` includes shape points, not only junctions. A closed street
    (a ring) repeats its first node at the end.
    """

    nodes: tuple[int, ...]
    highway: str
    name: str | None = None
    layer: int = 0
    bridge: bool = False
    tunnel: bool = False
    junction: str | None = None
    lanes: float | None = None
    width: float | None = None
    osm_ids: tuple[int, ...] = ()
    hierarchy: int = -1
    status: str = "built"
    year: int | None = None

    @property
    def layer_key(self) -> tuple[int, bool, bool]:
        """Streets cross only at a junction when their layer keys are equal."""
        return (self.layer, self.bridge, self.tunnel)

    @property
    def is_closed(self) -> bool:
        return len(self.nodes) > 2 and self.nodes[0] == self.nodes[-1]

    def with_nodes(self, nodes: tuple[int, ...] | list[int]) -> "Street":
        return replace(self, nodes=tuple(nodes))


@dataclass(frozen=True)
class Building:
    """An existing building footprint (outer ring, metres) and its height tags."""

    ring: np.ndarray
    height: float | None = None
    levels: float | None = None
    osm_id: int = 0


@dataclass(frozen=True)
class Context:
    """Everything around the streets that later stages need.

    ``water`` holds shapely polygons (areas, and waterway lines buffered by
    their class width); ``sea`` the sea polygons assembled from coastline.
    """

    projection: LocalProjection
    bounds_lonlat: tuple[float, float, float, float]
    bounds_from_header: bool
    water: tuple[Any, ...] = ()
    sea: tuple[Any, ...] = ()
    buildings: tuple[Building, ...] = ()

    @property
    def bounds_xy(self) -> tuple[float, float, float, float]:
        lon0, lat0, lon1, lat1 = self.bounds_lonlat
        xs, ys = self.projection.to_xy(np.array([lon0, lon1, lon0, lon1]), np.array([lat0, lat0, lat1, lat1]))
        return (float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max()))


@dataclass(frozen=True)
class StreetNetwork:
    """Nodes in metres, streets over them, and the context they sit in."""

    xy: np.ndarray
    node_ids: np.ndarray
    streets: tuple[Street, ...]
    context: Context
    stats: dict[str, Any] = field(default_factory=dict)

    def replace(self, **changes: Any) -> "StreetNetwork":
        return replace(self, **changes)

    def street_xy(self, street: Street) -> np.ndarray:
        return self.xy[np.asarray(street.nodes, dtype=np.intp)]

    def used_nodes(self) -> np.ndarray:
        """Sorted indices of the nodes that some street references."""
        if not self.streets:
            return np.zeros(0, dtype=np.intp)
        return np.unique(np.concatenate([np.asarray(s.nodes, dtype=np.intp) for s in self.streets]))

    def total_length(self) -> float:
        return float(sum(polyline_length(self.street_xy(s)) for s in self.streets))


def polyline_length(xy: np.ndarray) -> float:
    if len(xy) < 2:
        return 0.0
    return float(np.hypot(*np.diff(xy, axis=0).T).sum())


def closest_on_segments(pt: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For point(s) ``pt`` against segments a→b (broadcast): the parameter along
    each segment of the closest point, that point, and the distance to it."""
    d = b - a
    t = np.clip(((pt - a) * d).sum(axis=-1) / np.maximum((d * d).sum(axis=-1), 1e-24), 0.0, 1.0)
    foot = a + t[..., None] * d
    return t, foot, np.hypot(*np.moveaxis(pt - foot, -1, 0))


def network_from_lines(lines: list, attrs: list[dict] | None = None,
                       projection: LocalProjection | None = None) -> StreetNetwork:
    """A network from polylines in metres; equal coordinates become one shared node.

    For hand-built examples, tests and synthesised streets. ``attrs`` gives
    per-line :class:`Street` fields (default: residential, layer 0).
    """
    proj = projection or LocalProjection(0.0, 0.0)
    index: dict[tuple[float, float], int] = {}
    streets = []
    for k, line in enumerate(lines):
        nodes = tuple(index.setdefault((float(x), float(y)), len(index)) for x, y in line)
        fields = {"highway": "residential", **(attrs[k] if attrs else {})}
        streets.append(Street(nodes=nodes, **fields))
    xy = np.array(list(index.keys()), dtype=float).reshape(-1, 2)
    if len(xy):
        lon, lat = proj.to_lonlat(xy[:, 0], xy[:, 1])
        bounds = (float(lon.min()), float(lat.min()), float(lon.max()), float(lat.max()))
    else:
        bounds = (proj.lon0, proj.lat0, proj.lon0, proj.lat0)
    context = Context(projection=proj, bounds_lonlat=bounds, bounds_from_header=False)
    return StreetNetwork(xy=xy, node_ids=np.zeros(len(xy), dtype=np.int64), streets=tuple(streets), context=context)
