"""Read an OSM extract into a :class:`City` (the only stage that reads OSM).

pyosmium streams the file with a node-location index, and its C++ filters
drop everything that is not a street, water, building or mapped land area
before Python sees it, so memory and time scale with the town, not the file.

What is kept, as mapped (ids, tags and shapes):

- streets: ways of the selected ``highway=*`` classes (see
  :mod:`osm_expand.model.highways`); ways that reference nodes missing from a
  clipped extract are split at the gap and counted;
- buildings: closed ways and multipolygon relations with ``building=*``,
  with every ring's node ids, so they can be written back as mapped;
- water: water areas and multipolygons, waterway lines buffered by their
  width, coastline closed against the bounds into sea;
- mapped areas (:data:`AREA_KEYS`): land use, leisure, aeroway, military,
  natural vegetation and works' enclosures (``man_made=works`` and kin,
  ``power=plant|substation``), for the unbuildable land, the taken land and
  land use;
- the map's year: that of its newest way or relation.

Node coordinates that are not numbers (``lat="nan"``) or lie outside the
globe are an :class:`~osm_expand.errors.InputError` naming the file.
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import osmium
import shapely

from osm_expand.coastline import assemble_sea
from osm_expand.errors import InputError, UnreadableInputError
from osm_expand.model import (
    Building,
    City,
    Context,
    MappedArea,
    SourceFile,
    Street,
    StreetNetwork,
    UnplacedWay,
    held_ways,
)
from osm_expand.model.highways import highway_set
from osm_expand.model.projection import LocalProjection
from osm_expand.osmtags import number as _number  # the name tests and old callers use
from osm_expand.osmtags import street_attrs

OSM_SUFFIXES = (".osm", ".osm.gz", ".osm.bz2", ".osm.pbf", ".pbf", ".xml.gz", ".xml.bz2")
#: Files ``load`` reads: OSM extracts, and the tool's own GeoJSON and urbanenvironment outputs.
SUFFIXES = OSM_SUFFIXES + (".xml", ".geojson", ".json")

#: Default river widths (m) by ``waterway=*`` when no ``width`` tag says otherwise.
WATERWAY_WIDTH = {"river": 20.0, "canal": 12.0, "stream": 3.0, "drain": 2.0, "ditch": 1.5}
WATER_AREA_TAGS = {"natural": {"water"}, "waterway": {"riverbank", "dock"}, "landuse": {"reservoir", "basin"}}
#: Mapped areas kept for later stages: key → the values kept (None: every value).
AREA_KEYS: dict[str, frozenset[str] | None] = {
    "landuse": None, "leisure": None, "aeroway": None, "military": None,
    "amenity": frozenset({"grave_yard"}),
    "natural": frozenset({"wood", "scrub", "heath", "grassland", "wetland", "beach", "bare_rock"}),
    # works' enclosures, often mapped without landuse=industrial: the town's land (land.WORKS)
    "man_made": frozenset({"wastewater_plant", "water_works", "works"}),
    "power": frozenset({"plant", "substation"}),
}
_UNDEFINED = 2147483647  # libosmium's undefined coordinate


@dataclass
class _Raw:
    """What the OSM pass collects, in lon/lat, before projection."""

    streets: list[tuple[list[int], list[tuple[float, float]], dict]] = field(default_factory=list)
    clipped_ways: int = 0
    input_ways: int = 0
    waterways: list[tuple[list[tuple[float, float]], float]] = field(default_factory=list)
    water_areas: list[list[list[tuple[float, float]]]] = field(default_factory=list)
    coastline: list[list[tuple[float, float]]] = field(default_factory=list)
    #: (rings as (node ids, lon/lat), tags, osm type, osm id)
    buildings: list[tuple[list[tuple[list[int], list[tuple[float, float]]]], dict, str, int]] = field(
        default_factory=list)
    clipped_buildings: int = 0
    #: ways kept as mapped but without a drawable shape: (id, refs, located refs and lon/lat, tags)
    unplaced: list[tuple[int, list[int], list[tuple[int, tuple[float, float]]], dict]] = field(default_factory=list)
    areas: list[tuple[list[list[tuple[float, float]]], str, str, int]] = field(default_factory=list)
    newest: int = 0  # the newest object's timestamp (seconds since 1970)
    #: street nodes the file gave no location (absent from a clipped extract, or without lat/lon)
    missing: set[int] = field(default_factory=set)
    #: ``highway=service`` ways outside the kept classes: land evidence (lon/lat runs), not streets
    service: list[list[tuple[float, float]]] = field(default_factory=list)


def check_readable(path: str | os.PathLike, suffixes: tuple[str, ...] = SUFFIXES) -> Path:
    """Fail early, in one line, on paths osmium would choke on or misread."""
    p = Path(path)
    try:
        return _check_readable(p, suffixes)
    except OSError as exc:  # a name too long, a loop of links, ...
        raise UnreadableInputError(f"{p}: cannot read it ({exc.strerror or exc})") from None


def _check_readable(p: Path, suffixes: tuple[str, ...]) -> Path:
    if not p.exists():
        raise UnreadableInputError(f"{p}: no such file")
    if p.is_dir():
        raise UnreadableInputError(f"{p}: is a directory, not an OSM file")
    if not os.access(p, os.R_OK):
        raise UnreadableInputError(f"{p}: permission denied")
    if p.stat().st_size == 0:
        raise UnreadableInputError(f"{p}: file is empty")
    if not p.name.lower().endswith(suffixes):
        raise UnreadableInputError(f"{p}: unsupported file type (expected {', '.join(OSM_SUFFIXES[:4])})")
    return p


def load(path: str | os.PathLike, *, service: bool = False, paths: bool = False, context: bool = True) -> City:
    """Read a town from ``path``: streets, buildings, water and mapped areas, in metres.

    Parameters
    ----------
    path : path
        An OSM extract (``.osm``, ``.osm.gz``, ``.osm.bz2``, ``.osm.pbf``),
        or a GeoJSON or ``<urbanenvironment>`` file written by osm-expand.
    service, paths : bool
        Add ``highway=service`` and footways/paths/tracks to the drivable set.
    context : bool
        ``False`` reads streets only, in one pass (all ``simplify`` needs).

    Returns
    -------
    City
        The town as mapped, projected to a transverse Mercator centred on it.
    """
    p = check_readable(path)
    name = p.name.lower()
    if name.endswith((".geojson", ".json")) or (name.endswith(".xml") and _is_urbanenvironment(p)):
        from osm_expand.readback import load_output

        return load_output(p)
    kept = highway_set(service=service, paths=paths)
    try:
        try:
            raw, header_box = _read(str(p), kept, context, relations=context)
        except RuntimeError as exc:
            if "out of order" not in str(exc):
                raise
            # libosmium's multipolygon assembly needs sorted input; unsorted
            # files still give their closed-way buildings, water and areas.
            raw, header_box = _read(str(p), kept, context, relations=False)
    except InputError as exc:
        raise UnreadableInputError(f"{p}: {exc}") from None
    except osmium.InvalidLocationError as exc:
        raise UnreadableInputError(f"{p}: a node has an invalid location ({exc})") from None
    except (RuntimeError, ValueError, OSError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UnreadableInputError(f"{p}: not a readable OSM file ({msg})") from None
    if not raw.streets:
        raise UnreadableInputError(f"{p}: no streets of the selected highway classes"
                                   + ("" if service else " (try --service)"))
    try:
        if raw.missing:
            _check_missing(str(p), raw.missing)
        city = _build(raw, header_box)
    except InputError as exc:
        raise UnreadableInputError(f"{p}: {exc}") from None
    return city.replace(source=SourceFile(path=str(p.resolve()), ways=frozenset(held_ways(city)))) if context else city


def _check_missing(path: str, missing: set[int]) -> None:
    """Street nodes without a location must be absent from the file (a clipped extract), not present
    without coordinates: libosmium reads a node without ``lat`` or ``lon`` as one it never saw.

    One more read of the nodes, in C++ (an id filter), only when some street has a gap.
    """
    wanted = {i for i in missing if i > 0}  # IdFilter takes unsigned ids; libosmium never locates negative ones
    if not wanted:
        return
    for node in osmium.FileProcessor(path, osmium.osm.NODE).with_filter(osmium.filter.IdFilter(wanted)):
        raise UnreadableInputError(f"node {node.id} has no valid lat/lon (a coordinate missing or unreadable)")


def _is_urbanenvironment(p: Path) -> bool:
    with open(p, "rb") as fh:
        head = fh.read(400)
    return b"<urbanenvironment" in head


#: A multipolygon relation as read: id, timestamp (seconds), tags, and its way members (id, role).
_Relation = tuple[int, int, dict, list[tuple[int, str]]]


def _read(path: str, kept: frozenset[str], context: bool, relations: bool) -> tuple[_Raw, tuple | None]:
    keys = ["highway"] + (["waterway", "natural", "water", "building", *AREA_KEYS] if context else [])
    keys = list(dict.fromkeys(keys))
    fp = osmium.FileProcessor(path).with_locations()
    if relations:
        fp = fp.with_areas(osmium.filter.KeyFilter(*keys))
    # the multipolygon relations come in this pass too (after the ways), for those libosmium leaves out
    kinds = osmium.osm.WAY | osmium.osm.AREA
    kinds = kinds | osmium.osm.RELATION if context else kinds
    fp = fp.with_filter(osmium.filter.EntityFilter(kinds)).with_filter(osmium.filter.KeyFilter(*keys))
    box = fp.header.box()
    header_box = None
    if box.valid():
        header_box = (box.bottom_left.lon, box.bottom_left.lat, box.top_right.lon, box.top_right.lat)
    raw = _Raw()
    assembled: set[int] = set()
    multipolygons: list[_Relation] = []
    for obj in fp:
        if isinstance(obj, osmium.osm.Relation):
            if obj.tags.get("type") == "multipolygon" and _area_kind(obj.tags):
                multipolygons.append((obj.id, _seconds(obj), dict(obj.tags),
                                      [(m.ref, m.role) for m in obj.members if m.type == "w"]))
        elif isinstance(obj, osmium.osm.Way):  # obj.is_way(), in a form type checkers narrow on
            raw.newest = max(raw.newest, _seconds(obj))
            _take_way(obj, kept, raw, evidence=context)
            if context and obj.is_closed():
                _take_closed_way(obj, raw)
            elif context and obj.tags.get("building", "no") != "no" and "highway" not in obj.tags:
                _take_unplaced(obj, raw)  # a building drawn as an open way: a mapping error, kept as mapped
        elif isinstance(obj, osmium.osm.Area) and not obj.from_way():  # closed ways are taken above, as ways
            raw.newest = max(raw.newest, _seconds(obj))
            assembled.add(obj.orig_id())
            _take_relation_area(obj, raw)
    if context:
        _salvage_multipolygons(path, [r for r in multipolygons if r[0] not in assembled], raw)
    return raw, header_box


Ring = tuple[list[int], list[tuple[float, float]]]


def _salvage_multipolygons(path: str, left_out: list[_Relation], raw: _Raw) -> None:
    """Multipolygons libosmium left out (``left_out``, read in :func:`_read`'s pass), rebuilt from the
    member ways the file has.

    A clipped extract often lacks a member of a big multipolygon (an inner
    ring of a river, say); libosmium then builds no area at all, and the
    Danube would be missing from Krems. Here the closed rings that the
    members present still form are kept (one more read of the file, only
    when such a relation exists). The relations come from the main pass: a pass of their own was one
    more read of the whole file (Krems 0.04 s CPU).
    """
    relations = [(rel_id, tags, members) for rel_id, _, tags, members in left_out]
    for _, seconds, _, _ in left_out:
        raw.newest = max(raw.newest, seconds)
    if not relations:
        return
    wanted = {ref for _, _, members in relations for ref, _ in members}
    ways: dict[int, Ring] = {}
    fp = (osmium.FileProcessor(path).with_locations().with_filter(osmium.filter.EntityFilter(osmium.osm.WAY))
          .with_filter(osmium.filter.IdFilter(wanted)))
    for way in fp:
        runs, clipped = _way_runs(way)
        if runs and not clipped:
            ways[way.id] = runs[0]
    for rel_id, tags, members in relations:
        outers = _closed_rings([ways[r] for r, role in members if r in ways and role != "inner"])
        inners = _closed_rings([ways[r] for r, role in members if r in ways and role == "inner"])
        for outer in outers:
            shell = shapely.Polygon(outer[1])
            holes = [i for i in inners if shell.contains(shapely.Point(i[1][0]))]
            _take_rings([outer, *holes], tags, rel_id, raw)


def _closed_rings(parts: list[Ring]) -> list[Ring]:
    """Member ways joined end to end into closed rings (open chains are dropped)."""
    rings, todo = [], list(parts)
    while todo:
        refs, coords = list(todo[0][0]), list(todo[0][1])
        todo.pop(0)
        grew = True
        while refs[0] != refs[-1] and grew:
            grew = False
            for k, (r, c) in enumerate(todo):
                if r[0] == refs[-1]:
                    refs, coords = refs + r[1:], coords + c[1:]
                elif r[-1] == refs[-1]:
                    refs, coords = refs + r[-2::-1], coords + c[-2::-1]
                else:
                    continue
                todo.pop(k)
                grew = True
                break
        if refs[0] == refs[-1] and len(refs) >= 4:
            rings.append((refs, coords))
    return rings


def _take_rings(rings: list[Ring], tags: dict, rel_id: int, raw: _Raw) -> None:
    """One outer ring (and its holes) of a multipolygon relation, by its kind."""
    kind = _area_kind(tags)
    assert kind is not None  # callers pass only relations of a kind that is kept
    if kind[0] == "building":
        raw.buildings.append((rings, tags, "relation", rel_id))
    elif kind[0] == "water":
        raw.water_areas.append([coords for _, coords in rings])
    else:
        raw.areas.append(([coords for _, coords in rings], kind[0], kind[1], rel_id))


def _seconds(obj) -> int:
    ts = obj.timestamp
    return int(ts.timestamp()) if ts is not None and ts.year > 1970 else 0


def _way_runs(way) -> tuple[list[tuple[list[int], list[tuple[float, float]]]], bool]:
    """The way's runs of nodes with known locations; True if any node was missing."""
    runs, refs, coords, clipped = [], [], [], False
    for nd in way.nodes:
        loc = nd.location
        if loc.valid():
            refs.append(nd.ref)
            coords.append((loc.lon, loc.lat))
            continue
        if loc.x != _UNDEFINED or loc.y != _UNDEFINED:
            raise UnreadableInputError(f"node {nd.ref} has coordinates out of range "
                                       f"(lon {loc.x / 1e7:.7f}, lat {loc.y / 1e7:.7f})")
        clipped = True
        if len(refs) >= 2:
            runs.append((refs, coords))
        refs, coords = [], []
    if len(refs) >= 2:
        runs.append((refs, coords))
    return runs, clipped


#: Highway classes read, when the network leaves them out, as evidence of the town's land only
#: (:attr:`City.service_lines`, :func:`osm_expand.land._frontage`). Service ways are driveways, yards
#: and access lanes: the OSM wiki's ``highway=service`` is "access to a building, service station,
#: beach, campsite, industrial estate, business park, etc.", where the town is. Tracks are not here:
#: ``highway=track`` is "for agricultural use, forest tracks etc." and runs through the fields.
EVIDENCE_HIGHWAYS = frozenset({"service"})


def _take_way(way, kept: frozenset[str], raw: _Raw, evidence: bool = False) -> None:
    tags = way.tags
    hw = tags.get("highway")
    if hw is not None:
        if tags.get("area") == "yes":
            return
        if hw not in kept:
            if evidence and hw in EVIDENCE_HIGHWAYS:
                raw.service.extend(coords for _, coords in _way_runs(way)[0])
            return
        raw.input_ways += 1
        runs, clipped = _way_runs(way)
        raw.clipped_ways += clipped
        if clipped:
            raw.missing.update(nd.ref for nd in way.nodes if not nd.location.valid())
        if not runs:  # not one stretch of two known nodes: kept as mapped, drawn nowhere
            _take_unplaced(way, raw)
            return
        attrs = street_attrs(way.id, tags)
        raw.streets.extend((refs, coords, attrs) for refs, coords in runs)
        return
    ww = tags.get("waterway")
    if ww in WATERWAY_WIDTH:
        width = _number(tags.get("width")) or WATERWAY_WIDTH[ww]
        raw.waterways.extend((coords, width) for _, coords in _way_runs(way)[0])
    elif tags.get("natural") == "coastline":
        raw.coastline.extend(coords for _, coords in _way_runs(way)[0])


def _take_unplaced(way, raw: _Raw) -> None:
    """A way of the town whose nodes the extract mostly lacks: written back as mapped, not drawn."""
    located = [(nd.ref, (nd.location.lon, nd.location.lat)) for nd in way.nodes if nd.location.valid()]
    raw.unplaced.append((way.id, [nd.ref for nd in way.nodes], located, dict(way.tags)))


def _area_kind(tags) -> tuple[str, str] | None:
    """("building", ""), ("water", ""), (key, value) of a kept mapped area, or None."""
    if tags.get("building", "no") != "no":
        return ("building", "")
    if "water" in tags or any(tags.get(k) in v for k, v in WATER_AREA_TAGS.items()):
        return ("water", "")
    for key, values in AREA_KEYS.items():
        value = tags.get(key)
        if value is not None and (values is None or value in values):
            return (key, value)
    return None


def _take_closed_way(way, raw: _Raw) -> None:
    """A closed way is its own outer ring: buildings, water areas and mapped areas."""
    tags = way.tags
    kind = _area_kind(tags)
    if kind is None or "highway" in tags:
        return
    runs, clipped = _way_runs(way)
    if clipped or not runs:
        if kind[0] == "building":
            raw.clipped_buildings += 1
            _take_unplaced(way, raw)
        return
    refs, ring = runs[0]
    if kind[0] == "building":
        raw.buildings.append(([(refs, ring)], dict(tags), "way", way.id))
    elif kind[0] == "water":
        raw.water_areas.append([ring])
    else:
        raw.areas.append(([ring], kind[0], kind[1], way.id))


def _take_relation_area(area, raw: _Raw) -> None:
    if _area_kind(area.tags) is None:
        return
    tags = dict(area.tags)
    for outer in area.outer_rings():
        rings = [outer] + list(area.inner_rings(outer))
        _take_rings([([n.ref for n in r], [(n.lon, n.lat) for n in r]) for r in rings], tags, area.orig_id(), raw)


#: A header box is the map's bounds only when a local projection can cover it: less than this many degrees
#: of longitude and short of the poles (``--bbox -180,-90,180,90`` writes the whole globe into the extract's
#: header; projected, its corners are infinite). Wider boxes give way to the data's own bounds.
MAX_HEADER_SPAN_DEG = 90.0
MAX_HEADER_LAT_DEG = 85.0


def _check_coordinates(ids: np.ndarray, lonlat: np.ndarray) -> None:
    """Refuse street nodes whose coordinates cannot be the town's.

    - Longitudes spanning more than 180°: the town crosses the antimeridian,
      which a local projection centred on its bounds cannot represent.
    - A latitude or longitude of exactly 0 in a town far from the equator or
      the prime meridian: libosmium reads a three-digit exponent
      (``lat="1e400"``) as 0, which would put a node thousands of km away.
    """
    if not len(lonlat):
        return
    lo, hi = lonlat.min(axis=0), lonlat.max(axis=0)
    if hi[0] - lo[0] > 180:
        raise UnreadableInputError("the streets cross the antimeridian (longitude ±180, not supported); "
                                   "clip the town on one side of it")
    typical = np.median(np.abs(lonlat), axis=0)
    for axis, name in ((1, "lat"), (0, "lon")):
        zero = np.flatnonzero(lonlat[:, axis] == 0.0)
        if len(zero) and typical[axis] > 1.0:
            raise UnreadableInputError(f"node {int(ids[zero[0]])} has {name} 0, far from the rest of the town "
                                       f"({name} {np.median(lonlat[:, axis]):.4f}); a coordinate that is not a number "
                                       "in range (such as 1e400) is read as 0")


def _usable_header(header_box: tuple | None) -> tuple | None:
    if header_box is None:
        return None
    lon0, lat0, lon1, lat1 = header_box
    if lon1 - lon0 >= MAX_HEADER_SPAN_DEG or max(abs(lat0), abs(lat1)) >= MAX_HEADER_LAT_DEG:
        return None
    return header_box


def _build(raw: _Raw, header_box: tuple | None) -> City:
    ids, lonlat, streets_idx = _index_nodes(raw.streets)
    _check_coordinates(ids, lonlat)
    header_box = _usable_header(header_box)
    bounds = header_box or _data_bounds(lonlat)
    proj = LocalProjection.centred_on(bounds)
    xy = _project(lonlat, proj)
    streets = tuple(Street(nodes=nodes, id=k, **attrs)
                    for k, (nodes, (_, _, attrs)) in enumerate(zip(streets_idx, raw.streets)))
    lon0, lat0, lon1, lat1 = (float(v) for v in bounds)
    context = Context(projection=proj, bounds_lonlat=(lon0, lat0, lon1, lat1),
                      bounds_from_header=header_box is not None)
    stats = {"input_ways": raw.input_ways, "input_nodes": int(len(ids)), "clipped_ways": raw.clipped_ways,
             "streets": len(streets), "buildings": len(raw.buildings), "clipped_buildings": raw.clipped_buildings,
             "unplaced_ways": len(raw.unplaced)}
    network = StreetNetwork(xy=xy, node_ids=ids, streets=streets, context=context, stats=stats)
    year = _year(raw.newest)
    return City(
        network=network,
        buildings=_buildings(raw.buildings, proj),
        water=_water_polygons(raw, proj),
        sea=assemble_sea(_project_lines(raw.coastline, proj), _bounds_box(bounds, proj)),
        areas=_areas(raw.areas, proj),
        service_lines=tuple(shapely.linestrings(c) for c in _project_lines(raw.service, proj)),
        unplaced=tuple(UnplacedWay(osm_id=i, refs=tuple(refs), located=tuple(r for r, _ in known),
                                   xy=_project([ll for _, ll in known], proj), tags=tuple(tags.items()))
                       for i, refs, known, tags in raw.unplaced),
        year=year,
        stats=stats,
    )


def _year(seconds: int) -> int | None:
    if not seconds:
        return None
    import datetime

    return datetime.datetime.fromtimestamp(seconds, datetime.UTC).year


def _index_nodes(streets) -> tuple[np.ndarray, np.ndarray, list[tuple[int, ...]]]:
    index: dict[int, int] = {}
    lonlat: list[tuple[float, float]] = []
    out = []
    for refs, coords, _ in streets:
        seq = []
        for ref, ll in zip(refs, coords):
            i = index.get(ref)
            if i is None:
                i = index[ref] = len(lonlat)
                lonlat.append(ll)
            seq.append(i)
        out.append(tuple(seq))
    ids = np.fromiter(index.keys(), dtype=np.int64, count=len(index))
    return ids, np.asarray(lonlat, dtype=float).reshape(-1, 2), out


def _data_bounds(lonlat: np.ndarray) -> tuple[float, float, float, float]:
    lo, hi = lonlat.min(axis=0), lonlat.max(axis=0)
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def _bounds_box(bounds, proj: LocalProjection):
    lon0, lat0, lon1, lat1 = bounds
    return shapely.Polygon(_project(np.array([[lon0, lat0], [lon1, lat0], [lon1, lat1], [lon0, lat1]]), proj))


def _project(coords, proj: LocalProjection) -> np.ndarray:
    a = np.asarray(coords, dtype=float).reshape(-1, 2)
    x, y = proj.to_xy(a[:, 0], a[:, 1])
    return np.column_stack([x, y])


def _project_each(seqs: Sequence, proj: LocalProjection) -> list[np.ndarray]:
    """:func:`_project` of each coordinate sequence in ``seqs``, in one call of the projection: the same
    numbers (PROJ projects point by point), without its per-call cost (~50 µs: Krems' 1,500 rings and
    lines took 0.07 s one by one). Each result is a row slice of one array."""
    arrays = [np.asarray(c, dtype=float).reshape(-1, 2) for c in seqs]
    if not arrays:
        return []
    xy = _project(np.concatenate(arrays), proj)
    return np.split(xy, np.cumsum([len(a) for a in arrays[:-1]], dtype=np.int64))


def _project_lines(lines, proj: LocalProjection) -> list[np.ndarray]:
    return _project_each([c for c in lines if len(c) >= 2], proj)


def _polygons(ring_lists, proj: LocalProjection) -> list[shapely.Geometry | None]:
    """A polygon per list of rings (shell first), None where the shell has fewer than four points."""
    xy = iter(_project_each([r for rings in ring_lists for r in rings], proj))
    return [_polygon([next(xy) for _ in rings]) for rings in ring_lists]


def _polygon(rings: list[np.ndarray]) -> shapely.Geometry | None:
    shell, *holes = rings
    if len(shell) < 4:
        return None
    poly = shapely.Polygon(shell, [h for h in holes if len(h) >= 4])
    return poly if poly.is_valid else shapely.make_valid(poly)


def _water_polygons(raw: _Raw, proj: LocalProjection) -> tuple:
    polys = [p for p in _polygons(raw.water_areas, proj) if p is not None and not p.is_empty]
    lines = _project_each([coords for coords, _ in raw.waterways], proj)
    polys += [shapely.buffer(shapely.LineString(xy), width / 2, cap_style="flat")
              for xy, (_, width) in zip(lines, raw.waterways)]
    return tuple(polys)


def _areas(items, proj: LocalProjection) -> tuple[MappedArea, ...]:
    out = []
    for (_, key, value, osm_id), poly in zip(items, _polygons([rings for rings, *_ in items], proj)):
        if poly is not None and not poly.is_empty and poly.area > 0:
            out.append(MappedArea(polygon=poly, key=key, value=value, osm_id=osm_id))
    return tuple(out)


def _buildings(items, proj: LocalProjection) -> tuple[Building, ...]:
    kept = [item for item in items if len(item[0][0][1]) >= 4]
    xy = iter(_project_each([coords for rings, *_ in kept for _, coords in rings], proj))
    out = []
    for rings, tags, osm_type, osm_id in kept:
        out.append(Building(
            rings=tuple(next(xy) for _ in rings),
            node_ids=tuple(np.asarray(refs, dtype=np.int64) for refs, _ in rings),
            height=_number(tags.get("height")), levels=_number(tags.get("building:levels")),
            osm_id=osm_id, osm_type=osm_type, tags=tuple(tags.items())))
    return tuple(out)
