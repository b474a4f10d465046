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
from collections.abc import Iterator, Sequence
from importlib import resources
from itertools import chain

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


def _formatted(coords: np.ndarray) -> list[str]:
    """Every number of ``coords`` to the millimetre (three decimals: the writer's one coordinate format), row
    after row (x, then y): the numbers made Python floats in one call first (formatting numpy scalars one by
    one was a third of the writer's time on Campo Grande; a numpy float formats as the same float does)."""
    return [f"{v:.3f}" for v in coords.ravel().tolist()]


def _outlines(tag: str, attrs: Sequence[dict[str, str]], polygons: Sequence[shapely.Polygon]
              ) -> Iterator[etree._Element]:
    """One element per polygon with one ``node x y`` per corner of its outer ring (not repeating the first).

    The outer rings' corners of all the polygons are read and formatted at once (:func:`_formatted`)."""
    if not len(polygons):
        return
    rings = shapely.get_exterior_ring(np.array(polygons, dtype=object))
    coords, owner = shapely.get_coordinates(rings, return_index=True)
    text = _formatted(coords)
    ends = np.searchsorted(owner, np.arange(1, len(polygons) + 1)).tolist()
    start = 0
    for attr, end in zip(attrs, ends):
        el = etree.Element(tag, attr)
        for i in range(2 * start, 2 * (end - 1), 2):  # the ring's last point repeats its first
            etree.SubElement(el, "node", x=text[i], y=text[i + 1])
        yield el
        start = end


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
                sizes = [len(street.nodes) for street in net.streets]
                nodes = np.fromiter(chain.from_iterable(street.nodes for street in net.streets), dtype=np.intp,
                                    count=sum(sizes))
                text = _formatted(net.xy[nodes])  # every street's points at once
                start = 0
                for street, size in zip(net.streets, sizes):
                    el = etree.Element("street", _street_attrs(street))
                    for i in range(2 * start, 2 * (start + size - 1), 2):  # point i/2 to the next
                        etree.SubElement(el, "segment", x1=text[i], y1=text[i + 1], x2=text[i + 2], y2=text[i + 3])
                    xf.write(el)
                    start += size
            with xf.element("buildings"):
                all_corners = _corners_of(city.buildings)
                shaped = [c for c in all_corners if c is not None]
                rings = np.array(shaped)
                areas = iter(shapely.area(shapely.polygons(rings)).tolist() if shaped else [])
                numbers = iter(_formatted(rings) if shaped else [])
                for b, corners in zip(city.buildings, all_corners):
                    if corners is None:
                        continue
                    x0, y0, x1, y1, x2, y2, x3, y3 = (next(numbers) for _ in range(8))
                    if next(areas) < 1.0:
                        continue  # a footprint without area (a mapping error) has no rectangle
                    el = etree.Element("building", _building_attrs(b))
                    for x, y in ((x0, y0), (x1, y1), (x2, y2), (x3, y3)):
                        etree.SubElement(el, "node", x=x, y=y)
                    xf.write(el)
            if city.lots:
                with xf.element("lots"):
                    lots = city.lots
                    for el in _outlines("lot", [_lot_attrs(lot) for lot in lots], [lot.polygon for lot in lots]):
                        xf.write(el)
            blocks = [b for b in city.blocks if b.polygon.geom_type == "Polygon" and not b.polygon.is_empty]
            if blocks:
                with xf.element("blocks"):
                    for el in _outlines("block", [_block_attrs(b) for b in blocks], [b.polygon for b in blocks]):
                        xf.write(el)


def validate(path: str | os.PathLike) -> list[str]:
    """Schema errors of an ``<urbanenvironment>`` file (empty when it is valid)."""
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True)
    doc = etree.parse(str(path), parser)
    xsd = schema()
    return [] if xsd.validate(doc) else [str(e) for e in xsd.error_log]
