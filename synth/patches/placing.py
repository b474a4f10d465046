"""Cells on the free land and the patch each takes: where a patch goes and how it is shifted to continue
the streets of the cells already filled."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
import shapely.ops

from osm_expand.model.geometry import linestrings_of
from synth.patches.options import PatchOptions
from synth.patches.quilt import _Quilt
from synth.patches.source import _lengths, _Source


def _free_land(occupied: shapely.Geometry, region: shapely.Geometry, old: shapely.Geometry, clearance: float,
               spacing: float, min_land: float = 1.0) -> shapely.Geometry:
    """The region less everything occupied and a strip along the town's streets; parts under ``min_land``
    squares of the ``spacing`` dropped, but for the largest."""
    free = shapely.make_valid(shapely.difference(region, occupied))
    if not old.is_empty:
        free = shapely.make_valid(shapely.difference(free, shapely.buffer(old, clearance)))
    parts = [p for p in shapely.get_parts(free) if p.geom_type == "Polygon" and p.area >= spacing ** 2]
    if not parts:
        return shapely.Polygon()
    largest = max(p.area for p in parts)
    return shapely.union_all([p for p in parts if p.area >= min(min_land * spacing ** 2, largest)])


def _centres(free: shapely.Geometry, old: shapely.Geometry, size: float) -> np.ndarray:
    """Cell centres over the free land, about ``size`` apart, first next to the town, then outward."""
    step = size / 4
    x0, y0, x1, y1 = free.bounds
    gx, gy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    shapely.prepare(free)
    pts = pts[shapely.contains_xy(free, pts[:, 0], pts[:, 1])]
    if not len(pts):
        return np.array([shapely.get_coordinates(free.representative_point())[0]])
    to_town = shapely.distance(old, shapely.points(pts)) if not old.is_empty else np.zeros(len(pts))
    centres = [pts[int(np.argmin(to_town))]]
    nearest = np.hypot(*(pts - centres[0]).T)
    while True:
        open_ = nearest > 0.75 * size
        if not open_.any():
            break
        i = int(np.flatnonzero(open_)[np.argmin(nearest[open_] + 0.5 * to_town[open_])])  # next to the quilt, near town
        centres.append(pts[i])
        nearest = np.minimum(nearest, np.hypot(*(pts - pts[i]).T))
    return np.array(centres)


def _cells(free: shapely.Geometry, centres: np.ndarray) -> list[shapely.Geometry]:
    """Each centre's Voronoi cell of the free land (in the centres' order)."""
    if len(centres) == 1:
        return [free]
    cells = shapely.voronoi_polygons(shapely.MultiPoint(centres), extend_to=free.envelope.buffer(1.0), ordered=True)
    # centres on a lattice are cocircular, where GEOS's Voronoi can return a self-touching cell
    cells = shapely.make_valid(shapely.get_parts(cells))
    return [shapely.intersection(c, free) for c in cells]


@dataclass(frozen=True)
class _Transform:
    """district = R (source − source_centre) + target_centre"""

    source_centre: np.ndarray
    target_centre: np.ndarray
    turn: float  #: radians

    @property
    def rotation(self) -> np.ndarray:
        c, s = np.cos(self.turn), np.sin(self.turn)
        return np.array([[c, -s], [s, c]])

    def forward(self, xy: np.ndarray) -> np.ndarray:
        return (xy - self.source_centre) @ self.rotation.T + self.target_centre

    def back(self, xy: np.ndarray) -> np.ndarray:
        return (xy - self.target_centre) @ self.rotation + self.source_centre


def _main_direction(lines: np.ndarray, peak: float) -> float | None:
    """The lines' dominant bearing mod 90° (radians): the centre of the fullest 5° bin, or None when no bin
    stands out by ``peak``."""
    coords, index = shapely.get_coordinates(lines, return_index=True)
    same = index[1:] == index[:-1]
    d = (coords[1:] - coords[:-1])[same]
    if not len(d):
        return None
    length = np.hypot(*d.T)
    bearing = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 90.0
    hist = np.bincount((bearing // 5).astype(int) % 18, weights=length, minlength=18)
    smooth = hist + 0.5 * (np.roll(hist, 1) + np.roll(hist, -1))
    k = int(np.argmax(smooth))
    if smooth[k] < peak * smooth.mean():
        return None
    return float(np.radians((k + 0.5) * 5.0))


def _turn(source: _Source, src: np.ndarray, cell: shapely.Geometry, neighbours: np.ndarray,
          size: float, peak: float) -> float:
    """Turn a patch (radians, within ±45°) so its grid runs with its neighbours' grid, when both have one.

    ``neighbours``: the streets (LineStrings) of the town and the district near the cell.
    """
    patch = source.lines[source.tree.query(shapely.Point(src).buffer(size / 2))]
    a = _main_direction(patch, peak) if len(patch) else None
    b = _main_direction(neighbours, peak) if len(neighbours) else None
    if a is None or b is None:
        return 0.0
    return float((b - a + np.pi / 4) % (np.pi / 2) - np.pi / 4)


def _place(source: _Source, patches: np.ndarray, centres: np.ndarray, cells: list[shapely.Geometry],
           quilt: _Quilt, start: int, length: float, spacing: float, old: shapely.Geometry,
           opts: PatchOptions) -> int:
    """Copy patches into cells ``start``, ... (from the town outward) until the quilt has ``length`` metres
    of street; returns how many cells are filled now."""
    half = spacing / 2
    grid = np.linspace(-half, half, opts.offsets)
    offsets = np.array([[dx, dy] for dx in grid for dy in grid])
    offsets = offsets[np.argsort(np.hypot(*offsets.T), kind="stable")]  # the smallest offset wins ties
    total = float(_lengths(quilt.xy).sum()) if quilt.xy else 0.0
    size = float(np.median([np.sqrt(c.area) for c in cells if not c.is_empty] or [spacing]))
    town = np.array(shapely.get_parts(old))
    town_tree = shapely.STRtree(town)
    filled = [c for c in cells[:start] if not c.is_empty]
    # the quilt's pieces as lines, made once each (pieces are only added here): testing every piece
    # against every cell made them again per cell, quadratic in a large district's cells
    pieces = linestrings_of(quilt.xy)
    i = start
    while i < len(centres) and total < length:
        centre, cell = centres[i], cells[i]
        i += 1
        if cell.is_empty:
            continue
        src = patches[(i - 1) % len(patches)]
        around = shapely.buffer(cell, size / 2)
        pieces = np.concatenate([pieces, linestrings_of(quilt.xy[len(pieces):])])
        nearby = np.concatenate([town[town_tree.query(around)], pieces[shapely.intersects(pieces, around)]])
        turn = _turn(source, src, cell, nearby, size, opts.orientation_peak)
        boundary = shapely.boundary(cell)
        waiting = (np.flatnonzero(shapely.distance(boundary, shapely.points(np.reshape(quilt.cut_xy, (-1, 2)))) < 1.0)
                   .tolist())
        move = _Transform(src, centre, turn)
        move = _Transform(src, centre + _best_offset(source, quilt, waiting, move, offsets, spacing), turn)
        near = source.tree.query(shapely.transform(cell, move.back))
        moved = shapely.transform(source.lines[near], move.forward)
        if total + float(shapely.length(shapely.intersection(moved, cell)).sum()) > length:
            anchor = shapely.union_all(filled) if filled else old  # fill from the side touching the rest
            if anchor.is_empty:  # no town streets near: fill from the cell's centre
                anchor = shapely.Point(centre)
            cell = _part_of(cell, moved, shapely.ops.nearest_points(cell, anchor)[0], length - total)
            boundary = shapely.boundary(cell)
        filled.append(cell)
        copied = _cell_pieces(source, near, shapely.intersection(moved, cell))
        cut = _cut_ends(source, move, boundary, [np.asarray(part.coords) for _, part in copied])
        for (k, part), (xy, cut_at) in zip(copied, cut):
            piece = quilt.add(xy, source.highway[k], int(source.level[k]))
            total += part.length
            for end, prev, is_cut in ((xy[0], xy[1], cut_at[0]), (xy[-1], xy[-2], cut_at[1])):
                if is_cut:
                    d = end - prev
                    quilt.cut_xy.append(end)
                    quilt.cut_heading.append(d / max(float(np.hypot(*d)), 1e-12))
                    quilt.cut_cell.append(i - 1)
                    quilt.cut_piece.append(piece)
    return i


def _cell_pieces(source: _Source, near: np.ndarray, clipped: np.ndarray) -> list[tuple[int, shapely.LineString]]:
    """The clipped streets of a patch as (source street, piece); a bridge or tunnel piece that would cross
    another piece of the copy (it passed over or under it in the town) is left out."""
    pieces = [(int(k), part) for k, geom in zip(near.tolist(), clipped) for part in shapely.get_parts(geom)
              if part.geom_type == "LineString" and part.length >= 1.0]
    if source.layered is None or not any(source.layered[k] for k, _ in pieces):
        return pieces
    lines = np.array([part for _, part in pieces], dtype=object)
    left, right = shapely.STRtree(lines).query(lines, predicate="crosses")
    crossing = {i for i, j in zip(left.tolist(), right.tolist()) if i != j}
    return [(k, part) for i, (k, part) in enumerate(pieces) if not (source.layered[k] and i in crossing)]


def _cut_ends(source: _Source, move: _Transform, boundary: shapely.Geometry,
              pieces: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each piece's polyline and whether its (first, last) point is a cut end: on the cell's ``boundary``,
    or where the street met one that is not copied (a motorway, a bridge) in the town.

    All the pieces' ends are measured in one call each (one GEOS distance and one tree query per end
    were a tenth of placing a cell)."""
    if not pieces:
        return []
    ends = np.array([xy[i] for xy in pieces for i in (0, -1)])
    cut = shapely.distance(boundary, shapely.points(ends)) < 1e-6
    if source.broken is not None:
        cut |= source.broken.query(move.back(ends), distance_upper_bound=1e-6)[0] < 1e-6
    return list(zip(pieces, cut.reshape(-1, 2)))


def _part_of(cell: shapely.Geometry, lines: np.ndarray, anchor: shapely.Point, need: float) -> shapely.Geometry:
    """The part of ``cell`` nearest ``anchor`` (where it touches the district so far, or the town) holding
    about ``need`` metres of ``lines``: the last cell is filled from the side that touches the rest."""
    if need <= 0:
        return shapely.Polygon()
    lo, hi = 0.0, float(np.hypot(*np.subtract(cell.bounds[2:], cell.bounds[:2])))
    for _ in range(12):
        mid = (lo + hi) / 2
        part = shapely.intersection(cell, anchor.buffer(mid))
        if float(shapely.length(shapely.intersection(lines, part)).sum()) < need:
            lo = mid
        else:
            hi = mid
    return shapely.intersection(cell, anchor.buffer(hi))


def _best_offset(source: _Source, quilt: _Quilt, waiting: list[int], move: _Transform, offsets: np.ndarray,
                 spacing: float) -> np.ndarray:
    """The offset that best continues the neighbours' cut streets into this patch's streets."""
    if not waiting:
        return np.zeros(2)
    probe = np.array([quilt.cut_xy[k] + quilt.cut_heading[k] * 0.1 * spacing for k in waiting])
    sigma = 0.1 * spacing
    best, best_score = np.zeros(2), -1.0
    # every offset's probes in one nearest query (it was one query per offset, 81 a cell); each offset's
    # score is still summed from its own row of distances, as before
    at = np.concatenate([move.back(probe - off) for off in offsets])  # each as before: the same rounding
    (which, _), near = source.tree.query_nearest(shapely.points(at), return_distance=True, all_matches=False)
    dists = np.empty(len(at))
    dists[which] = near
    for off, dist in zip(offsets, dists.reshape(len(offsets), len(probe))):
        score = float(np.exp(-0.5 * (dist / sigma) ** 2).sum())
        if score > best_score + 1e-9:
            best, best_score = off, score
    return best
