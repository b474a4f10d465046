"""Steps 5–6 of the build-out year: substitution of standing buildings and new buildings on lots
near built streets, with floors and heights from the economy (module docstring of
:mod:`osm_expand.engine.buildout.year`).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.engine.buildout.calibration import size_bands
from osm_expand.engine.buildout.economy import HeightScale, lot_economy, substitute
from osm_expand.engine.buildout.footprints import place_buildings
from osm_expand.engine.buildout.lots import LandUse, land_use
from osm_expand.engine.buildout.work import _Units, _Year
from osm_expand.model import Building, Lot, Origin

# ---------------------------------------------------------------------------- step 5–6: buildings


def _economy(work: _Year, units: _Units, envelope: NDArray[np.float64], scale: HeightScale | None,
             reference_raw: NDArray[np.float64] | None = None):
    return lot_economy(units.area, envelope, units.luv, units.lut, units.attrs[:, 0], avgprice=work.now.avgprice,
                       calibration=work.town.heights, scale=scale, reference_raw=reference_raw,
                       economies=work.history.economies, rng=work.rng, options=work.history.options.economy)


def _substitute(work: _Year, units: _Units) -> None:
    """Step 5 (002 §5.4): sample replacements of the buildings on lots; replaced ones are demolished."""
    scale = work.memory.scale
    lots_with = sorted(work.buildings)
    if scale is None or not lots_with:
        return
    rows = np.array([units.row(k) for k in lots_with], dtype=np.intp)
    fp = np.array([work.footprint(k)[1] for k in lots_with])
    envelope = np.zeros(len(units.lut))
    envelope[rows] = fp
    econ = _economy(work, units, envelope, scale)
    built = np.array([work.buildings[k].year if work.buildings[k].year is not None else np.nan for k in lots_with],
                     dtype=np.float64)
    levels = np.array([work.buildings[k].levels or 0.0 for k in lots_with], dtype=np.float64)
    sub = substitute(built, econ.floors[rows] * fp, levels * fp, year=work.year, rng=work.rng,
                     options=work.history.options.economy)
    for k, replaced in zip(lots_with, sub.replaced.tolist()):
        if replaced:
            del work.buildings[k]
            work.states[k] = work.states[k].but(tried=None)
            work.count(buildings_demolished=1)  # a replacement built below turns this into a substitution
            work.substituted.add(k)


def _build(work: _Year, units: _Units) -> None:
    """Step 6: buildings on lots near built streets, with floors and heights from the economy."""
    town = work.town
    built_ids = work.streets.built_ids
    types = town.types
    classes = [land_use(t.lot_size_key) for t in types]
    cands, keys = [], []
    for k in sorted(work.states):
        if k in work.buildings:
            continue
        state = work.states[k]
        cls = classes[state.type]
        if not town.footprint_options[cls].build:
            continue
        front = tuple(s for s in state.streets if s in built_ids)
        if not front:
            continue
        key = (state.type, front)
        if state.tried == key:
            continue
        cands.append(k)
        keys.append(key)
    if not cands:
        return
    lots = [replace(work.states[k].lot, land_use=classes[work.states[k].type].value) for k in cands]
    footprints = place_buildings(lots, traffic_per_street=work.traffic, built_streets=built_ids,
                                 options=_bands(work, [classes[work.states[k].type] for k in cands], classes),
                                 rng=work.rng, sizes=town.sizes,
                                 obstacles=_obstacles(work, lots), resolution=work.memory.options.resolution)
    placed = {fp.lot: fp for fp in footprints}
    for i, (k, key) in enumerate(zip(cands, keys)):
        if i not in placed:
            work.states[k] = work.states[k].but(tried=key)
    if not footprints:
        return
    rows = np.array([units.row(cands[fp.lot]) for fp in footprints], dtype=np.intp)
    envelope = np.zeros(len(units.lut))
    envelope[rows] = [fp.rectangle.area for fp in footprints]
    raw = work.memory.raw
    standing = np.array([raw[k] for k in sorted(work.buildings) if k in raw], dtype=np.float64)
    econ = _economy(work, units, envelope, None, reference_raw=standing)  # the scale of the whole stock
    work.memory = replace(work.memory, scale=econ.scale)
    raw = dict(raw)
    for fp, row in zip(footprints, rows.tolist()):
        floors = int(econ.floors[row])
        if floors <= 0:
            continue
        k = cands[fp.lot]
        ring = np.vstack([fp.rectangle.corners, fp.rectangle.corners[:1]])
        work.buildings[k] = Building(rings=(ring,), height=float(econ.height[row]), levels=float(floors),
                                     origin=Origin.ENGINE, year=work.year, land_use=types[work.states[k].type].name,
                                     lot=k)
        raw[k] = float(econ.raw[row])
        if k in work.substituted:
            work.count(buildings_substituted=1, buildings_demolished=-1)
        work.count(buildings_built=1)
    work.memory = replace(work.memory, raw=raw)


def _bands(work: _Year, candidates: Sequence[LandUse], classes: Sequence[LandUse]) -> dict:
    """Footprint options with this year's size bands (:func:`~osm_expand.engine.buildout.calibration.size_bands`).

    The bands are stacked by the buildings standing and about to be built,
    per lot class, plus ``band_prior`` buildings in the expected shares, so
    that the generated buildings together keep the town's footprint
    distribution while a small year's few keep the expected bands.
    """
    town, opts = work.town, work.memory.options
    if not (town.sizes.count and work.memory.calibration.size_bands):
        return dict(town.footprint_options)
    counts = {c: opts.band_prior * v for c, v in town.building_shares.items()}
    index = {t.name: k for k, t in enumerate(town.types)}
    for b in work.buildings.values():
        k = index.get(b.land_use or "")
        if k is not None:
            counts[classes[k]] = counts.get(classes[k], 0.0) + 1.0
    for c in candidates:
        counts[c] = counts.get(c, 0.0) + 1.0
    return size_bands(counts, town.footprint_options, overlap=work.memory.calibration.band_overlap)


def _obstacles(work: _Year, lots: Sequence[Lot]) -> list[shapely.Geometry]:
    """What no new building may touch near these lots: carriageways, the town's buildings (as the XML draws
    them), the generated buildings standing."""
    polys = np.array([lot.polygon for lot in lots], dtype=object)
    streets, memory = work.streets, work.memory
    _, cw = streets.carriageway_tree.query(polys, predicate="intersects")
    out = streets.carriageways[np.unique(cw)].tolist()
    if len(memory.town.outlines):
        _, near = memory.outline_tree.query(polys, predicate="intersects")
        out.extend(memory.town.outlines[np.unique(near)].tolist())
    mine = sorted(work.buildings)
    if mine:
        footprints = np.array([work.footprint(k)[0] for k in mine], dtype=object)
        near = np.unique(shapely.STRtree(footprints).query(polys, predicate="intersects")[1])
        out.extend(footprints[near].tolist())
    return out
