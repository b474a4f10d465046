"""Steps 2–3 of the build-out year: the free land of blocks that need it, their land-use types,
subdivided into lots that face the streets (module docstring of
:mod:`osm_expand.engine.buildout.year`).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from itertools import chain

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.engine.buildout.landuse import block_types, choose_types
from osm_expand.engine.buildout.landuse_types import goal_shares
from osm_expand.engine.buildout.lot_values import distance_to
from osm_expand.engine.buildout.lots import Frontage, block_frontage, land_use, subdivide_blocks
from osm_expand.engine.buildout.memory import LotState
from osm_expand.engine.buildout.streets import _on_carriageway, _Streets
from osm_expand.engine.buildout.work import _attributes, _unit_traffic, _Year

# ---------------------------------------------------------------------------- step 2–3: new lots


def _buildable(work: _Year) -> NDArray[np.bool_]:
    """Blocks that touch a street the tool made, (B,) bool (:func:`_free_land` keeps the town's buildings' land)."""
    blocks = work.blocks
    if not blocks:
        return np.zeros(0, dtype=bool)
    sizes = np.array([len(b.street_ids) for b in blocks], dtype=np.int64)
    ids = np.fromiter(chain.from_iterable(b.street_ids for b in blocks), dtype=np.int64, count=int(sizes.sum()))
    new = np.isin(ids, work.streets.ids[work.streets.new])  # all blocks' streets at once
    owner = np.repeat(np.arange(len(blocks)), sizes)
    return np.bincount(owner, weights=new.astype(np.float64), minlength=len(blocks)) > 0


def _build_out_blocks(work: _Year, healing: set[int]) -> list[int]:
    """Steps 2–3: subdivide the free land of blocks that need it; returns the new lots' ids."""
    buildable = _buildable(work)
    keys = work.keys
    todo = [k for k in range(len(work.blocks))
            if buildable[k] and (keys[k] not in work.memory.done or k in healing)]
    done = {keys[k] for k in range(len(work.blocks)) if buildable[k] and keys[k] in work.memory.done}
    done.update(keys[k] for k in todo)
    work.memory = replace(work.memory, done=frozenset(done))
    if not todo:
        return []
    by_block: dict[int, list[int]] = {}
    for lot_id, blk in work.lot_block.items():
        by_block.setdefault(blk, []).append(lot_id)
    parts, part_block = [], []
    for k in todo:
        for part in _free_land(work, k, by_block.get(k, [])):
            parts.append(part)
            part_block.append(k)
    if not parts:
        return []
    block_type = _block_types(work, todo, by_block)
    types = work.town.types
    classes = [land_use(t.lot_size_key) for t in types]
    uses = [classes[block_type[k]].value for k in part_block]
    streets = work.streets
    frontage = _with_near_streets(parts, block_frontage(parts, list(streets.lines), streets.ids, streets.widths),
                                  streets)
    made = subdivide_blocks(parts, frontage, uses, options=work.town.lot_options, rng=work.rng)
    if not made:
        work.count(blocks=len(todo))
        return []
    polys = np.array([lot.polygon for lot in made], dtype=object)
    crossed = _on_carriageway(polys, streets)  # bridges over blocks, wider streets over the block's edge
    keep = [i for i in range(len(made)) if not crossed[i] and made[i].polygon.is_valid]
    points = shapely.get_coordinates(shapely.point_on_surface(polys[keep])) if keep else np.zeros((0, 2))
    water = distance_to(points, work.town.water)
    green = distance_to(points, work.town.green)
    new_ids = []
    next_id = work.memory.next_lot
    for j, i in enumerate(keep):
        blk = part_block[made[i].block]
        lot = made[i]
        work.states[next_id] = LotState(lot=replace(lot, block=work.blocks[blk].id), type=int(block_type[blk]),
                                        year=work.year, point=(float(points[j, 0]), float(points[j, 1])),
                                        water=float(water[j]), green=float(green[j]))
        work.lot_block[next_id] = blk
        new_ids.append(next_id)
        next_id += 1
    work.memory = replace(work.memory, next_lot=next_id)
    work.count(blocks=len(todo), lots_made=len(new_ids))
    return new_ids


def _with_near_streets(parts: Sequence[shapely.Polygon], frontage: list[list[Frontage]],
                       streets: _Streets) -> list[list[Frontage]]:
    """Each part's frontage plus the whole centre line of every street whose carriageway reaches into it.

    :func:`~osm_expand.engine.buildout.lots.block_frontage` gives each boundary edge to
    the one street nearest it, so where two streets run close (a town street
    and a grown one beside it, a wide road meeting at an acute angle) the
    shrink by the frontage alone leaves land on the other one's carriageway,
    and whole lots would be lost to :func:`_on_carriageway`. The shrink takes
    these streets too; a lot edge they leave faces them.
    """
    if not len(parts) or not len(streets.lines):
        return frontage
    half = 0.5 * streets.widths
    polys = np.array(parts, dtype=object)
    part, line = streets.line_tree.query(polys, predicate="dwithin", distance=float(half.max()))
    close = shapely.distance(polys[part], streets.lines[line]) < half[line]
    out = [list(f) for f in frontage]
    for k, j in zip(part[close].tolist(), line[close].tolist()):
        out[k].append(Frontage(line=shapely.get_coordinates(streets.lines[j]), street=int(streets.ids[j]),
                               width=float(streets.widths[j])))
    return out


def _free_land(work: _Year, block: int, lots_in: Sequence[int]) -> list[shapely.Polygon]:
    """A block's land free for new lots, in parts: minus its surviving lots, water, unbuildable land and
    the land within ``town_clearance`` of the town's buildings."""
    geom = work.blocks[block].polygon
    if lots_in:
        geom = shapely.difference(geom, shapely.union_all([work.states[k].lot.polygon for k in lots_in]))
    memory = work.memory
    taken = memory.no_build[memory.no_build_tree.query(geom, predicate="intersects")].tolist()
    clearance = memory.options.town_clearance
    near = memory.outline_tree.query(geom, predicate="dwithin", distance=clearance)
    if len(near):
        taken.extend(shapely.buffer(memory.town.outlines[near], clearance, join_style="mitre").tolist())
    if taken:
        geom = shapely.difference(geom, shapely.union_all(taken))
    geom = shapely.make_valid(geom) if not geom.is_valid else geom
    return [p for p in shapely.get_parts(geom).tolist()
            if p.geom_type == "Polygon" and p.area >= memory.options.min_region]


def _block_types(work: _Year, todo: list[int], by_block: Mapping[int, list[int]]) -> dict[int, int]:
    """The land-use type of each block to subdivide (002 §4.1): its surviving lots', else the best for it."""
    types = work.town.types
    out: dict[int, int] = {}
    fresh = []
    for k in todo:
        lots_in = by_block.get(k, [])
        if lots_in:
            area = np.array([work.states[i].lot.area for i in lots_in])
            lut = np.array([work.states[i].type for i in lots_in], dtype=np.int64)
            out[k] = int(block_types(np.zeros(len(lots_in), dtype=np.int64), area, lut, 1, len(types))[0])
        else:
            fresh.append(k)
    if not fresh:
        return out
    polys = [work.blocks[k].polygon for k in fresh]
    xy = shapely.get_coordinates(shapely.point_on_surface(np.array(polys, dtype=object)))
    area = np.array([p.area for p in polys])
    memory = work.memory
    layout = memory.layout
    if layout is None or layout.n == 0:
        chosen = _by_goals(area, types)
    else:
        traffic = np.array([sum(work.traffic.get(int(i), 0.0) for i in set(work.blocks[k].street_ids) if i >= 0)
                            for k in fresh])
        attrs = _attributes(work, xy, distance_to(xy, work.town.water), distance_to(xy, work.town.green), traffic,
                            reference=_unit_traffic(work))
        chosen = choose_types(layout, memory.layout_lut, xy, area, attrs, types=types,
                              options=work.history.options.land_use)
    out.update({k: int(t) for k, t in zip(fresh, chosen.tolist())})
    return out


def _by_goals(area: NDArray[np.float64], types: Sequence) -> NDArray[np.int64]:
    """Without any lots to compare with: each unit in turn takes the type furthest below its goal."""
    goals = goal_shares(types)
    per = np.zeros(len(goals))
    out = np.empty(len(area), dtype=np.int64)
    for q, a in enumerate(area.tolist()):
        total = per.sum() + a
        t = int(np.argmin(per / total - goals))
        out[q] = t
        per[t] += a
    return out
