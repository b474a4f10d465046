"""Writing the extracts: nodes streamed in as read, then each box's ways and relations, sorted; each
extract under a temporary name, renamed when whole."""
from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

import osmium
from osmium.osm.mutable import Relation, Way

from osm_expand.clip.boxes import Box
from osm_expand.clip.found import BoxesOf, _each, _Found


class _Extracts:
    """The extracts being written: nodes streamed in as read, then each box's ways and relations, sorted.

    Every extract is written to a temporary name and renamed when whole; a
    box that received no node inside it is not written at all.
    """

    #: extracts open at once (each a file and a 64 kB buffer); more boxes take more node reads
    MAX_OPEN = 128

    def __init__(self, paths: list[Path], boxes: list[Box]):
        self.paths, self.boxes = paths, boxes
        self.counts: dict[int, dict[str, int]] = {}
        self.writers: dict[int, osmium.SimpleWriter] = {}
        self.nodes: dict[int, int] = {}
        self.pool = osmium.io.ThreadPool(1, 8)

    def groups(self) -> list[set[int]]:
        limit = self.MAX_OPEN
        with contextlib.suppress(ValueError, OSError):
            import resource

            soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
            if soft > 0:
                limit = max(1, min(limit, (soft - 64) // 2))
        ks = list(range(len(self.paths)))
        return [set(ks[i:i + limit]) for i in range(0, len(ks), limit)]

    def add_node(self, k: int, node) -> None:
        self.writers[k].add_node(node)
        self.nodes[k] += 1

    @contextlib.contextmanager
    def open(self, group: set[int], found: _Found) -> Iterator[None]:
        tmp = {k: self.paths[k].with_name(f".{self.paths[k].name[:-len('.osm.pbf')]}.part.osm.pbf") for k in group}
        try:
            for k in sorted(group):
                w, s, e, n = self.boxes[k]
                header = osmium.io.Header()
                header.add_box(osmium.osm.Box(osmium.osm.Location(w, s), osmium.osm.Location(e, n)))
                header.set("generator", "osm-expand clip")
                header.set("sorting", "Type_then_ID")
                self.writers[k] = osmium.SimpleWriter(str(tmp[k]), bufsz=64 * 1024, header=header, overwrite=True,
                                                      thread_pool=self.pool)
                self.nodes[k] = 0
            yield
            inside = {b for boxes in found.node_boxes.values() for b in _each(boxes)} & group
            ways = _by_box(found.way_boxes, inside)
            relations = _by_box(found.rel_boxes, inside)
            for k in sorted(group):
                writer = self.writers.pop(k)
                for way_id in ways.get(k, []):
                    refs, tags, meta = found.ways[way_id]
                    writer.add_way(Way(id=way_id, nodes=refs, tags=tags, **_meta_attrs(meta)))
                for rel_id in relations.get(k, []):
                    members, tags, meta = found.relations[rel_id]
                    writer.add_relation(Relation(id=rel_id, members=members, tags=tags, **_meta_attrs(meta)))
                writer.close()
                if k in inside:
                    os.replace(tmp[k], self.paths[k])
                    self.counts[k] = {"nodes": self.nodes[k], "ways": len(ways.get(k, [])),
                                      "relations": len(relations.get(k, []))}
                else:
                    tmp[k].unlink(missing_ok=True)
        finally:
            for writer in self.writers.values():
                writer.close()
            self.writers.clear()
            for path in tmp.values():
                path.unlink(missing_ok=True)


def _by_box(table: dict[int, BoxesOf], boxes: set[int]) -> dict[int, list[int]]:
    """Box → the ids filed under it, ascending."""
    out: dict[int, list[int]] = {}
    for key in sorted(table):
        for b in _each(table[key]):
            if b in boxes:
                out.setdefault(b, []).append(key)
    return out


def _meta_attrs(meta: tuple) -> dict:
    """The metadata the object has (a missing timestamp reads as 1970, a missing version as 0)."""
    version, timestamp, changeset, uid, user = meta
    attrs = {"version": version, "changeset": changeset, "uid": uid, "user": user,
             "timestamp": timestamp if timestamp is not None and timestamp.year > 1970 else None}
    return {k: v for k, v in attrs.items() if v}
