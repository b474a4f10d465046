"""What every export says about a street or a building, in one place.

The town's own streets and buildings keep their OSM tags as mapped; what
the tool made gets tags from its typed fields. Everything carries its
origin, so a user can select the new district with one expression:
``"origin" = 'grown'`` in GeoJSON, the :data:`ORIGIN_KEY` tag in OSM, the
``origin`` attribute in the XML.
"""
from __future__ import annotations

import re

import numpy as np

from osm_expand.model import Building, City, Lot, Origin, Street

#: OSM tag key that says where an object came from: ``source`` (the town as mapped), ``grown``,
#: ``join`` (a street joining the district to the town) or ``engine`` (built in the simulated years).
ORIGIN_KEY = "osm_expand:origin"
#: OSM tag key of the year an object was built in the simulation.
YEAR_KEY = "osm_expand:year"
#: Characters XML 1.0 forbids (control characters, surrogates, U+FFFE/U+FFFF): lxml refuses to write them.
_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def xml_text(text: str) -> str:
    """``text`` with the characters XML cannot hold replaced by U+FFFD.

    A street name with U+0001 (possible in PBF, GeoJSON or a history's
    names) would otherwise stop the XML and OSM writers after the whole run.
    """
    return _NOT_XML.sub("\ufffd", text)


def xml_attrs(attrs: dict[str, str]) -> dict[str, str]:
    """Every key and value made safe for XML (:func:`xml_text`).

    One search of all of them first: almost always none needs a change, and a substitution per key and
    value was a fifth of the XML writer's time on Campo Grande (16,000 elements)."""
    if _NOT_XML.search("".join([*attrs, *attrs.values()])) is None:
        return dict(attrs)
    return {xml_text(k): xml_text(v) for k, v in attrs.items()}


def street_tags(street: Street) -> dict[str, str]:
    """OSM-style tags from a street's typed fields; absent or default values are left out."""
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


def osm_street_tags(street: Street) -> dict[str, str]:
    """The tags a street is written with: as mapped for the town's, typed fields for new ones, and its origin."""
    if street.origin == Origin.SOURCE and street.tags:
        tags = dict(street.tags)
    else:
        tags = street_tags(street)
    return {**tags, **history_tags(street.origin, street.year, street.era)}


def history_tags(origin: Origin, year: int | None, era: str | None = None) -> dict[str, str]:
    """Origin always; year and era for what the tool made."""
    tags = {ORIGIN_KEY: str(origin)}
    if origin != Origin.SOURCE:
        if year is not None:
            tags[YEAR_KEY] = str(year)
        if era:
            tags["osm_expand:era"] = era
    return tags


#: ``building=*`` of a generated building by its land-use type (the bundled types; others get ``yes``):
#: detached houses, blocks of flats, shops and offices, sheds and halls (OSM wiki, Key:building).
BUILDING_VALUE = {"residential_low": "house", "residential_high": "apartments", "commercial": "commercial",
                  "industrial": "industrial"}
#: The OSM tag of a generated lot's land use by its type (OSM wiki, Key:landuse; parks are ``leisure``).
LANDUSE_TAG = {"residential_low": ("landuse", "residential"), "residential_high": ("landuse", "residential"),
               "commercial": ("landuse", "commercial"), "industrial": ("landuse", "industrial"),
               "park": ("leisure", "park")}
#: OSM tag key of the land-use type the tool gave a lot or a building.
LANDUSE_KEY = "osm_expand:landuse"


def building_tags(b: Building) -> dict[str, str]:
    """A building's tags: as mapped for the town's, from the model for generated ones, and its origin.

    A generated building is ``building=*`` by its land use (:data:`BUILDING_VALUE`)
    with ``height`` (m), ``building:levels``, its land-use type and its lot.
    """
    if b.origin == Origin.SOURCE and b.tags:
        tags = dict(b.tags)
    else:
        tags = {"building": BUILDING_VALUE.get(b.land_use or "", "yes")}
        if b.height:
            tags["height"] = f"{b.height:.1f}"
        if b.levels:
            tags["building:levels"] = f"{b.levels:g}"
        if b.land_use:
            tags[LANDUSE_KEY] = b.land_use
        if b.lot is not None:
            tags["osm_expand:lot"] = str(b.lot)
    return {**tags, **history_tags(b.origin, b.year)}


def lot_tags(lot: Lot) -> dict[str, str]:
    """A generated lot as an OSM area: ``landuse=*`` (or ``leisure=park``) by its type, its type, id and year."""
    key, value = LANDUSE_TAG.get(lot.land_use, ("landuse", lot.land_use))
    tags = {key: value, LANDUSE_KEY: lot.land_use, "osm_expand:lot": str(lot.id)}
    if lot.people:
        tags["osm_expand:people"] = f"{lot.people:.0f}"
    return {**tags, **history_tags(Origin.ENGINE, lot.year)}


def to_lonlat(city: City, xy: np.ndarray) -> np.ndarray:
    """(n, 2) metres → (n, 2) lon/lat rounded to OSM's 1e-7 degrees."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    lon, lat = city.projection.to_lonlat(xy[:, 0], xy[:, 1])
    return np.round(np.column_stack([lon, lat]), 7)


def lonlat_of_used(city: City) -> tuple[np.ndarray, np.ndarray]:
    """Used street-node indices and their lon/lat."""
    used = city.network.used_nodes()
    return used, to_lonlat(city, city.network.xy[used])
