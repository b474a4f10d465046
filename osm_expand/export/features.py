"""What every export says about a street, in one place."""
from __future__ import annotations

import numpy as np

from osm_expand.model import Street, StreetNetwork


def street_tags(street: Street) -> dict[str, str]:
    """OSM-style tags for a street; absent or default values are left out."""
    tags = {"highway": street.highway}
    if street.name:
        tags["name"] = street.name
    if street.layer:
        tags["layer"] = str(street.layer)
    if street.bridge:
        tags["bridge"] = "yes"
    if street.tunnel:
        tags["tunnel"] = "yes"
    if street.junction:
        tags["junction"] = street.junction
    for key in ("lanes", "width"):
        value = getattr(street, key)
        if value is not None:
            tags[key] = f"{value:g}"
    if street.hierarchy >= 0:
        tags["hierarchy"] = str(street.hierarchy)
    return tags


def lonlat_of_used(net: StreetNetwork) -> tuple[np.ndarray, np.ndarray]:
    """Used node indices and their lon/lat, rounded to OSM's 1e-7 degrees."""
    used = net.used_nodes()
    lon, lat = net.context.projection.to_lonlat(net.xy[used, 0], net.xy[used, 1])
    return used, np.round(np.column_stack([lon, lat]), 7)
