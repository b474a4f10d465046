"""OSM XML output: the town as mapped plus what the tool made, readable by osmium and JOSM.

- The town's nodes, ways and relations keep their ids and tags; every
  object also carries :data:`~osm_expand.export.features.ORIGIN_KEY`
  (``source`` for the town's own), and new ones the year they were built.
- A mapped way that the city holds in several parts (split at a gap in a
  clipped extract, or by the tool) keeps its id on its first part; the
  other parts get new negative ids, as JOSM does when it splits a way.
- New ways and relations get negative ids. New *nodes* cannot: libosmium's
  node-location index ignores negative ids, so ways over them could not be
  read back. They are numbered from :data:`SYNTHETIC_NODE_BASE` instead,
  and the file says ``upload="never"`` so JOSM will not upload them.
- Buildings are written as mapped: closed ways with their own nodes, and
  multipolygon relations with their rings as member ways. Generated
  buildings are closed ways tagged ``building=*`` by their land use,
  ``height`` and ``building:levels``
  (:func:`~osm_expand.export.features.building_tags`).
- Generated lots are closed ways tagged ``landuse=*`` (``leisure=park`` for
  parks) by their type (:func:`~osm_expand.export.features.lot_tags`).
- Ways a clipped extract leaves without a drawable shape (a street with one
  node inside the map, a building cut by its edge) are written back as they
  were mapped, with references to the nodes the extract lacks.
- ``<bounds>`` cover the map's bounds and every node written.
- Objects are sorted as ``osmium sort`` does (nodes, ways, relations; by id).
"""
from __future__ import annotations

import os
from collections import defaultdict

import numpy as np
from lxml import etree

from osm_expand.export.atomic import atomic_write
from osm_expand.export.features import ORIGIN_KEY, building_tags, lot_tags, osm_street_tags, to_lonlat, xml_text
from osm_expand.model import Building, City

GENERATOR = "osm-expand"
SYNTHETIC_NODE_BASE = 10**15


class _Nodes:
    """Every node written: OSM id → lon/lat, the town's ids kept, new ones numbered from the base."""

    def __init__(self) -> None:
        self.ids: list[np.ndarray] = []
        self.lonlat: list[np.ndarray] = []
        self.next = SYNTHETIC_NODE_BASE

    def add(self, osm_ids: np.ndarray, lonlat: np.ndarray) -> np.ndarray:
        """Register points; those without an id (<= 0) get a new one. Returns their ids."""
        ids = np.asarray(osm_ids, dtype=np.int64).copy()
        fresh = ids <= 0
        ids[fresh] = self.next + 1 + np.arange(int(fresh.sum()))
        self.next += int(fresh.sum())
        self.ids.append(ids)
        self.lonlat.append(lonlat)
        return ids

    def table(self) -> tuple[np.ndarray, np.ndarray]:
        """Unique ids, ascending, with their lon/lat (the first seen for an id)."""
        ids = np.concatenate(self.ids) if self.ids else np.zeros(0, dtype=np.int64)
        ll = np.concatenate(self.lonlat) if self.lonlat else np.zeros((0, 2))
        uniq, first = np.unique(ids, return_index=True)
        return uniq, ll[first]


def write_osm(city: City, path: str | os.PathLike) -> None:
    """Write the whole city as OSM XML (atomically)."""
    nodes = _Nodes()
    net = city.network
    used = net.used_nodes()
    street_node = np.zeros(len(net.xy), dtype=np.int64)
    street_node[used] = nodes.add(net.node_ids[used], to_lonlat(city, net.xy[used]))
    ways: list[tuple[int, list[int], dict[str, str]]] = []
    next_way = _NewIds()
    for way_id, street in zip(_way_ids(city, next_way), net.streets):
        ways.append((way_id, street_node[list(street.nodes)].tolist(), osm_street_tags(street)))
    relations = _buildings(city, nodes, ways, next_way)
    for lot in city.lots:
        ring = np.asarray(lot.polygon.exterior.coords)
        ids = nodes.add(np.zeros(len(ring) - 1, dtype=np.int64), to_lonlat(city, ring[:-1]))
        ways.append((next_way(), [*ids.tolist(), int(ids[0])], lot_tags(lot)))
    for way in city.unplaced:  # as mapped: its missing nodes stay missing, as in the input
        nodes.add(np.asarray(way.located, dtype=np.int64), to_lonlat(city, way.xy))
        ways.append((way.osm_id, list(way.refs), {**dict(way.tags), ORIGIN_KEY: "source"}))
    node_ids, lonlat = nodes.table()
    with atomic_write(path, "wb") as fh, etree.xmlfile(fh, encoding="UTF-8") as xf:
        xf.write_declaration()
        with xf.element("osm", version="0.6", generator=GENERATOR, upload="never"):
            lon0, lat0, lon1, lat1 = _bounds(city, lonlat)
            xf.write(etree.Element("bounds", minlat=f"{lat0:.7f}", minlon=f"{lon0:.7f}",
                                   maxlat=f"{lat1:.7f}", maxlon=f"{lon1:.7f}"))
            for i, (lon, lat) in zip(node_ids.tolist(), lonlat.tolist()):
                xf.write(etree.Element("node", id=str(i), version="1", lat=f"{lat:.7f}", lon=f"{lon:.7f}"))
            for way_id, refs, tags in sorted(ways, key=lambda w: _order(w[0])):
                way = etree.Element("way", id=str(way_id), version="1")
                for n in refs:
                    etree.SubElement(way, "nd", ref=str(n))
                _tags(way, tags)
                xf.write(way)
            for rel_id, members, tags in sorted(relations, key=lambda r: _order(r[0])):
                rel = etree.Element("relation", id=str(rel_id), version="1")
                for way_id, role in members:
                    etree.SubElement(rel, "member", type="way", ref=str(way_id), role=role)
                _tags(rel, tags)
                xf.write(rel)


def _tags(el: etree._Element, tags: dict[str, str]) -> None:
    for k, v in tags.items():
        etree.SubElement(el, "tag", k=xml_text(k), v=xml_text(v))


def _order(osm_id: int) -> tuple[bool, int]:
    """osmium's order: negative ids first by absolute value, then positive ones."""
    return (osm_id > 0, abs(osm_id))


class _NewIds:
    """Negative ids for new ways and relations, -1, -2, ..."""

    def __init__(self) -> None:
        self.last = 0

    def __call__(self) -> int:
        self.last -= 1
        return self.last


def _way_ids(city: City, new_id: _NewIds) -> list[int]:
    """The town's way id for the first street holding it; new negative ids for the rest."""
    seen, out = set(), []
    for s in city.network.streets:
        if len(s.osm_ids) == 1 and s.osm_ids[0] > 0 and s.osm_ids[0] not in seen:
            seen.add(s.osm_ids[0])
            out.append(s.osm_ids[0])
        else:
            out.append(new_id())
    return out


def _buildings(city: City, nodes: _Nodes, ways: list, new_id: _NewIds) -> list[tuple[int, list, dict]]:
    """Buildings as ways (appended to ``ways``) and multipolygon relations (returned)."""
    relations: dict[int, list[Building]] = defaultdict(list)
    for b in city.buildings:
        if b.osm_type == "relation" and b.osm_id > 0:
            relations[b.osm_id].append(b)
            continue
        ids = _ring_ids(city, nodes, b)
        way_id = b.osm_id if b.osm_id > 0 else new_id()
        ways.append((way_id, ids[0], building_tags(b)))
    out = []
    for rel_id, parts in relations.items():
        members = []
        for b in parts:
            for k, ring in enumerate(_ring_ids(city, nodes, b)):
                way_id = new_id()
                ways.append((way_id, ring, {}))
                members.append((way_id, "outer" if k == 0 else "inner"))
        out.append((rel_id, members, {"type": "multipolygon", **building_tags(parts[0])}))
    return out


def _ring_ids(city: City, nodes: _Nodes, b: Building) -> list[list[int]]:
    """Node ids of each ring of a building, registering its nodes."""
    out = []
    for k, ring in enumerate(b.rings):
        if k < len(b.node_ids):  # as mapped
            out.append(nodes.add(b.node_ids[k], to_lonlat(city, ring)).tolist())
        else:  # a generated ring: new nodes, closed on its first
            ids = nodes.add(np.zeros(len(ring) - 1, dtype=np.int64), to_lonlat(city, ring[:-1]))
            out.append([*ids.tolist(), int(ids[0])])
    return out


def _bounds(city: City, lonlat: np.ndarray) -> tuple[float, float, float, float]:
    """The map's bounds grown to cover every node written, rounded outward to 1e-7 degrees."""
    lon0, lat0, lon1, lat1 = city.context.bounds_lonlat
    if len(lonlat):
        lon0, lat0 = min(lon0, float(lonlat[:, 0].min())), min(lat0, float(lonlat[:, 1].min()))
        lon1, lat1 = max(lon1, float(lonlat[:, 0].max())), max(lat1, float(lonlat[:, 1].max()))
    down, up = lambda v: np.floor(v * 1e7) / 1e7, lambda v: np.ceil(v * 1e7) / 1e7  # noqa: E731
    return float(down(lon0)), float(down(lat0)), float(up(lon1)), float(up(lat1))
