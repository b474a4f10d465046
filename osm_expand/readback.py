"""Read osm-expand's own outputs back: GeoJSON (lon/lat) and ``<urbanenvironment>`` (metres).

So that ``stats`` and ``compare`` take any file the tool writes. Streets
keep their attributes (class, name, layer, origin, year, ...); buildings come
back as footprints with their height and origin.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from lxml import etree

from osm_expand.errors import InputError, UnreadableInputError
from osm_expand.model import Building, City, LocalProjection, Origin, Status, network_from_lines
from osm_expand.osmtags import number as _number
from osm_expand.osmtags import street_attrs

#: Street attributes of the formats that are not OSM tags.
_MODEL_KEYS = ("origin", "year", "era", "status", "hierarchy", "osm_ids", "osm_id", "id")


def load_output(path: Path) -> City:
    """A :class:`City` from a GeoJSON or ``<urbanenvironment>`` file written by osm-expand."""
    if path.name.lower().endswith((".geojson", ".json")):
        return _from_geojson(path)
    return _from_urbanenvironment(path)


def _model_fields(props: dict) -> dict:
    """Origin, status, year, era and hierarchy of a feature or element, checked."""
    out: dict = {}
    try:
        if props.get("origin") is not None:
            out["origin"] = Origin(str(props["origin"]))
        if props.get("status") is not None:
            out["status"] = Status(str(props["status"]))
        if props.get("year") not in (None, ""):
            out["year"] = int(props["year"])
        if props.get("hierarchy") not in (None, ""):
            out["hierarchy"] = int(props["hierarchy"])
    except (ValueError, TypeError) as exc:
        raise UnreadableInputError(f"bad attribute ({exc})") from None
    if props.get("era"):
        out["era"] = str(props["era"])
    return out


def _street_fields(props: dict) -> dict:
    """A feature's properties read as OSM tags (booleans as "true"/"false"), by the ingest rules."""
    tags = {k: str(v).lower() if isinstance(v, bool) else str(v)
            for k, v in props.items() if v is not None and not isinstance(v, (list, dict)) and k not in _MODEL_KEYS}
    tags.setdefault("highway", "road")
    ids = props.get("osm_ids") or ([props["osm_id"]] if props.get("osm_id") else [])
    fields = {**street_attrs(0, tags), **_model_fields(props)}
    fields["osm_ids"] = tuple(int(i) for i in ids if isinstance(i, int) or str(i).lstrip("-").isdigit())
    if fields.get("origin", Origin.SOURCE) != Origin.SOURCE:
        fields["tags"] = ()
    return fields


def _city(lines: list[np.ndarray], attrs: list[dict], buildings: list[Building], proj: LocalProjection) -> City:
    net = network_from_lines(lines, attrs, projection=proj)
    stats = {"input_ways": len(lines), "input_nodes": len(net.xy), "clipped_ways": 0, "streets": len(lines)}
    return City(network=net.replace(stats=stats), buildings=tuple(buildings), stats=stats)


#: What a malformed file raises while it is read: each is the file's fault, reported in one line.
_BAD = (ValueError, KeyError, TypeError, IndexError, AttributeError, RecursionError, OverflowError)

#: Metres from the local projection's centre beyond which a coordinate is not on the Earth (half the equator,
#: 2.0e7 m): a file holding one is malformed, not a town (a fuzzed ``x1="1e39"`` reached GEOS and failed there).
EARTH_REACH = 2.0e7


def _on_earth(a: np.ndarray) -> bool:
    """Whether every coordinate of ``a`` is finite and within :data:`EARTH_REACH` of the projection's centre."""
    return bool(np.isfinite(a).all() and (np.abs(a) <= EARTH_REACH).all())


def _points(value, what: str, least: int) -> np.ndarray:
    """An ``(n, 2)`` array of finite coordinates with ``n >= least``, or InputError naming ``what``."""
    a = np.asarray(value, dtype=float)
    if a.ndim != 2 or a.shape[1] < 2 or len(a) < least:
        raise UnreadableInputError(f"{what}: expected at least {least} points of two coordinates")
    a = a[:, :2]
    if not _on_earth(a):
        raise UnreadableInputError(f"{what}: a coordinate is not a finite number of metres on the Earth")
    return a


def _osm_id(value) -> int:
    """An ``osm_id`` property: a whole number (0 when absent)."""
    if value in (None, ""):
        return 0
    if isinstance(value, bool) or not (isinstance(value, int) or str(value).lstrip("-").isdigit()):
        raise UnreadableInputError(f"bad osm_id {value!r} (a whole number expected)")
    return int(value)


def _projection(lon0: float, lat0: float) -> LocalProjection:
    if not (math.isfinite(lon0) and math.isfinite(lat0) and -180 <= lon0 <= 180 and -90 < lat0 < 90):
        raise UnreadableInputError(f"bad projection centre lon0={lon0:g}, lat0={lat0:g} (degrees expected)")
    return LocalProjection(lon0, lat0)


def _from_geojson(path: Path) -> City:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        features = [f for f in doc["features"] if f.get("geometry")]
        streets = [f for f in features if f["geometry"]["type"] == "LineString"]
        lines = [_points(f["geometry"]["coordinates"], f"street {k}", 2) for k, f in enumerate(streets)]
        props = [f.get("properties") or {} for f in streets]
        polygons = [(f["geometry"], f.get("properties") or {}) for f in features
                    if f["geometry"]["type"] in ("Polygon", "MultiPolygon")]
    except InputError as exc:
        raise UnreadableInputError(f"{path}: {exc}") from None
    except (*_BAD, UnicodeDecodeError, OSError) as exc:
        raise UnreadableInputError(f"{path}: not a readable GeoJSON street network "
                                   f"({type(exc).__name__}: {exc})") from None
    if not lines:
        raise UnreadableInputError(f"{path}: no LineString streets in the GeoJSON")
    allpts = np.concatenate(lines)
    if np.abs(allpts[:, 0]).max() > 180 or np.abs(allpts[:, 1]).max() > 90:
        raise UnreadableInputError(f"{path}: coordinates out of range (GeoJSON must be lon/lat)")
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    if hi[0] - lo[0] > 180:
        raise UnreadableInputError(f"{path}: the streets cross the antimeridian (longitude ±180, not supported)")
    proj = LocalProjection.centred_on((float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])))
    to_xy = lambda a: np.column_stack(proj.to_xy(a[:, 0], a[:, 1]))  # noqa: E731
    try:
        attrs = [_street_fields(p) for p in props]
        buildings = []
        for k, (geom, p) in enumerate(polygons):
            polys = geom["coordinates"] if geom["type"] == "MultiPolygon" else [geom["coordinates"]]
            fields = _model_fields({"origin": p.get("origin", "source"), "year": p.get("year")})
            for rings in polys:
                buildings.append(Building(rings=tuple(to_xy(_points(r, f"building {k}", 4)) for r in rings),
                                          height=_number(str(p.get("height", ""))), osm_id=_osm_id(p.get("osm_id")),
                                          origin=fields.get("origin", Origin.SOURCE)))
    except InputError as exc:
        raise UnreadableInputError(f"{path}: {exc}") from None
    except _BAD as exc:
        raise UnreadableInputError(f"{path}: not a readable GeoJSON street network "
                                   f"({type(exc).__name__}: {exc})") from None
    return _city([to_xy(ln) for ln in lines], attrs, buildings, proj)


def _from_urbanenvironment(path: Path) -> City:
    try:
        parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True)
        root = etree.parse(str(path), parser).getroot()
        proj = _projection(float(root.get("lon0", 0.0)), float(root.get("lat0", 0.0)))
        lines, attrs = [], []
        for k, st in enumerate(root.iterfind("streets/street")):
            segs = np.array([[float(sg.get(c)) for c in ("x1", "y1", "x2", "y2")] for sg in st.iterfind("segment")])
            if len(segs) and not _on_earth(segs):
                raise UnreadableInputError(f"street {k}: a coordinate is not a finite number of metres on the Earth")
            props = dict(st.attrib)
            if props.get("osm_id"):
                props["osm_ids"] = [_osm_id(props["osm_id"])]
            fields = _street_fields(props)
            for run in _chains(segs):
                lines.append(run)
                attrs.append(fields)
        buildings = []
        for k, b in enumerate(root.iterfind("buildings/building")):
            ring = _points([[float(n.get("x")), float(n.get("y"))] for n in b.iterfind("node")], f"building {k}", 3)
            fields = _model_fields({"origin": b.get("origin", "source"), "year": b.get("year")})
            height = float(b.get("height"))
            if not math.isfinite(height):
                raise UnreadableInputError(f"building {k}: height {b.get('height')!r} is not a finite number")
            buildings.append(Building(rings=(np.vstack([ring, ring[:1]]),), height=height,
                                      osm_id=_osm_id(b.get("osm_id")), origin=fields.get("origin", Origin.SOURCE),
                                      year=fields.get("year")))
    except InputError as exc:
        raise UnreadableInputError(f"{path}: {exc}") from None
    except (etree.XMLSyntaxError, OSError, *_BAD) as exc:
        raise UnreadableInputError(f"{path}: not a readable urbanenvironment file ({exc})") from None
    if not lines:
        raise UnreadableInputError(f"{path}: no streets in the urbanenvironment file")
    return _city(lines, attrs, buildings, proj)


def _chains(segs: np.ndarray) -> list[np.ndarray]:
    """Consecutive segments that meet end to start, as polylines."""
    if not len(segs):
        return []
    breaks = np.flatnonzero(np.any(segs[1:, :2] != segs[:-1, 2:], axis=1)) + 1
    out = []
    for part in np.split(segs, breaks):
        out.append(np.vstack([part[:, :2], part[-1:, 2:]]))
    return out
