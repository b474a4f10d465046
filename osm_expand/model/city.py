"""The city: the real town as mapped, and everything the tool adds to it.

A :class:`City` is what every stage after ingest reads and returns: its
street network holds every street of the town as mapped (ids, tags, shapes
and dead ends kept) plus the streets the tool grew, each with its origin and
year; beside it the town's buildings, water, sea and mapped land use, the
blocks, and the current year. The simplified network and the example that
synthesis learns from are derived from a city and kept beside it by the
pipeline; they are never handed back as the town.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
import shapely

from osm_expand.model.geometry import ring_area, ring_edge_lengths
from osm_expand.model.land import OPEN_BLOCK, Land, town_blocks
from osm_expand.model.memo import ContentMemo, EachMemo, IdentityMemo, replace_keeping
from osm_expand.model.network import Context, Origin, StreetNetwork, Tags
from osm_expand.model.projection import LocalProjection


@dataclass(frozen=True, eq=False)
class Building:
    """A building footprint: the town's own (as mapped) or one the tool made.

    ``rings`` holds the outer ring first, then holes, each ``(n, 2)`` metres
    and closed. For the town's buildings ``node_ids`` holds the OSM node id
    of every ring point (so the footprint can be written back as mapped) and
    ``osm_type``/``osm_id`` the way or relation it came from.
    """

    rings: tuple[np.ndarray, ...]
    height: float | None = None  #: metres, from ``height`` (source) or the economy (generated)
    levels: float | None = None  #: from ``building:levels``, or the floors the model gave it
    osm_id: int = 0
    osm_type: str = "way"  #: "way" or "relation"
    node_ids: tuple[np.ndarray, ...] = ()
    tags: Tags = ()
    origin: Origin = Origin.SOURCE
    year: int | None = None
    land_use: str | None = None
    lot: int | None = None

    @property
    def ring(self) -> np.ndarray:
        """The outer ring."""
        return self.rings[0]

    @cached_property
    def polygon(self) -> shapely.Polygon:
        """The footprint as a polygon, made once per building: every year asks for the town's
        (which blocks are town, the site's rasters), and a year keeps last year's buildings as
        they were (Krems' 150 european years made 262,000 polygons of a few thousand buildings)."""
        return shapely.Polygon(self.rings[0], self.rings[1:])


@dataclass(frozen=True, eq=False)
class MappedArea:
    """An area mapped in OSM that later stages care about: land use, leisure, aeroway, military."""

    polygon: shapely.Geometry  #: metres
    key: str  #: the tag that made it interesting, e.g. ``landuse``
    value: str  #: its value, e.g. ``cemetery``
    osm_id: int = 0


#: A lot's land use before the build-out gives it one (the bundled ``residential_low`` type's name,
#: :class:`osm_expand.engine.buildout.lots.LandUse`).
DEFAULT_LOT_LAND_USE = "residential_low"


@dataclass(frozen=True, eq=False)
class Lot:
    """A building lot (002 §5.1, 004 §4.3.3): part of a block with access from a street.

    One type from the split of a block (:func:`osm_expand.engine.buildout.lots.subdivide`: the ring and
    the street each edge faces) to the city's lots the exporters write, whose access street, people, id
    and year the build-out's year sets (:meth:`placed`). ``ring`` is ``(N, 2)`` metres, counter-clockwise,
    without the closing point; ``edge_street`` is ``(N,)`` int64: the id of the street edge ``k``
    (``ring[k] → ring[k + 1]``) faces, or -1.
    """

    ring: np.ndarray
    edge_street: np.ndarray
    block: int = 0  #: the block's id (while the build-out splits blocks: its index among them)
    land_use: str = DEFAULT_LOT_LAND_USE  #: the land-use type's name
    street: int = -1  #: id of the street it faces (its access; the busiest one it touches); -1 not yet known
    people: float = 0.0  #: residents, workers and visitors over a day (the trip model's people)
    id: int = -1
    year: int | None = None

    @cached_property
    def polygon(self) -> shapely.Polygon:
        """metres."""
        return shapely.Polygon(self.ring)

    @cached_property
    def area(self) -> float:
        """m²."""
        return ring_area(self.ring)

    @property
    def streets(self) -> np.ndarray:
        """Sorted ids of the streets the lot fronts, (K,) int64."""
        return np.unique(self.edge_street[self.edge_street >= 0])

    def frontage(self) -> list[tuple[np.ndarray, np.ndarray, int]]:
        """Each street-facing edge as (start (2,), end (2,), street id)."""
        nxt = np.roll(self.ring, -1, axis=0)
        return [(self.ring[k], nxt[k], int(self.edge_street[k])) for k in np.flatnonzero(self.edge_street >= 0)]

    def frontage_length(self, street: int | None = None) -> float:
        """m of the boundary facing ``street`` (any street when None)."""
        lengths = ring_edge_lengths(self.ring)
        mask = self.edge_street >= 0 if street is None else self.edge_street == street
        return float(lengths[mask].sum())

    def placed(self, *, block: int, street: int, land_use: str, people: float, id: int, year: int | None) -> Lot:
        """The lot as the city holds it at a year's end; its polygon and area, once made, come along (the
        build-out hands every lot to the city every year)."""
        return replace_keeping(self, ("polygon", "area"), block=block, street=street, land_use=land_use,
                               people=people, id=id, year=year)


@dataclass(frozen=True, eq=False)
class UnplacedWay:
    """A way of the town that a clipped extract leaves without a drawable shape (fewer than two
    consecutive nodes inside it): no stage uses it, the OSM output gives it back as mapped."""

    osm_id: int
    refs: tuple[int, ...]  #: every node id, as mapped (most of them missing from the extract)
    located: tuple[int, ...]  #: the node ids the extract has
    xy: np.ndarray  #: (len(located), 2) metres
    tags: Tags = ()


@dataclass(frozen=True)
class SourceFile:
    """The OSM file a city was read from, so the OSM output can give back all of it (not only what
    the stages use): the writer streams it again rather than the city holding every object.

    ``ways`` are the ids of the ways ingest took into the city (streets, buildings, unplaced ways):
    one of them the city no longer holds was demolished (:func:`demolished_ways`).
    """

    path: str
    ways: frozenset[int] = frozenset()


#: Derived from the model's objects by their identity (:class:`~osm_expand.model.memo.IdentityMemo`): the year
#: loop makes a new City every year, sharing the water, land, buildings and (until the streets change) the
#: blocks with last year's, and these are asked for many times a year.
_UNIONS = IdentityMemo()  #: the union of water, sea and unbuildable land, and its parts with a tree
_FOOTPRINTS = IdentityMemo()  #: the buildings' polygons
_BLOCKS = IdentityMemo()  #: the blocks' polygons and a tree over them
_TAKEN = IdentityMemo()  #: the union of the land the town takes (:attr:`Land.taken`)
#: :meth:`City.occupied_within` by the content of what it unions: a year whose district failed asks for the
#: land around the same sites again, in a town whose blocks and buildings are new objects but the same there.
#: 32 entries: a site asks for up to five discs (:data:`osm_expand.sites.REGION_STEPS`) and its joins for a
#: few areas more, so 32 hold the asks of the last several sites of a year, which is what a failed year's
#: retry asks for again; each entry is one union of a disc's land. Where sites are not retried on the same
#: land nothing is found again (Campo Grande: 393 asked, none found again), and the memo costs only those
#: 32 unions' memory.
_OCCUPIED = ContentMemo(kept=32)
#: The area of a large block's overlap with each building on it (:func:`_overlap`), per pair of polygons.
_OVERLAPS = EachMemo()


def _land_nobody_takes(water: tuple, sea: tuple, unbuildable: shapely.Geometry | None) -> shapely.Geometry:
    """The union of water, sea and unbuildable land (the slow part of :attr:`City.occupied`), made once for
    the very same three objects."""
    def make() -> shapely.Geometry:
        return shapely.union_all([*water, *sea] + ([unbuildable] if unbuildable is not None else []))
    return _UNIONS.get((water, sea, unbuildable), "union", make)


def _land_parts(water: tuple, sea: tuple, unbuildable: shapely.Geometry | None
                ) -> tuple[np.ndarray, shapely.STRtree]:
    """The parts of :func:`_land_nobody_takes` and a tree over them (made once beside the union)."""
    def make() -> tuple[np.ndarray, shapely.STRtree]:
        union = _land_nobody_takes(water, sea, unbuildable)
        parts = shapely.get_parts(union) if not union.is_empty else np.empty(0, dtype=object)
        return parts, shapely.STRtree(parts)
    return _UNIONS.get((water, sea, unbuildable), "parts", make)


def _taken_union(taken: np.ndarray) -> shapely.Geometry:
    """The union of the town's taken land (:attr:`Land.taken`), made once for the very same array: the land
    is read once and shared by every year's City, and :meth:`City.occupied_within` asks for it 18 times on
    Krems, 35 on Monaco. Cutting each ask's box out of it (0.001-0.002 s) is cheaper than a union of the
    pieces meeting the box every time: occupied_within Krems 0.84 -> 0.50 s CPU, Monaco 1.54 -> 0.76 s
    (session 39, h39k's measure)."""
    return _TAKEN.get((taken,), None, lambda: shapely.union_all(taken))


def _footprints(buildings: tuple[Building, ...]) -> np.ndarray:
    """The buildings' polygons, (B,) object array, made once for the very same tuple of buildings.

    Every district the engine grows asks which blocks are town several times
    (:meth:`City.occupied_within`), and the year's City shares its buildings
    with last year's until the build-out adds some: making Campo Grande's
    polygons each time took 7.6 s of a 30-year run (293,000 polygons).
    """
    return _FOOTPRINTS.get((buildings,), None,
                           lambda: _frozen(np.array([b.polygon for b in buildings], dtype=object)))


def _block_index(blocks: tuple[Block, ...]) -> tuple[np.ndarray, shapely.STRtree]:
    """The blocks' polygons and a tree over them, made once for the very same tuple of blocks (the
    blocks change once a year; a district asks for those near it five to ten times)."""
    def make() -> tuple[np.ndarray, shapely.STRtree]:
        polygons = _frozen(np.array([b.polygon for b in blocks], dtype=object))
        return polygons, shapely.STRtree(polygons)
    return _BLOCKS.get((blocks,), None, make)


def _overlap(blocks: np.ndarray, buildings: np.ndarray) -> np.ndarray:
    """The areas (m²) of the intersections of ``blocks`` and ``buildings`` pair by pair, each made once for the
    very same two polygons: every year asks which large blocks are town, of a town whose blocks and buildings
    are mostly last year's objects (Krems' 150 north-american years, 13 large blocks at the end: with the
    growth's 1 m shrink of the blocks kept too, :func:`osm_expand.engine.growth.minor_streets._forbidden` went
    from 3.54 to 1.79 s CPU, the same bytes)."""
    def make(missing: list[int]) -> list[float]:
        return shapely.area(shapely.intersection(blocks[missing], buildings[missing])).tolist()
    return np.array(_OVERLAPS.get(list(zip(blocks.tolist(), buildings.tolist())), make), dtype=np.float64)


def _union_prepared(geoms: list[shapely.Geometry]) -> shapely.Geometry:
    """The union of ``geoms``, prepared: it is asked many point and line questions (where streets may go)."""
    geom = shapely.union_all(geoms)
    shapely.prepare(geom)
    return geom


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False  # shared between callers: nobody may change it in place
    return array


@dataclass(frozen=True, eq=False)
class Block:
    """A block: a face of the street graph (004 §4.3) that knows the streets around it.

    ``street_ids[i]`` is the id of the street that the exterior edge from
    point i to point i+1 lies on, so lots can find their frontage.
    """

    polygon: shapely.Polygon
    street_ids: tuple[int, ...]
    id: int = -1
    origin: Origin = Origin.SOURCE
    year: int | None = None
    land_use: str | None = None  #: the block's land-use type (it sets its lots' sizes, 002 §4), once built out


@dataclass(frozen=True)
class City:
    """The town and everything added to it; stages return a new City, never mutate one."""

    network: StreetNetwork  #: every street: the town's as mapped, and the new ones
    buildings: tuple[Building, ...] = ()
    water: tuple[shapely.Geometry, ...] = ()  #: water areas and rivers buffered to their width
    sea: tuple[shapely.Geometry, ...] = ()  #: assembled from coastline
    areas: tuple[MappedArea, ...] = ()
    blocks: tuple[Block, ...] = ()
    lots: tuple[Lot, ...] = ()
    unplaced: tuple[UnplacedWay, ...] = ()  #: mapped ways without a drawable shape, given back as mapped
    #: ``highway=service`` ways the network leaves out (ingest without ``--service``), as LineStrings
    #: in metres: evidence of the town's land only (their frontage), never streets, never output
    service_lines: tuple[shapely.Geometry, ...] = ()
    year: int | None = None  #: the current year (the map's, from its newest object, at ingest)
    unbuildable: shapely.Geometry | None = None  #: land nothing new may take (see :mod:`osm_expand.land`)
    #: the land as the town uses it: frontage, settlement, land cover (see :mod:`osm_expand.land`)
    land: Land | None = None
    stats: dict[str, Any] = field(default_factory=dict)  #: what ingest counted
    source: SourceFile | None = None  #: the OSM file read (None: not read from OSM, e.g. a simplified network)

    @property
    def context(self) -> Context:
        return self.network.context

    @property
    def projection(self) -> LocalProjection:
        return self.network.context.projection

    @property
    def bounds_xy(self) -> tuple[float, float, float, float]:
        """The bounds of the map's data in metres: what lies outside is unknown land."""
        return self.network.context.bounds_xy

    @property
    def bounds_polygon(self) -> shapely.Polygon:
        """The data bounds as a polygon in metres (the projected corners of the lon/lat box)."""
        proj = self.projection
        lon0, lat0, lon1, lat1 = self.context.bounds_lonlat
        lon = np.array([lon0, lon1, lon1, lon0])
        lat = np.array([lat0, lat0, lat1, lat1])
        return shapely.Polygon(np.column_stack(proj.to_xy(lon, lat)))

    def replace(self, **changes: Any) -> City:
        return replace(self, **changes)

    def water_geometry(self) -> shapely.Geometry:
        """Water and sea as one geometry (empty when there is none).

        The union of the very same water and sea as last time comes back as it
        is: every year of the engine asks, and the water does not change.
        """
        return _land_nobody_takes(self.water, self.sea, None)

    def town_block_polygons(self, among: np.ndarray | None = None) -> np.ndarray:
        """The blocks that are town (:func:`osm_expand.model.land.town_blocks`): a large face of fields
        between roads is not, so streets may grow into it. ``among``: (B,) bool, only those blocks
        (the polygons and tree of all blocks are made once a year, not for every selection)."""
        polygons = _block_index(self.blocks)[0]
        return self._town_of(polygons if among is None else polygons[among])

    def _town_of(self, polygons: np.ndarray) -> np.ndarray:
        """Those of the block ``polygons`` that are town (buildings read only when one is large)."""
        if not len(polygons):
            return polygons
        large = shapely.area(polygons) > OPEN_BLOCK
        footprints = _footprints(self.buildings) if large.any() else np.empty(0, dtype=object)
        return polygons[town_blocks(polygons, footprints, overlap=_overlap)]

    @cached_property
    def occupied(self) -> shapely.Geometry:
        """Where no new street may go: water, sea, unbuildable land, the land the town takes (its
        frontage and settlement, :class:`~osm_expand.model.land.Land`), and the town's blocks (shrunk
        1 m, so streets may run along their edges)."""
        blocks = shapely.buffer(self.town_block_polygons(), -1.0)
        taken = self.land.taken.tolist() if self.land is not None else []
        return _union_prepared([_land_nobody_takes(self.water, self.sea, self.unbuildable), *taken,
                                *blocks.tolist()])

    def occupied_within(self, area: shapely.Geometry, *, taken: bool = True) -> shapely.Geometry:
        """:attr:`occupied` where it meets ``area``'s bounding box: the same answer to any question
        asked inside ``area``, without the union of the whole town (0.8 s on Campo Grande, paid
        for every district the engine grows). ``taken=False`` leaves out the land the town is taken
        to use (:attr:`Land.taken`): a joining street may pass between presumed houses when nothing
        else joins."""
        box = shapely.box(*area.bounds)
        parts, tree = _land_parts(self.water, self.sea, self.unbuildable)
        near = parts[tree.query(box, predicate="intersects")] if len(parts) else parts
        blocks, block_tree = _block_index(self.blocks)
        if len(blocks):  # those meeting the box, in the blocks' order
            blocks = shapely.buffer(self._town_of(blocks[np.sort(block_tree.query(box, predicate="intersects"))]), -1.0)
        # the taken land inside the box: the same land as its pieces meeting the box, but for the last bits
        held = ([shapely.intersection(_taken_union(self.land.taken), box)]
                if self.land is not None and taken and len(self.land.taken) else [])
        inputs = [*near.tolist(), *held, *blocks.tolist()]
        return _OCCUPIED.get(ContentMemo.key(inputs), _union_prepared, inputs)

    def new_streets(self) -> list[int]:
        """Indices (into ``network.streets``) of the streets the tool made."""
        return [k for k, s in enumerate(self.network.streets) if s.is_new]


def held_ways(city: City) -> set[int]:
    """Ids of the OSM ways the city holds: its streets from the map (each part of one), its mapped
    buildings drawn as ways, and the ways it keeps without a shape. Negative ids count: a map may
    be an earlier output, whose new ways have them."""
    held = {s.osm_ids[0] for s in city.network.streets if len(s.osm_ids) == 1 and s.osm_ids[0] != 0}
    held.update(b.osm_id for b in city.buildings if b.osm_type == "way" and b.osm_id != 0)
    held.update(w.osm_id for w in city.unplaced)
    return held


def demolished_ways(city: City) -> list[int]:
    """Ids, ascending, of the ways read from the map that the city no longer holds (a history
    demolished them); the OSM output leaves them out."""
    return sorted(city.source.ways - held_ways(city)) if city.source is not None else []
