"""Step 1 of the build-out year: lots and buildings a street now lies on are demolished, and the
surviving lots find their block again (module docstring of
:mod:`osm_expand.engine.buildout.year`).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.engine.buildout.memory import LotState
from osm_expand.engine.buildout.streets import _buildings_hit, _lots_hit, _relabel
from osm_expand.engine.buildout.work import _Year


def _demolish(work: _Year, *, check: bool = True) -> set[int]:
    """Step 1 and the block matching of step 2; returns the indices of blocks that lost lots.

    With ``check`` False (the streets are last year's) nothing can have come
    under a street since, and only the block matching runs.
    """
    streets, states = work.streets, work.states
    order = sorted(states)
    polys = np.array([states[k].lot.polygon for k in order], dtype=object)
    recent = streets.only_recent() if check else streets
    crossed = _lots_hit(polys, recent, work.memory.options.street_overlap) if check \
        else np.zeros(len(order), dtype=bool)
    within, block_tree = _lot_blocks(work, order)
    healing: set[int] = set()
    gone = 0
    changed = streets.changed
    for k, lot_id, hit, blk in zip(range(len(order)), order, crossed.tolist(), within.tolist()):
        was = states[lot_id]
        state: LotState | None = None
        if not (hit or blk < 0):  # most lots: none of their streets changed, no call to _relabel
            state = _relabel(was, streets) if changed and not changed.isdisjoint(was.streets) else was
        if state is None:
            del states[lot_id]
            gone += 1
            if work.buildings.pop(lot_id, None) is not None:
                work.count(buildings_demolished=1)
            if blk >= 0:
                healing.add(blk)
            elif work.blocks:  # outside every block: heal the block its land now lies in, if any
                healing.update(block_tree().query(polys[k], predicate="intersects").tolist())
            continue
        states[lot_id] = state
        work.lot_block[lot_id] = blk
    work.count(lots_demolished=gone)
    if not check:
        return healing
    lots_with = sorted(work.buildings)
    bpolys = np.array([work.footprint(k)[0] for k in lots_with], dtype=object)
    for lot_id, hit in zip(lots_with, _buildings_hit(bpolys, recent, work.memory.options.building_overlap).tolist()):
        if hit:
            del work.buildings[lot_id]
            work.count(buildings_demolished=1)
    return healing



def _lot_blocks(work: _Year, order: list[int]) -> tuple[NDArray[np.int64], Callable[[], shapely.STRtree]]:
    """The block each lot's point lies within (an index into ``work.blocks``, -1: none), lots in ``order``,
    and the tree over the blocks (made when first asked).

    A lot whose point was found within a block polygon that is still one of this year's blocks (the same
    object: the loop keeps the polygons of faces that did not change) lies within it alone, since the
    blocks are pairwise disjoint; only the other lots (in blocks a street changed, and lots made last
    year) are looked up in the tree (Campo Grande: a few hundred of up to 2,500 lots a year).
    """
    memo = work.memory.memo
    polys = [b.polygon for b in work.blocks]
    at = {id(p): k for k, p in enumerate(polys)}
    within = np.full(len(order), -1, dtype=np.int64)
    todo = []
    for j, lot_id in enumerate(order):
        known = memo.lot_blocks.get(lot_id)  # a lot of that id in another memory's year may lie elsewhere
        k = at.get(id(known[1]), -1) if known is not None and known[0] == work.states[lot_id].point else -1
        if k >= 0 and known is not None and polys[k] is known[1]:
            within[j] = k
        else:
            todo.append(j)
    tree: list[shapely.STRtree] = []

    def block_tree() -> shapely.STRtree:
        if not tree:
            tree.append(shapely.STRtree(np.array(polys, dtype=object)))
        return tree[0]

    if todo and polys:
        points = shapely.points(np.array([work.states[order[j]].point for j in todo]).reshape(-1, 2))
        pt, blk = block_tree().query(points, predicate="within")
        within[np.array(todo, dtype=np.int64)[pt]] = blk
    memo.lot_blocks = {lot_id: (work.states[lot_id].point, polys[k])
                       for lot_id, k in zip(order, within.tolist()) if k >= 0}
    return within, block_tree
