"""The ``<urbanenvironment>`` XML of seed 004 §4.4, and its schema.

Streets are lists of ``segment x1 y1 x2 y2`` in local metres (x east, y
north), one segment per pair of consecutive shape points, so curved streets
stay curved; buildings are four ``node x y`` and a ``height``. Only optional
attributes are added: on the root the PROJ string and origin that
georeference the coordinates, on each street its id, name, class,
hierarchy, origin (``source`` or ``grown``), layer, bridge, tunnel, width and
year. The XSD ships with the package (``osm_expand/schemas``).
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from importlib import resources

import numpy as np
from lxml import etree

from osm_expand.export.atomic import atomic_write
from osm_expand.export.features import street_tags
from osm_expand.model import StreetNetwork

#: One building: its four corners (metres, in order around it) and its height (m).
Footprint = tuple[np.ndarray, float]


def schema() -> etree.XMLSchema:
    xsd = resources.files("osm_expand").joinpath("schemas/urbanenvironment.xsd").read_bytes()
    return etree.XMLSchema(etree.fromstring(xsd))


def _fmt(v: float) -> str:
    return f"{v:.3f}"


def _street_attrs(net: StreetNetwork, k: int, origin: str) -> dict[str, str]:
    """The street's tags (:func:`street_tags`) that the schema knows, layer, bridge and tunnel always."""
    s = net.streets[k]
    tags = {"layer": "0", "bridge": "no", "tunnel": "no", **street_tags(s)}
    attrs = {"id": str(k), "highway": s.highway, "origin": origin}
    attrs.update({key: tags[key] for key in ("layer", "bridge", "tunnel", "name", "hierarchy", "width") if key in tags})
    if s.year is not None:
        attrs["year"] = str(s.year)
    return attrs


def write_urbanenvironment(net: StreetNetwork, path: str | os.PathLike,
                           buildings: Sequence[Footprint] = (), origins: Sequence[str] | None = None) -> None:
    """Write streets (and buildings) as ``<urbanenvironment>``; ``origins`` marks streets source/grown."""
    proj = net.context.projection
    with atomic_write(path, "wb") as fh, etree.xmlfile(fh, encoding="UTF-8") as xf:
        xf.write_declaration()
        with xf.element("urbanenvironment", projection=proj.proj_string,
                        lon0=f"{proj.lon0:.7f}", lat0=f"{proj.lat0:.7f}"):
            with xf.element("streets"):
                for k, street in enumerate(net.streets):
                    el = etree.Element("street", _street_attrs(net, k, origins[k] if origins else "source"))
                    pts = net.street_xy(street)
                    for (x1, y1), (x2, y2) in zip(pts[:-1], pts[1:]):
                        etree.SubElement(el, "segment", x1=_fmt(x1), y1=_fmt(y1), x2=_fmt(x2), y2=_fmt(y2))
                    xf.write(el)
            with xf.element("buildings"):
                for corners, height in buildings:
                    el = etree.Element("building", height=f"{height:.2f}")
                    for x, y in np.asarray(corners, dtype=float)[:4]:
                        etree.SubElement(el, "node", x=_fmt(x), y=_fmt(y))
                    xf.write(el)


def validate(path: str | os.PathLike) -> list[str]:
    """Schema errors of an ``<urbanenvironment>`` file (empty when it is valid)."""
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True)
    doc = etree.parse(str(path), parser)
    xsd = schema()
    return [] if xsd.validate(doc) else [str(e) for e in xsd.error_log]
