"""GeoJSON output (RFC 7946): lon/lat WGS 84, one LineString feature per street."""
from __future__ import annotations

import json
import os

from osm_expand.export.atomic import atomic_write
from osm_expand.export.features import lonlat_of_used, street_tags
from osm_expand.model import StreetNetwork


def geojson_document(net: StreetNetwork) -> dict:
    used, lonlat = lonlat_of_used(net)
    where = {n: i for i, n in enumerate(used.tolist())}
    features = []
    for k, street in enumerate(net.streets):
        coords = [lonlat[where[n]].tolist() for n in street.nodes]
        props = street_tags(street)
        if street.layer == 0:
            props["layer"] = "0"
        props["osm_ids"] = list(street.osm_ids)
        features.append({"type": "Feature", "id": k,
                         "geometry": {"type": "LineString", "coordinates": coords},
                         "properties": props})
    return {"type": "FeatureCollection", "features": features}


def write_geojson(net: StreetNetwork, path: str | os.PathLike) -> None:
    doc = geojson_document(net)
    with atomic_write(path, "w") as fh:
        json.dump(doc, fh, ensure_ascii=False, separators=(",", ":"))
        fh.write("\n")
