"""Step 1 of the build-out year: lots and buildings a street now lies on are demolished, and the
surviving lots find their block again (module docstring of
:mod:`osm_expand.engine.buildout.year`).
"""
from __future__ import annotations

import numpy as np
import shapely

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
    block_polys = np.array([b.polygon for b in work.blocks], dtype=object)
    points = shapely.points(np.array([states[k].point for k in order]).reshape(-1, 2))
    within = np.full(len(order), -1, dtype=np.int64)
    block_tree = shapely.STRtree(block_polys) if len(block_polys) else None
    if len(order) and block_tree is not None:
        pt, blk = block_tree.query(points, predicate="within")
        within[pt] = blk
    healing: set[int] = set()
    gone = 0
    for k, lot_id, hit, blk in zip(range(len(order)), order, crossed.tolist(), within.tolist()):
        state = None if hit or blk < 0 else _relabel(states[lot_id], streets)
        if state is None:
            del states[lot_id]
            gone += 1
            if work.buildings.pop(lot_id, None) is not None:
                work.count(buildings_demolished=1)
            if blk >= 0:
                healing.add(blk)
            elif block_tree is not None:  # outside every block: heal the block its land now lies in, if any
                healing.update(block_tree.query(polys[k], predicate="intersects").tolist())
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

