"""The ``one-pass`` clip: one read with a location index of every node, every way tested in Python against
the boxes (see :mod:`osm_expand.clip`)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import osmium
from osmium.osm.mutable import Node

from osm_expand.clip.boxes import _Boxes
from osm_expand.clip.found import _add, _boxes_of, _each, _Found, _meta, _Order
from osm_expand.clip.writer import _Extracts, _meta_attrs


def _one_pass(src: Path, grid: _Boxes, extracts: _Extracts, index: str, complete: bool) -> int:
    """The clip with a location index of every node, every way tested in Python; returns the reads."""
    found = _Found()
    locations = osmium.index.create_map(index)
    tagged_nodes = osmium.filter.EmptyTagFilter()
    tagged_nodes.enable_for(osmium.osm.NODE)
    tagged: dict[int, tuple] = {}
    order = _Order(src)
    # with_locations() is annotated as taking a str but takes a LocationTable too (pyosmium 4's file_processor.py)
    reader = osmium.FileProcessor(str(src)).with_locations(locations)  # type: ignore[arg-type]
    for obj in reader.with_filter(tagged_nodes):
        order.saw(obj, nodes_first=True)
        if isinstance(obj, osmium.osm.Node):  # obj.is_node(), in a form type checkers narrow on
            loc = obj.location
            _, box = grid.members(np.array([loc.x]), np.array([loc.y]))
            for b in box.tolist():
                _add(found.node_boxes, obj.id, b)
                tagged[obj.id] = (loc.lon, loc.lat, dict(obj.tags), _meta(obj))
        elif isinstance(obj, osmium.osm.Way):
            refs, xs, ys = [], [], []
            for nr in obj.nodes:
                refs.append(nr.ref)
                xs.append(nr.x)
                ys.append(nr.y)
            point, box = grid.members(np.array(xs), np.array(ys))
            if box.size:
                for p, b in zip(point.tolist(), box.tolist()):
                    _add(found.node_boxes, refs[p], b)
                found.take_way(obj, _boxes_of(box.tolist()))
        else:
            found.take_relation(obj)
    found.reads += 1
    order.retake_relations(found)
    missing = found.missing_members() if complete else {}
    if missing:
        tracker = osmium.IdTracker()
        for way_id in missing:
            tracker.add_way(way_id)
        for way in osmium.FileProcessor(str(src), osmium.osm.WAY).with_filter(tracker.id_filter()):
            found.take_way(way, missing[way.id])
        found.reads += 1
    needed = found.needed_nodes()
    for group in extracts.groups():
        with extracts.open(group, found):
            for node_id in sorted(needed):
                boxes = [b for b in _each(needed[node_id]) if b in group]
                if not boxes:
                    continue
                if node_id in tagged:
                    lon, lat, tags, meta = tagged[node_id]
                    node = Node(id=node_id, location=(lon, lat), tags=tags, **_meta_attrs(meta))
                else:
                    try:
                        loc = locations.get(node_id)
                    except KeyError:
                        continue  # referenced, but not in the file
                    if not loc.valid():
                        continue
                    node = Node(id=node_id, location=(loc.lon, loc.lat))
                for b in boxes:
                    extracts.add_node(b, node)
    return found.reads
