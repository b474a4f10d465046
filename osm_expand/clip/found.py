"""Which objects of the input an extract keeps, and in which boxes (the ways and relations found, the
nodes they need), whatever the strategy; and the order of a file not sorted as usual (:class:`_Order`)."""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import osmium

from osm_expand.errors import UnreadableInputError

# An object's boxes are one int (nearly always) or a sorted tuple of ints: far less memory than sets.

BoxesOf = int | tuple[int, ...]


def _add(table: dict[int, BoxesOf], key: int, boxes: BoxesOf) -> None:
    """Add ``boxes`` to ``table[key]``."""
    old = table.get(key)
    if old is None or old == boxes:
        table[key] = boxes
        return
    table[key] = _boxes_of({*_each(old), *_each(boxes)})


def _each(boxes: BoxesOf) -> tuple[int, ...]:
    return (boxes,) if isinstance(boxes, int) else boxes


def _boxes_of(boxes: Iterable[int]) -> BoxesOf:
    """The compact form of some boxes: the one int, or the sorted tuple of several."""
    ordered = tuple(sorted(set(boxes)))
    return ordered[0] if len(ordered) == 1 else ordered


@dataclass
class _Found:
    """The ways and relations kept, as plain values, and the boxes of every kept object."""

    ways: dict[int, tuple] = field(default_factory=dict)  # id → (refs, tags, meta)
    relations: dict[int, tuple] = field(default_factory=dict)  # id → (members, tags, meta)
    node_boxes: dict[int, BoxesOf] = field(default_factory=dict)  # nodes inside the boxes
    way_boxes: dict[int, BoxesOf] = field(default_factory=dict)
    rel_boxes: dict[int, BoxesOf] = field(default_factory=dict)
    reads: int = 0

    def take_way(self, way, boxes: BoxesOf) -> None:
        if way.id not in self.ways:
            self.ways[way.id] = ([n.ref for n in way.nodes], dict(way.tags), _meta(way))
        _add(self.way_boxes, way.id, boxes)

    def take_relation(self, rel) -> None:
        """The relation, if a member node or way is kept, in the boxes of its kept members."""
        boxes: set[int] = set()
        for m in rel.members:
            table = self.node_boxes if m.type == "n" else self.way_boxes if m.type == "w" else None
            if table is not None and m.ref in table:
                boxes.update(_each(table[m.ref]))
        if boxes:
            self.relations[rel.id] = ([(m.type, m.ref, m.role) for m in rel.members], dict(rel.tags), _meta(rel))
            self.rel_boxes[rel.id] = _boxes_of(boxes)

    def missing_members(self) -> dict[int, BoxesOf]:
        """Member ways of kept multipolygons that some of their boxes lack: way id → those boxes."""
        missing: dict[int, BoxesOf] = {}
        for rel_id, (members, tags, _) in self.relations.items():
            if tags.get("type") != "multipolygon":
                continue
            for mtype, ref, _ in members:
                if mtype == "w":
                    lack = set(_each(self.rel_boxes[rel_id])) - set(_each(self.way_boxes.get(ref, ())))
                    if lack:
                        _add(missing, ref, _boxes_of(lack))
        return missing

    def needed_nodes(self) -> dict[int, BoxesOf]:
        """Node id → the boxes it is written to: the nodes inside, and every node of a kept way."""
        needed = dict(self.node_boxes)
        for way_id, boxes in self.way_boxes.items():
            for ref in self.ways[way_id][0]:
                _add(needed, ref, boxes)
        return needed


def _meta(obj) -> tuple:
    return (obj.version, obj.timestamp, obj.changeset, obj.uid, obj.user)


class _Order:
    """Files not sorted as usual (nodes, ways, relations): relations read before the ways they hold
    were matched against too few ways, so they are read again once every way is known; a way read
    before its nodes has no location in a one-read clip, which is refused in one line."""

    def __init__(self, src: Path) -> None:
        self.src = src
        self.relation_seen = self.way_seen = self.relations_early = False

    def saw(self, obj, *, nodes_first: bool = False) -> None:
        if obj.is_relation():
            self.relation_seen = True
        elif obj.is_way():
            self.way_seen = True
            self.relations_early |= self.relation_seen
        elif nodes_first and self.way_seen:
            raise UnreadableInputError(f"{self.src}: not sorted (a node after a way); the one-pass clip needs nodes "
                                       "first: sort it (osmium sort) or use the default two-pass clip")

    def retake_relations(self, found: _Found) -> None:
        """Every relation matched again against all kept ways (one more read), if any came early."""
        if not self.relations_early:
            return
        for rel in osmium.FileProcessor(str(self.src), osmium.osm.RELATION):
            found.take_relation(rel)
        found.reads += 1
