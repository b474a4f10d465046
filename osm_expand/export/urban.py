"""The ``<urbanenvironment>`` XML of seed 004 §4.4, and its schema.

Streets are lists of ``segment x1 y1 x2 y2`` in local metres (x east, y
north), one segment per pair of consecutive shape points, so curved streets
stay curved; buildings are four ``node x y`` and a ``height``. The town's
own buildings are written as the minimum rotated rectangle of their
footprint. Only optional attributes are added: on the root the PROJ string
and origin that georeference the coordinates; on each street its id, OSM id,
name, class, hierarchy, origin (``source``, ``grown``, ``join``,
``engine``), layer, bridge, tunnel, width, status, year and era; on each street also its ``kind``
(``major`` or ``minor``, 003's classes: motorway to secondary and their links are major) and its ``width`` in metres
(mapped, from its lanes, or its class's); on each building its origin, OSM
id, year, floors, land use and lot. After the buildings, when the city has
them, ``<lots>`` (each ``<lot>`` with its outline as ``node x y``, its id,
block, access street, land use, people and year) and ``<blocks>`` (each
``<block>`` with its outer outline as ``node x y``, its id, origin, year and
land use). The XSD ships with the package (``osm_expand/schemas``).
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from importlib import resources

import numpy as np
import shapely
from lxml import etree

from osm_expand.export.atomic import atomic_write
from osm_expand.export.features import street_tags, xml_attrs
from osm_expand.model import Block, Building, City, Lot, Origin, Street
from osm_expand.model.geometry import minimum_rectangles
from osm_expand.model.segments import is_major, street_width

#: A building with no height gets this one (m); :mod:`osm_expand.heights` fills heights before export.
FALLBACK_HEIGHT = 6.0


def schema() -> etree.XMLSchema:
    xsd = resources.files("osm_expand").joinpath("schemas/urbanenvironment.xsd").read_bytes()
    return etree.XMLSchema(etree.fromstring(xsd))


def _fmt(v: float) -> str:
    return f"{v:.3f}"


def _street_attrs(s: Street) -> dict[str, str]:
    """The street's attributes that the schema knows; layer, bridge and tunnel always."""
    tags = {"layer": "0", "bridge": "no", "tunnel": "no", **street_tags(s)}
    attrs = {"id": str(s.id), "highway": s.highway, "origin": str(s.origin)}
    if s.origin == Origin.SOURCE and s.osm_ids and s.osm_ids[0] > 0:
        attrs["osm_id"] = str(s.osm_ids[0])
    attrs.update({key: tags[key] for key in ("layer", "bridge", "tunnel", "name", "hierarchy") if key in tags})
    attrs["status"] = str(s.status)
    attrs["kind"] = "major" if is_major(s) else "minor"
    attrs["width"] = f"{street_width(s):g}"
    if s.year is not None:
        attrs["year"] = str(s.year)
    if s.era:
        attrs["era"] = s.era
    return xml_attrs(attrs)


def _building_attrs(b: Building) -> dict[str, str]:
    attrs = {"height": f"{b.height if b.height and b.height > 0 else FALLBACK_HEIGHT:.2f}", "origin": str(b.origin)}
    if b.osm_id > 0:
        attrs["osm_id"] = str(b.osm_id)
    if b.year is not None:
        attrs["year"] = str(b.year)
    if b.levels and b.origin != Origin.SOURCE:
        attrs["floors"] = f"{b.levels:g}"
    if b.land_use:
        attrs["landuse"] = b.land_use
    if b.lot is not None:
        attrs["lot"] = str(b.lot)
    return xml_attrs(attrs)


def _lot_attrs(lot: Lot) -> dict[str, str]:
    attrs = {"id": str(lot.id), "block": str(lot.block), "street": str(lot.street), "landuse": lot.land_use,
             "people": f"{lot.people:.1f}"}
    if lot.year is not None:
        attrs["year"] = str(lot.year)
    return xml_attrs(attrs)


def _block_attrs(block: Block) -> dict[str, str]:
    attrs = {"id": str(block.id), "origin": str(block.origin)}
    if block.year is not None:
        attrs["year"] = str(block.year)
    if block.land_use:
        attrs["landuse"] = block.land_use
    return xml_attrs(attrs)


def _outline(tag: str, attrs: dict[str, str], polygon: shapely.Polygon) -> etree._Element:
    """An element with one ``node x y`` per corner of the polygon's outer ring (not repeating the first)."""
    el = etree.Element(tag, attrs)
    for x, y in np.asarray(polygon.exterior.coords)[:-1]:
        etree.SubElement(el, "node", x=_fmt(x), y=_fmt(y))
    return el


def four_corners(b: Building) -> np.ndarray | None:
    """The four corners the XML gives a building: its footprint when that is a rectangle already
    (generated ones), else the minimum rotated rectangle; None when it has no area."""
    return _corners_of([b])[0]


def _corners_of(buildings: Sequence[Building]) -> list[np.ndarray | None]:
    """:func:`four_corners` of each building, the minimum rectangles made in one batch
    (:func:`~osm_expand.model.geometry.minimum_rectangles`)."""
    rings = [np.asarray(b.ring, dtype=float) for b in buildings]
    own = [b.origin != Origin.SOURCE and len(ring) == 5 for b, ring in zip(buildings, rings)]
    made = iter(minimum_rectangles([ring for ring, o in zip(rings, own) if not o]))
    return [ring[:4] if o else next(made) for ring, o in zip(rings, own)]


def write_urbanenvironment(city: City, path: str | os.PathLike) -> None:
    """Write the whole city (streets, buildings, lots and blocks) as ``<urbanenvironment>``, atomically."""
    net = city.network
    proj = city.projection
    with atomic_write(path, "wb") as fh, etree.xmlfile(fh, encoding="UTF-8") as xf:
        xf.write_declaration()
        with xf.element("urbanenvironment", projection=proj.proj_string,
                        lon0=f"{proj.lon0:.7f}", lat0=f"{proj.lat0:.7f}"):
            with xf.element("streets"):
                for street in net.streets:
                    el = etree.Element("street", _street_attrs(street))
                    pts = net.street_xy(street)
                    for (x1, y1), (x2, y2) in zip(pts[:-1], pts[1:]):
                        etree.SubElement(el, "segment", x1=_fmt(x1), y1=_fmt(y1), x2=_fmt(x2), y2=_fmt(y2))
                    xf.write(el)
            with xf.element("buildings"):
                all_corners = _corners_of(city.buildings)
                shaped = [c for c in all_corners if c is not None]
                areas = iter(shapely.area(shapely.polygons(np.array(shaped))).tolist() if shaped else [])
                for b, corners in zip(city.buildings, all_corners):
                    if corners is None or next(areas) < 1.0:
                        continue  # a footprint without area (a mapping error) has no rectangle
                    el = etree.Element("building", _building_attrs(b))
                    for x, y in corners:
                        etree.SubElement(el, "node", x=_fmt(x), y=_fmt(y))
                    xf.write(el)
            if city.lots:
                with xf.element("lots"):
                    for lot in city.lots:
                        xf.write(_outline("lot", _lot_attrs(lot), lot.polygon))
            blocks = [b for b in city.blocks if b.polygon.geom_type == "Polygon" and not b.polygon.is_empty]
            if blocks:
                with xf.element("blocks"):
                    for block in blocks:
                        xf.write(_outline("block", _block_attrs(block), block.polygon))


def validate(path: str | os.PathLike) -> list[str]:
    """Schema errors of an ``<urbanenvironment>`` file (empty when it is valid)."""
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True)
    doc = etree.parse(str(path), parser)
    xsd = schema()
    return [] if xsd.validate(doc) else [str(e) for e in xsd.error_log]
