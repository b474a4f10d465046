"""Step 4 of the build-out year: the land-use units of the year and, in the years the history
says, 002's land-use update over them (module docstring of :mod:`osm_expand.engine.buildout.year`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from osm_expand.engine.buildout.calibration import TownCalibration
from osm_expand.engine.buildout.landuse import update_land_use
from osm_expand.engine.buildout.lot_values import LotLayout, lot_layout, lot_values, relayout
from osm_expand.engine.buildout.lots import land_use
from osm_expand.engine.buildout.work import _attributes, _unit_traffic, _Units, _Year

# ---------------------------------------------------------------------------- step 4: land use


def _land_use(work: _Year) -> _Units:
    """Step 4: this year's units, their attributes and layout; the update when the history says so."""
    town, memory = work.town, work.memory
    ids = tuple(sorted(work.states))
    lots = [work.states[k] for k in ids]
    xy = np.vstack([town.unit_xy, np.array([s.point for s in lots]).reshape(-1, 2)])
    area = np.concatenate([town.unit_area, np.array([s.lot.area for s in lots])])
    water = np.concatenate([town.unit_water, np.array([s.water for s in lots])])
    green = np.concatenate([town.unit_green, np.array([s.green for s in lots])])
    attrs = _attributes(work, xy, water, green, _unit_traffic(work))
    lut = np.concatenate([memory.town_types, np.array([s.type for s in lots], dtype=np.int64)])
    lu_opts = work.history.options.land_use
    n_town = len(town.unit_xy)
    if len(lut) == 0:
        return _Units(ids, n_town, area, attrs, lut, np.zeros(0))
    if memory.layout is not None and memory.layout_ids == ids and memory.layout.n == len(lut):
        layout = replace(memory.layout, attributes=attrs)
    elif memory.layout is not None and memory.layout.n == n_town + len(memory.layout_ids):
        layout = relayout(memory.layout, _old_rows(memory.layout, memory.layout_ids, ids, xy, area), xy, area,
                          attrs, options=lu_opts)
    else:
        layout = lot_layout(xy, area, attrs, options=lu_opts)
    if work.now.land_use_update and len(lut) >= 2:
        result = update_land_use(layout, lut, types=town.types, rng=work.rng, options=lu_opts,
                                 allowed=_allowed(town, n_town, area[n_town:]))
        work.count(land_use_proposed=result.proposed, land_use_changes=int((result.lut != lut).sum()))
        lut, luv = result.lut, result.luv
    else:
        values = lot_values(layout, lut, types=town.types, options=lu_opts)
        luv = np.where(lut >= 0, values[np.arange(len(lut)), np.maximum(lut, 0)], 0.0)
    for j, k in enumerate(ids):
        t = int(lut[n_town + j])
        if t != work.states[k].type:
            work.states[k] = work.states[k].but(type=t, tried=None)
    work.memory = replace(memory, town_types=lut[:n_town].copy(), layout=layout, layout_ids=ids,
                          layout_lut=lut.copy())
    return _Units(ids, n_town, area, attrs, lut, luv)


def _old_rows(prev: LotLayout, prev_ids: tuple[int, ...], ids: tuple[int, ...], xy: NDArray[np.float64],
              area: NDArray[np.float64]) -> NDArray[np.int64]:
    """Each unit's row in last year's layout ``prev`` (whose lots were ``prev_ids``), −1 where it is new: the
    town's units, and the lots of the same id at the very same point and area (for
    :func:`~osm_expand.engine.buildout.lot_values.relayout`)."""
    n_town = prev.n - len(prev_ids)
    before, now = np.asarray(prev_ids, dtype=np.int64), np.asarray(ids, dtype=np.int64)
    lots = np.full(len(now), -1, dtype=np.int64)  # each lot's row among last year's (ids are unique)
    if len(before):
        order = np.argsort(before)
        at = order[np.minimum(np.searchsorted(before, now, sorter=order), len(before) - 1)]
        lots = np.where(before[at] == now, n_town + at, -1)
    rows = np.concatenate([np.arange(n_town, dtype=np.int64), lots])
    known = np.flatnonzero(rows >= 0)
    same = (prev.xy[rows[known]] == xy[known]).all(axis=1) & (prev.area[rows[known]] == area[known])
    rows[known[~same]] = -1
    return rows


def _allowed(town: TownCalibration, n_town: int, lot_area: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Types each unit may take, (U + L, T): the town's units any; a lot those whose lot class's
    ``min_area``..``max_area`` holds its area, so that every type's lots keep their class's bounds."""
    types = town.types
    low = np.array([town.lot_options[land_use(t.lot_size_key)].min_area for t in types])
    high = np.array([town.lot_options[land_use(t.lot_size_key)].max_area for t in types])
    fits = (lot_area[:, None] >= low[None, :]) & (lot_area[:, None] <= high[None, :])
    return np.vstack([np.ones((n_town, len(types)), dtype=bool), fits])
