"""GeoJSON output (RFC 7946): lon/lat WGS 84; streets as LineStrings, buildings as Polygons.

Every feature has an ``origin`` property (``source``, ``grown``, ``join``,
``engine``), so ``"origin" != 'source'`` selects everything new in QGIS. The
town's streets and buildings carry their OSM tags as mapped and their
``osm_id(s)``; new ones their typed attributes and ``year`` (generated
buildings also ``landuse``, ``floors`` and ``lot``). Lots and blocks are
Polygons with ``"feature": "lot"`` / ``"block"`` and their land use and year.

``debug`` features (``--debug-layers``: a growth pattern's attraction
points, flow field, region and parameters, in local metres) are appended
after the city's, reprojected to lon/lat, with ``"feature": "debug"``.
"""
from __future__ import annotations

import json
import os

import numpy as np

from osm_expand.export.atomic import atomic_write
from osm_expand.export.features import LANDUSE_KEY, ORIGIN_KEY, YEAR_KEY, building_tags, osm_street_tags, to_lonlat
from osm_expand.model import City, Origin


def _model_props(tags: dict[str, str]) -> dict:
    """OSM-style tags with the tool's keys as plain properties: ``origin``, ``year``, ``era``, ``landuse``, ``lot``."""
    props: dict[str, str | int] = {k: v for k, v in tags.items() if not k.startswith("osm_expand:")}
    props["origin"] = tags[ORIGIN_KEY]
    if YEAR_KEY in tags:
        props["year"] = int(tags[YEAR_KEY])
    if "osm_expand:era" in tags:
        props["era"] = tags["osm_expand:era"]
    if LANDUSE_KEY in tags:
        props["landuse"] = tags[LANDUSE_KEY]
    if "osm_expand:lot" in tags:
        props["lot"] = int(tags["osm_expand:lot"])
    return props


def geojson_document(city: City) -> dict:
    net = city.network
    used = net.used_nodes()
    lonlat = np.zeros((len(net.xy), 2))
    lonlat[used] = to_lonlat(city, net.xy[used])
    features = []
    for street in net.streets:
        props = _model_props(osm_street_tags(street))
        props.setdefault("layer", str(street.layer))
        if street.hierarchy >= 0:
            props["hierarchy"] = street.hierarchy
        if street.origin != Origin.SOURCE:
            props["status"] = str(street.status)
        props["osm_ids"] = list(street.osm_ids)
        features.append({"type": "Feature", "id": f"street/{street.id}",
                         "geometry": {"type": "LineString", "coordinates": lonlat[list(street.nodes)].tolist()},
                         "properties": props})
    for k, b in enumerate(city.buildings):
        props = _model_props(building_tags(b))
        if b.height:
            props["height"] = round(float(b.height), 2)
        if b.osm_id > 0:
            props["osm_id"] = b.osm_id
            props["osm_type"] = b.osm_type
        rings = [_ring_lonlat(city, r, outer=(i == 0)) for i, r in enumerate(b.rings)]
        if b.levels and b.origin != Origin.SOURCE:
            props["floors"] = float(b.levels)
        features.append({"type": "Feature", "id": f"building/{k}",
                         "geometry": {"type": "Polygon", "coordinates": rings}, "properties": props})
    for lot in city.lots:
        props = {"feature": "lot", "origin": str(Origin.ENGINE), "landuse": lot.land_use, "block": lot.block,
                 "street": lot.street, "people": round(float(lot.people), 1)}
        if lot.year is not None:
            props["year"] = lot.year
        features.append({"type": "Feature", "id": f"lot/{lot.id}", "properties": props,
                         "geometry": {"type": "Polygon", "coordinates": _polygon_lonlat(city, lot.polygon)}})
    for block in city.blocks:
        if block.polygon.geom_type != "Polygon" or block.polygon.is_empty:
            continue
        props = {"feature": "block", "origin": str(block.origin)}
        if block.year is not None:
            props["year"] = block.year
        if block.land_use:
            props["landuse"] = block.land_use
        features.append({"type": "Feature", "id": f"block/{block.id}", "properties": props,
                         "geometry": {"type": "Polygon", "coordinates": _polygon_lonlat(city, block.polygon)}})
    return {"type": "FeatureCollection", "features": features}


def _polygon_lonlat(city: City, polygon) -> list:
    """A shapely polygon's rings in lon/lat, oriented as RFC 7946 wants."""
    rings = [polygon.exterior, *polygon.interiors]
    return [_ring_lonlat(city, np.asarray(r.coords), outer=(i == 0)) for i, r in enumerate(rings)]


def _ring_lonlat(city: City, ring: np.ndarray, outer: bool) -> list:
    """A closed ring in lon/lat, counter-clockwise when outer and clockwise when a hole (RFC 7946 §3.1.6)."""
    ll = to_lonlat(city, ring)
    x, y = ll[:, 0], ll[:, 1]
    ccw = float(np.dot(x[:-1], y[1:]) - np.dot(x[1:], y[:-1])) > 0
    return (ll if ccw == outer else ll[::-1]).tolist()


def write_geojson(city: City, path: str | os.PathLike, *, debug: list[dict] | None = None) -> None:
    doc = geojson_document(city)
    if debug:
        doc["features"] += debug_features_lonlat(city, debug)
    with atomic_write(path, "w") as fh:
        json.dump(doc, fh, ensure_ascii=False, separators=(",", ":"))
        fh.write("\n")


def debug_features_lonlat(city: City, features: list[dict]) -> list[dict]:
    """A pattern's debug features (local metres) as RFC 7946 features in lon/lat."""
    import shapely
    import shapely.geometry

    out = []
    for k, feat in enumerate(features):
        geom = feat.get("geometry")
        if geom is not None:
            shape = shapely.transform(shapely.geometry.shape(geom), lambda xy: to_lonlat(city, xy))
            geom = shapely.geometry.mapping(shapely.geometry.polygon.orient(shape) if shape.geom_type == "Polygon"
                                            else shape)
            geom = json.loads(json.dumps(geom))  # tuples → lists
        props = {"feature": "debug", **feat.get("properties", {})}
        out.append({"type": "Feature", "id": f"debug/{k}", "geometry": geom, "properties": props})
    return out
