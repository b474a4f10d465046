"""Read an OSM extract into a :class:`StreetNetwork` (the only stage that reads OSM).

pyosmium streams the file with a node-location index, and its C++ filters
drop everything that is not a street, water or building before Python sees
it, so memory and time scale with the streets, not the file. Ways that
reference nodes missing from a clipped extract are split at the gap.
"""
from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import osmium
import shapely

from osm_expand.coastline import assemble_sea
from osm_expand.errors import InputError
from osm_expand.highways import highway_set
from osm_expand.model import Building, Context, Street, StreetNetwork, network_from_lines
from osm_expand.projection import LocalProjection

SUFFIXES = (".osm", ".osm.gz", ".osm.bz2", ".osm.pbf", ".pbf", ".xml", ".xml.gz", ".xml.bz2", ".geojson")

#: Default river widths (m) by ``waterway=*`` when no ``width`` tag says otherwise.
WATERWAY_WIDTH = {"river": 20.0, "canal": 12.0, "stream": 3.0, "drain": 2.0, "ditch": 1.5}
WATER_AREA_TAGS = {"natural": {"water"}, "waterway": {"riverbank", "dock"}, "landuse": {"reservoir", "basin"}}
_UNDEFINED = 2147483647  # libosmium's undefined coordinate


@dataclass
class _Raw:
    """What the OSM pass collects, in lon/lat, before projection."""

    streets: list[tuple[list[int], list[tuple[float, float]], dict]] = field(default_factory=list)
    clipped_ways: int = 0
    waterways: list[tuple[list[tuple[float, float]], float]] = field(default_factory=list)
    water_areas: list[list[list[tuple[float, float]]]] = field(default_factory=list)
    coastline: list[list[tuple[float, float]]] = field(default_factory=list)
    buildings: list[tuple[list[tuple[float, float]], float | None, float | None, int]] = field(default_factory=list)
    input_ways: int = 0


def check_readable(path: str | os.PathLike) -> Path:
    """Fail early, in one line, on paths osmium would choke on or misread."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: no such file")
    if p.is_dir():
        raise InputError(f"{p}: is a directory, not an OSM file")
    if not os.access(p, os.R_OK):
        raise InputError(f"{p}: permission denied")
    if p.stat().st_size == 0:
        raise InputError(f"{p}: file is empty")
    if not p.name.lower().endswith(SUFFIXES):
        raise InputError(f"{p}: unsupported file type (expected {', '.join(SUFFIXES[:4])})")
    return p


def load(path: str | os.PathLike, *, service: bool = False, paths: bool = False,
         context: bool = True) -> StreetNetwork:
    """Read streets, water and buildings from ``path`` and project them to metres.

    ``service`` and ``paths`` add those highway classes to the default
    drivable set (see :mod:`osm_expand.highways`). ``context=False`` reads
    streets only, in a single pass (what ``osm-expand simplify`` needs).
    """
    p = check_readable(path)
    if p.name.lower().endswith(".geojson"):
        return load_geojson(p)
    kept = highway_set(service=service, paths=paths)
    try:
        try:
            raw, header_box = _read(str(p), kept, context, areas=context)
        except RuntimeError as exc:
            if "out of order" not in str(exc):
                raise
            # libosmium's multipolygon assembly needs sorted input; unsorted
            # files still give closed-way buildings and water.
            raw, header_box = _read(str(p), kept, context, areas=False)
    except InputError as exc:
        raise InputError(f"{p}: {exc}") from None
    except (RuntimeError, ValueError, OSError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{p}: not a readable OSM file ({msg})") from None
    if not raw.streets:
        raise InputError(f"{p}: no streets of the selected highway classes"
                         + ("" if service else " (try --service)"))
    return _build(raw, header_box)


def _read(path: str, kept: frozenset[str], context: bool,
          areas: bool) -> tuple[_Raw, tuple | None]:
    keys = ["highway"] + (["waterway", "natural", "water", "landuse", "building"] if context else [])
    fp = osmium.FileProcessor(path).with_locations()
    if areas:
        fp = fp.with_areas(osmium.filter.KeyFilter(*keys))
    fp = (fp.with_filter(osmium.filter.EntityFilter(osmium.osm.WAY | osmium.osm.AREA))
          .with_filter(osmium.filter.KeyFilter(*keys)))
    box = fp.header.box()
    header_box = None
    if box.valid():
        header_box = (box.bottom_left.lon, box.bottom_left.lat, box.top_right.lon, box.top_right.lat)
    raw = _Raw()
    for obj in fp:
        if obj.is_way():
            _take_way(obj, kept, raw)
            if context and not areas and obj.is_closed():
                _take_closed_way(obj, raw)
        elif obj.is_area():
            _take_area(obj, raw)
    return raw, header_box


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
            raise InputError(f"node {nd.ref} has coordinates out of range "
                             f"(lon {loc.x / 1e7:.7f}, lat {loc.y / 1e7:.7f})")
        clipped = True
        if len(refs) >= 2:
            runs.append((refs, coords))
        refs, coords = [], []
    if len(refs) >= 2:
        runs.append((refs, coords))
    return runs, clipped


def _take_way(way, kept: frozenset[str], raw: _Raw) -> None:
    tags = way.tags
    hw = tags.get("highway")
    if hw is not None:
        if hw not in kept or tags.get("area") == "yes":
            return
        raw.input_ways += 1
        runs, clipped = _way_runs(way)
        raw.clipped_ways += clipped
        attrs = _street_attrs(way.id, tags)
        raw.streets.extend((refs, coords, attrs) for refs, coords in runs)
        return
    ww = tags.get("waterway")
    if ww in WATERWAY_WIDTH:
        width = _number(tags.get("width")) or WATERWAY_WIDTH[ww]
        raw.waterways.extend((coords, width) for _, coords in _way_runs(way)[0])
    elif tags.get("natural") == "coastline":
        raw.coastline.extend(coords for _, coords in _way_runs(way)[0])


def _area_kind(tags) -> str | None:
    """"building", "water" or None for an area's tags."""
    if tags.get("building", "no") != "no":
        return "building"
    if "water" in tags or any(tags.get(k) in v for k, v in WATER_AREA_TAGS.items()):
        return "water"
    return None


def _take_area(area, raw: _Raw) -> None:
    tags = area.tags
    kind = _area_kind(tags)
    if kind == "building":
        for outer in area.outer_rings():
            ring = [(n.lon, n.lat) for n in outer]
            raw.buildings.append((ring, _number(tags.get("height")), _number(tags.get("building:levels")),
                                  area.orig_id()))
            break
        return
    if kind == "water":
        for outer in area.outer_rings():
            rings = [[(n.lon, n.lat) for n in outer]]
            rings += [[(n.lon, n.lat) for n in inner] for inner in area.inner_rings(outer)]
            raw.water_areas.append(rings)


def _take_closed_way(way, raw: _Raw) -> None:
    """Area fallback for unsorted files: a closed way is its own outer ring."""
    runs, clipped = _way_runs(way)
    if clipped or not runs:
        return
    ring = runs[0][1]
    tags = way.tags
    kind = _area_kind(tags)
    if kind == "building":
        raw.buildings.append((ring, _number(tags.get("height")), _number(tags.get("building:levels")), way.id))
    elif kind == "water":
        raw.water_areas.append([ring])


def _street_attrs(way_id: int, tags) -> dict:
    layer = _number(tags.get("layer"))
    return {
        "highway": tags.get("highway"),
        "name": tags.get("name"),
        "layer": int(layer) if layer is not None and abs(layer) < 10 else 0,
        "bridge": tags.get("bridge", "no") not in ("no", "false", "0"),
        "tunnel": tags.get("tunnel", "no") not in ("no", "false", "0"),
        "junction": tags.get("junction"),
        "lanes": _number(tags.get("lanes")),
        "width": _number(tags.get("width")),
        "osm_ids": (way_id,),
    }


_NUMBER = re.compile(r"^\s*(-?\d+(?:[.,]\d+)?)\s*(m|meters?|metres?|ft|')?\s*$", re.IGNORECASE)


def _number(text: str | None) -> float | None:
    """Parse OSM numeric tags such as ``12``, ``12.5 m`` or ``40'``; None if unusable."""
    if not text:
        return None
    m = _NUMBER.match(text.split(";")[0])
    if not m:
        return None
    value = float(m.group(1).replace(",", "."))
    if m.group(2) and m.group(2).lower() in ("ft", "'"):
        value *= 0.3048
    return value if math.isfinite(value) else None


def _build(raw: _Raw, header_box: tuple | None) -> StreetNetwork:
    ids, lonlat, streets_idx = _index_nodes(raw.streets)
    bounds = header_box or _data_bounds(lonlat)
    proj = LocalProjection.centred_on(bounds)
    x, y = proj.to_xy(lonlat[:, 0], lonlat[:, 1])
    xy = np.column_stack([x, y])
    streets = tuple(Street(nodes=nodes, **attrs) for nodes, (_, _, attrs) in zip(streets_idx, raw.streets))
    context = Context(
        projection=proj,
        bounds_lonlat=tuple(float(v) for v in bounds),
        bounds_from_header=header_box is not None,
        water=_water_polygons(raw, proj),
        sea=assemble_sea(_project_lines(raw.coastline, proj), _bounds_box(bounds, proj)),
        buildings=_buildings(raw.buildings, proj),
    )
    stats = {"input_ways": raw.input_ways, "input_nodes": int(len(ids)),
             "clipped_ways": raw.clipped_ways, "streets": len(streets)}
    return StreetNetwork(xy=xy, node_ids=ids, streets=streets, context=context, stats=stats)


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
    lons = np.array([lon0, lon1, lon1, lon0])
    lats = np.array([lat0, lat0, lat1, lat1])
    x, y = proj.to_xy(lons, lats)
    return shapely.Polygon(np.column_stack([x, y]))


def _project(coords, proj: LocalProjection) -> np.ndarray:
    a = np.asarray(coords, dtype=float).reshape(-1, 2)
    x, y = proj.to_xy(a[:, 0], a[:, 1])
    return np.column_stack([x, y])


def _project_lines(lines, proj: LocalProjection) -> list[np.ndarray]:
    return [_project(c, proj) for c in lines if len(c) >= 2]


def _water_polygons(raw: _Raw, proj: LocalProjection) -> tuple:
    polys = []
    for rings in raw.water_areas:
        shell, *holes = [_project(r, proj) for r in rings]
        if len(shell) >= 4:
            poly = shapely.Polygon(shell, [h for h in holes if len(h) >= 4])
            polys.append(poly if poly.is_valid else shapely.make_valid(poly))
    for coords, width in raw.waterways:
        polys.append(shapely.buffer(shapely.LineString(_project(coords, proj)), width / 2, cap_style="flat"))
    return tuple(polys)


def _buildings(items, proj: LocalProjection) -> tuple[Building, ...]:
    out = []
    for ring, height, levels, osm_id in items:
        if len(ring) >= 4:
            out.append(Building(ring=_project(ring, proj), height=height, levels=levels, osm_id=osm_id))
    return tuple(out)


def load_geojson(path: Path) -> StreetNetwork:
    """Read back a street network written by ``osm-expand`` as GeoJSON (LineString features)."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        features = [f for f in doc["features"] if (f.get("geometry") or {}).get("type") == "LineString"]
        lines = [np.asarray(f["geometry"]["coordinates"], dtype=float)[:, :2] for f in features]
    except (ValueError, KeyError, TypeError, IndexError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a readable GeoJSON street network ({type(exc).__name__}: {exc})") from None
    if not lines:
        raise InputError(f"{path}: no LineString streets in the GeoJSON")
    allpts = np.concatenate(lines)
    if not np.isfinite(allpts).all() or np.abs(allpts[:, 0]).max() > 180 or np.abs(allpts[:, 1]).max() > 90:
        raise InputError(f"{path}: coordinates out of range (GeoJSON must be lon/lat)")
    bounds = _data_bounds(allpts)
    proj = LocalProjection.centred_on(bounds)
    projected = [np.column_stack(proj.to_xy(ln[:, 0], ln[:, 1])) for ln in lines]
    attrs = [_geojson_attrs(f.get("properties") or {}) for f in features]
    net = network_from_lines([[tuple(p) for p in ln] for ln in projected], attrs, projection=proj)
    return net.replace(stats={"input_ways": len(lines), "input_nodes": len(net.xy), "clipped_ways": 0,
                              "streets": len(lines)})


def _geojson_attrs(props: dict) -> dict:
    """A feature's properties read as OSM tags (booleans as "true"/"false"), by the same rules."""
    tags = {k: str(v).lower() if isinstance(v, bool) else str(v)
            for k, v in props.items() if v is not None and not isinstance(v, (list, dict))}
    tags.setdefault("highway", "road")
    ids = props.get("osm_ids") or ()
    return {**_street_attrs(0, tags), "osm_ids": tuple(int(i) for i in ids if isinstance(i, int))}
