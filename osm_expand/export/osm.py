"""OSM XML output: the town as mapped plus what the tool made, readable by osmium, JOSM and GDAL.

A city read from an OSM file (:attr:`City.source <osm_expand.model.City.source>`) is written
as that file plus what grew: the file is streamed again (never held in memory) and every node,
way and relation of it is written with its id, version, timestamp and tags, in the file's order
— footways, railways, land use, routes and everything else no stage reads — except:

- the ways the city holds as streets are written as the city holds them: with the nodes the
  tool put on them (the tees where new streets join), tags as mapped;
- the ways a history demolished (:func:`~osm_expand.model.demolished_ways`) are left out, and
  relations lose them as members;
- every tagged way and relation carries :data:`~osm_expand.export.features.ORIGIN_KEY`
  (``source``), but for relations tagged with their ``type`` alone (old-style multipolygons,
  whose tags are on their outer way); nodes are left as mapped (GDAL's ``points`` layer is the
  tagged nodes).

What the tool made follows :func:`_new_objects`. A city without a source (a simplified
network, a GeoJSON read back) is written from the city alone: its streets, buildings and lots.

Ids and order, chosen so that the three readers users have all read the file (each checked in
``tests/test_faithful_output.py``):

- nodes come first in the input's order (ascending in any sorted extract), then the new nodes
  with ascending *positive* ids above :data:`SYNTHETIC_NODE_BASE` (and above the input's largest).
  GDAL's OSM driver (QGIS, geopandas) with its default indexing refuses negative node ids and ids
  of 2**47 (1.4e14) and more, and needs node ids in increasing order; libosmium's node-location
  index (pyosmium, ``osmium add-locations-to-ways``) ignores negative ids. 10**14 is far above
  OSM's own ids (1.3e10 in 2025) and leaves 4e13 ids below GDAL's limit.
- new ways and relations get negative ids, -1, -2, ... (JOSM's ids of new objects), and are
  written before the input's, as ``osmium sort`` orders them (negative ids first by absolute
  value); libosmium's multipolygon assembly needs that order. A map that is itself an output
  has negative ids already: the new ones follow them, numbered on below the lowest.
- a mapped way that the city holds in parts it cannot lay back onto the mapped way keeps its id
  on its first part; the other parts get new negative ids, as JOSM does when it splits a way.
- the file says ``upload="never"``, so JOSM will not upload the new objects.
- ``<bounds>`` cover the map's bounds and every node written.

Generated buildings are closed ways tagged ``building=*`` by their land use, ``height`` and
``building:levels`` (:func:`~osm_expand.export.features.building_tags`); generated lots are closed
ways tagged ``landuse=*`` (``leisure=park`` for parks) by their type
(:func:`~osm_expand.export.features.lot_tags`).
"""
from __future__ import annotations

import itertools
import os
import shutil
import tempfile
from array import array
from collections import defaultdict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, TypeVar
from xml.sax.saxutils import escape

import numpy as np
import osmium
from lxml import etree

from osm_expand.errors import UnreadableInputError
from osm_expand.export.atomic import atomic_write
from osm_expand.export.features import (
    ORIGIN_KEY,
    building_tags,
    lot_tags,
    osm_street_tags,
    to_lonlat,
    xml_attrs,
    xml_text,
)
from osm_expand.model import Building, City, Origin, demolished_ways

GENERATOR = "osm-expand"
#: New nodes get ids above max(this, the largest node id of the input): positive, ascending, far
#: above OSM's own ids and below GDAL's limit of 2**47 (see the module's docstring).
SYNTHETIC_NODE_BASE = 10**14

Refs = list[int]  # node ids; new nodes as placeholders -1, -2, ... until their ids are known
Members = list[tuple[str, int, str]]  # (type "n"/"w"/"r", ref, role)


class _Nodes:
    """The nodes the city's objects use: mapped ones by OSM id, new ones by placeholders -1, -2, ...

    New nodes are numbered only when the writer knows the input's largest node id
    (:func:`numbered`), so their ids stay above every id of the input.
    """

    def __init__(self) -> None:
        self.ids: list[np.ndarray] = []
        self.lonlat: list[np.ndarray] = []
        self.fresh = 0

    def add(self, osm_ids: np.ndarray, lonlat: np.ndarray) -> np.ndarray:
        """Register points; those without an id (<= 0) get a placeholder. Returns their ids."""
        ids = np.asarray(osm_ids, dtype=np.int64).copy()
        fresh = ids <= 0
        ids[fresh] = -(self.fresh + 1 + np.arange(int(fresh.sum())))
        self.fresh += int(fresh.sum())
        self.ids.append(ids)
        self.lonlat.append(np.asarray(lonlat, dtype=float).reshape(-1, 2))
        return ids

    def table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(mapped ids ascending, new placeholders -1, -2, ..., lon/lat of both in that order)."""
        ids = np.concatenate(self.ids) if self.ids else np.zeros(0, dtype=np.int64)
        ll = np.concatenate(self.lonlat) if self.lonlat else np.zeros((0, 2))
        uniq, first = np.unique(ids, return_index=True)
        mapped, fresh = uniq > 0, np.flatnonzero(uniq < 0)[::-1]
        return uniq[mapped], uniq[fresh], np.concatenate([ll[first[mapped]], ll[first[fresh]]])


def numbered(refs: Refs, base: int) -> list[int]:
    """Node ids with the placeholders of new nodes replaced: -k → ``base + k``."""
    return [r if r > 0 else base - r for r in refs]


@dataclass
class _New:
    """What the tool made, and the city's own view of the ways it holds, before writing."""

    nodes: _Nodes = field(default_factory=_Nodes)
    ways: list[tuple[int, Refs, dict[str, str]]] = field(default_factory=list)
    relations: list[tuple[int, Members, dict[str, str]]] = field(default_factory=list)
    #: mapped way id → the node lists of the city's streets made from it, in order
    parts: dict[int, list[Refs]] = field(default_factory=dict)
    part_tags: dict[int, dict[str, str]] = field(default_factory=dict)
    last_id: int = 0

    def new_id(self) -> int:
        """Negative ids for new ways and relations, -1, -2, ..."""
        self.last_id -= 1
        return self.last_id


def write_osm(city: City, path: str | os.PathLike) -> None:
    """Write the whole city as OSM XML (atomically): its source file plus what grew, or the city alone.

    Raises
    ------
    InputError
        The city's source file can no longer be read (moved or deleted since it was loaded).
    """
    new = _new_objects(city)
    folder = os.path.dirname(os.path.abspath(path))
    with atomic_write(path, "wb") as fh:
        if city.source is None:
            _write_city(city, new, fh, folder)
        else:
            _write_over_source(city, new, fh, folder)


# ------------------------------------------------------------------------------------------ the city's objects


def _new_objects(city: City) -> _New:
    """Streets, buildings and lots of the city as OSM objects: new ones with negative ids, and the
    parts of mapped ways (laid back onto the mapped way when the source is streamed)."""
    new = _New()
    net = city.network
    used = net.used_nodes()
    street_node = np.zeros(len(net.xy), dtype=np.int64)
    street_node[used] = new.nodes.add(net.node_ids[used], to_lonlat(city, net.xy[used]))
    for street in net.streets:
        refs = street_node[list(street.nodes)].tolist()
        if len(street.osm_ids) == 1 and street.osm_ids[0] != 0:
            new.parts.setdefault(street.osm_ids[0], []).append(refs)
            new.part_tags.setdefault(street.osm_ids[0], _source_tags(dict(street.tags)) if street.tags
                                     else osm_street_tags(street))
        else:
            new.ways.append((new.new_id(), refs, osm_street_tags(street)))
    from_source = city.source is not None
    relations: dict[int, list[Building]] = defaultdict(list)
    for b in city.buildings:
        if b.osm_id != 0 and from_source:  # written from the source, as mapped
            continue
        if b.osm_type == "relation" and b.osm_id > 0:
            relations[b.osm_id].append(b)
            continue
        rings = _ring_ids(city, new.nodes, b)
        new.ways.append((b.osm_id if b.osm_id > 0 else new.new_id(), rings[0], building_tags(b)))
    for rel_id, parts in relations.items():
        members: Members = []
        for b in parts:
            for k, ring in enumerate(_ring_ids(city, new.nodes, b)):
                way_id = new.new_id()
                new.ways.append((way_id, ring, {}))
                members.append(("w", way_id, "outer" if k == 0 else "inner"))
        new.relations.append((rel_id, members, {"type": "multipolygon", **building_tags(parts[0])}))
    for lot in city.lots:
        coords = np.asarray(lot.polygon.exterior.coords)
        ids = new.nodes.add(np.zeros(len(coords) - 1, dtype=np.int64), to_lonlat(city, coords[:-1]))
        new.ways.append((new.new_id(), [*ids.tolist(), int(ids[0])], lot_tags(lot)))
    if not from_source:
        for way in city.unplaced:  # as mapped: its missing nodes stay missing, as in the input
            new.nodes.add(np.asarray(way.located, dtype=np.int64), to_lonlat(city, way.xy))
            new.ways.append((way.osm_id, list(way.refs), _source_tags(dict(way.tags))))
    return new


def _ring_ids(city: City, nodes: _Nodes, b: Building) -> list[Refs]:
    """Node ids of each ring of a building, registering its nodes."""
    out = []
    for k, ring in enumerate(b.rings):
        if k < len(b.node_ids):  # as mapped
            out.append(nodes.add(b.node_ids[k], to_lonlat(city, ring)).tolist())
        else:  # a generated ring: new nodes, closed on its first
            ids = nodes.add(np.zeros(len(ring) - 1, dtype=np.int64), to_lonlat(city, ring[:-1]))
            out.append([*ids.tolist(), int(ids[0])])
    return out


def _source_tags(tags: dict[str, str]) -> dict[str, str]:
    """A mapped object's tags, with its origin when it has none yet (a map that is an earlier output
    keeps the origins that output gave) and tags beyond ``type``: untagged ways are structure, and
    so is a relation tagged with its type alone, an old-style multipolygon that takes its tags
    from its outer way (GDAL reads it so only while the relation has no other tag)."""
    return {**tags, ORIGIN_KEY: tags.get(ORIGIN_KEY, str(Origin.SOURCE))} if set(tags) - {"type"} else tags


def laid_over(refs: Refs, parts: list[Refs], located: list[bool] | None = None) -> Refs | None:
    """The mapped way's node list ``refs`` with each part laid over the run of its mapped nodes.

    The city holds a mapped way as one street, or several where a clipped extract cut it, with
    new nodes (tees) put in between its mapped ones. Each part's mapped nodes are a run of
    ``refs`` (or of it reversed); the result is ``refs`` with those runs replaced by the parts,
    the nodes outside every part kept (those the extract lacks). None when a part does not fit,
    or when a stretch between two nodes the file has (``located``) is in no part: ingest made a
    street of every such stretch, so the tool demolished it, and the way is written as its parts.
    """
    if located is not None:
        held = {frozenset(e) for part in parts for e in _pairs([r for r in part if r > 0])}
        if any(located[i] and located[i + 1] and frozenset(e) not in held for i, e in enumerate(_pairs(refs))):
            return None
    out: Refs = []
    pos = 0
    for part in parts:
        mapped = [r for r in part if r > 0]
        if len(mapped) < 2 or part[0] <= 0 or part[-1] <= 0:
            return None
        start = _run(refs, mapped, max(pos - 1, 0))
        if start is None:
            part, mapped = part[::-1], mapped[::-1]
            start = _run(refs, mapped, max(pos - 1, 0))
            if start is None:
                return None
        if start < pos:  # the part begins on the node the last one ended on
            part = part[1:]
        out += refs[pos:start] + part
        pos = start + len(mapped)
    return out + refs[pos:]


def _pairs(refs: Refs) -> list[tuple[int, int]]:
    return list(itertools.pairwise(refs))


def _run(refs: Refs, run: Refs, start: int) -> int | None:
    """The first index at or after ``start`` where ``run`` lies in ``refs``."""
    n = len(run)
    for i in range(start, len(refs) - n + 1):
        if refs[i] == run[0] and refs[i:i + n] == run:
            return i
    return None


# ------------------------------------------------------------------------------------------ writing


class _Body:
    """The file's elements, one a line, into a temporary file, with the extent of the nodes
    written (the ``<bounds>`` before them need it)."""

    def __init__(self, fh: IO[bytes]) -> None:
        self.fh = fh
        self.lon = array("d")  # 8 bytes a node, not a Python float's 24 and a list slot
        self.lat = array("d")

    def node(self, attrs: dict[str, str], lon: float, lat: float, tags: dict[str, str] | None = None) -> None:
        """A node; an untagged one (most of a file) formatted directly rather than built by lxml
        (Andorra's OSM output: 1.64 → 1.39 s CPU), when every attribute is printable text (lxml
        checks the rest)."""
        self.lon.append(lon)
        self.lat.append(lat)
        if not tags and all(v.isprintable() for v in attrs.values()):
            text = " ".join(f'{k}="{escape(v, _QUOTE)}"' for k, v in attrs.items())
            self.fh.write(f'<node {text} lat="{lat:.7f}" lon="{lon:.7f}"/>\n'.encode())
            return
        el = etree.Element("node", {**xml_attrs(attrs), "lat": f"{lat:.7f}", "lon": f"{lon:.7f}"})
        _tags(el, tags or {})
        self.write(el)

    def way(self, attrs: dict[str, str], refs: list[int], tags: dict[str, str]) -> None:
        el = etree.Element("way", xml_attrs(attrs))
        for n in refs:
            etree.SubElement(el, "nd", ref=str(n))
        _tags(el, tags)
        self.write(el)

    def relation(self, attrs: dict[str, str], members: Members, tags: dict[str, str]) -> None:
        el = etree.Element("relation", xml_attrs(attrs))
        for kind, ref, role in members:
            etree.SubElement(el, "member", type=_MEMBER_TYPE[kind], ref=str(ref), role=role)
        _tags(el, tags)
        self.write(el)

    def write(self, el: etree._Element) -> None:
        self.fh.write(etree.tostring(el, encoding="UTF-8") + b"\n")


_MEMBER_TYPE = {"n": "node", "w": "way", "r": "relation"}
_QUOTE = {'"': "&quot;"}


def _tags(el: etree._Element, tags: dict[str, str]) -> None:
    for k, v in tags.items():  # a name with U+0001 (possible in PBF or GeoJSON) must not stop the writer
        etree.SubElement(el, "tag", k=xml_text(k), v=xml_text(v))


def _new_attrs(osm_id: int) -> dict[str, str]:
    return {"id": str(osm_id), "version": "1"}


def _mapped_attrs(obj) -> dict[str, str]:
    """id, version, timestamp, changeset, uid and user of an object of the input, as far as it has them.

    JOSM needs a version on every object with a positive id; an input without versions gets 1.
    """
    attrs = {"id": str(obj.id), "version": str(obj.version or 1)}
    ts = obj.timestamp
    if ts is not None and ts.year > 1970:
        attrs["timestamp"] = ts.isoformat().replace("+00:00", "Z")  # pyosmium's are UTC, whole seconds
    if obj.changeset:
        attrs["changeset"] = str(obj.changeset)
    if obj.uid:
        attrs["uid"] = str(obj.uid)
        attrs["user"] = obj.user
    return attrs


def _envelope(out: IO[bytes], body: _Body, city: City, extra_lonlat: np.ndarray) -> None:
    """The declaration, ``<osm>``, ``<bounds>`` over every node, the body (a temporary file beside
    the output, gone with the process), ``</osm>``."""
    lonlat = np.column_stack([np.frombuffer(body.lon, dtype=float), np.frombuffer(body.lat, dtype=float)])
    lon0, lat0, lon1, lat1 = _bounds(city, np.concatenate([lonlat.reshape(-1, 2), extra_lonlat.reshape(-1, 2)]))
    out.write(b'<?xml version=\'1.0\' encoding=\'UTF-8\'?>\n')
    out.write(f'<osm version="0.6" generator="{GENERATOR}" upload="never">\n'.encode())
    out.write(etree.tostring(etree.Element("bounds", minlat=f"{lat0:.7f}", minlon=f"{lon0:.7f}",
                                           maxlat=f"{lat1:.7f}", maxlon=f"{lon1:.7f}")) + b"\n")
    body.fh.seek(0)
    shutil.copyfileobj(body.fh, out)
    out.write(b"</osm>\n")


def _write_city(city: City, new: _New, out: IO[bytes], folder: str) -> None:
    """A city without a source: its own objects, sorted as ``osmium sort`` does."""
    ways = list(new.ways)
    for way_id, parts in new.parts.items():  # a way in several parts keeps its id on the first
        ways.append((way_id, parts[0], new.part_tags[way_id]))
        ways.extend((new.new_id(), refs, new.part_tags[way_id]) for refs in parts[1:])
    mapped, fresh, lonlat = new.nodes.table()
    base = max(SYNTHETIC_NODE_BASE, int(mapped.max()) if len(mapped) else 0)
    with tempfile.TemporaryFile(dir=folder) as tmp:
        body = _Body(tmp)
        for i, (lon, lat) in zip(numbered([*mapped.tolist(), *fresh.tolist()], base), lonlat.tolist()):
            body.node(_new_attrs(i), lon, lat)
        for way_id, refs, tags in sorted(ways, key=lambda w: _order(w[0])):
            body.way(_new_attrs(way_id), numbered(refs, base), tags)
        for rel_id, members, tags in sorted(new.relations, key=lambda r: _order(r[0])):
            body.relation(_new_attrs(rel_id), members, tags)
        _envelope(out, body, city, np.zeros((0, 2)))


def _write_over_source(city: City, new: _New, out: IO[bytes], folder: str) -> None:
    """The source file streamed again, the city's changes and new objects put in (module docstring)."""
    assert city.source is not None
    src = city.source.path
    if not Path(src).is_file():
        raise UnreadableInputError(f"{src}: the town's OSM file is gone (it is read again to write the OSM output)")
    gone = set(demolished_ways(city))
    laid, split = _lay_parts(src, new)
    ways = list(new.ways)
    for way_id, parts in split.items():  # parts that do not fit the mapped way: the others get new ids
        ways.extend((new.new_id(), refs, new.part_tags[way_id]) for refs in parts[1:])
        laid[way_id] = parts[0]
    _, fresh, lonlat = new.nodes.table()
    fresh_lonlat = lonlat[len(lonlat) - len(fresh):]
    largest = 0
    with tempfile.TemporaryFile(dir=folder) as tmp:
        body = _Body(tmp)
        for node in _read(src, osmium.osm.Node):
            loc = node.location
            if loc.valid():
                body.node(_mapped_attrs(node), loc.lon, loc.lat, dict(node.tags))
                largest = max(largest, node.id)
        base = max(SYNTHETIC_NODE_BASE, largest)
        for i, (lon, lat) in zip(numbered(fresh.tolist(), base), fresh_lonlat.tolist()):
            body.node(_new_attrs(i), lon, lat)

        def write_new_ways(below: int) -> None:
            for way_id, refs, tags in ways:
                body.way(_new_attrs(way_id + below), numbered(refs, base), tags)

        def write_new_relations(below: int) -> None:
            for rel_id, members, tags in new.relations:
                body.relation(_new_attrs(rel_id + below), members, tags)

        new_ways = _AfterNegative(write_new_ways)
        for way in _read(src, osmium.osm.Way):
            new_ways.before(way.id)
            if way.id in gone:
                continue
            refs = laid.get(way.id)
            if refs is None:
                body.way(_mapped_attrs(way), [n.ref for n in way.nodes], _source_tags(dict(way.tags)))
            else:
                body.way(_mapped_attrs(way), numbered(refs, base), new.part_tags[way.id])
        new_ways.before(1)
        new_relations = _AfterNegative(write_new_relations)
        for rel in _read(src, osmium.osm.Relation):
            new_relations.before(rel.id)
            members = [(m.type, m.ref, m.role) for m in rel.members if not (m.type == "w" and m.ref in gone)]
            body.relation(_mapped_attrs(rel), members, _source_tags(dict(rel.tags)))
        new_relations.before(1)
        _envelope(out, body, city, fresh_lonlat)


_Object = TypeVar("_Object", osmium.osm.Node, osmium.osm.Way, osmium.osm.Relation)
_ENTITY = {osmium.osm.Node: osmium.osm.NODE, osmium.osm.Way: osmium.osm.WAY, osmium.osm.Relation: osmium.osm.RELATION}


def _read(src: str, kind: type[_Object]) -> Iterator[_Object]:
    """The file's objects of one kind, in file order."""
    for obj in osmium.FileProcessor(src, _ENTITY[kind]):
        if isinstance(obj, kind):
            yield obj


class _AfterNegative:
    """Writes the new ways (or relations) once, where ``osmium sort`` puts them: after the input's
    negative ids (a map that is an earlier output has them), numbered on below the lowest of those,
    and before its first positive id."""

    def __init__(self, write: Callable[[int], None]) -> None:
        self.write, self.lowest, self.done = write, 0, False

    def before(self, osm_id: int) -> None:
        if self.done:
            return
        if osm_id < 0:
            self.lowest = min(self.lowest, osm_id)
            return
        self.write(self.lowest)
        self.done = True


def _lay_parts(src: str, new: _New) -> tuple[dict[int, Refs], dict[int, list[Refs]]]:
    """The city's streets laid back onto the mapped ways they came from (one read of the file with
    node locations, only its highways reaching Python): (way id → its node list, way id → parts
    that do not fit)."""
    laid: dict[int, Refs] = {}
    split: dict[int, list[Refs]] = {}
    if not new.parts:
        return laid, split
    fp = (osmium.FileProcessor(src, osmium.osm.NODE | osmium.osm.WAY).with_locations()
          .with_filter(osmium.filter.EntityFilter(osmium.osm.WAY))
          .with_filter(osmium.filter.KeyFilter("highway")))  # streets (pyosmium's IdFilter takes no negative ids)
    for way in fp:
        if not isinstance(way, osmium.osm.Way) or way.id not in new.parts:
            continue
        located = [n.location.valid() for n in way.nodes]
        refs = laid_over([n.ref for n in way.nodes], new.parts[way.id], located)
        if refs is None:
            split[way.id] = new.parts[way.id]
        else:
            laid[way.id] = refs
    for way_id in new.parts.keys() - laid.keys() - split.keys():  # not in the file (never expected)
        split[way_id] = new.parts[way_id]
    return laid, split


def _order(osm_id: int) -> tuple[bool, int]:
    """osmium's order: negative ids first by absolute value, then positive ones."""
    return (osm_id > 0, abs(osm_id))


def _bounds(city: City, lonlat: np.ndarray) -> tuple[float, float, float, float]:
    """The map's bounds grown to cover every node written, rounded outward to 1e-7 degrees."""
    lon0, lat0, lon1, lat1 = city.context.bounds_lonlat
    if len(lonlat):
        lon0, lat0 = min(lon0, float(lonlat[:, 0].min())), min(lat0, float(lonlat[:, 1].min()))
        lon1, lat1 = max(lon1, float(lonlat[:, 0].max())), max(lat1, float(lonlat[:, 1].max()))
    down, up = lambda v: np.floor(v * 1e7) / 1e7, lambda v: np.ceil(v * 1e7) / 1e7  # noqa: E731
    return float(down(lon0)), float(down(lat0)), float(up(lon1)), float(up(lat1))
