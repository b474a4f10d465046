"""One whole neighbourhood of the town, transplanted onto the site (:attr:`PatchOptions.transplant`).

The quilt (cells, patches, seams, perimeter streets) cuts a neighbourhood
into cells and stitches them back: every rule on its joints repaired damage
the cutting did (issue 20: Krems' district read as a scribble of seam jogs,
perimeter zig-zags and hooks). A real neighbourhood already has its town's
density, dead ends, blocks and straight streets, so here one is copied whole:

1. **Fit.** For each of the most typical neighbourhoods (the ranked patch
   centres, at the site's size; :data:`TRIED`), a few turns (none; the one
   that lays its grid along the town's streets around the site; the one
   along the free land's long axis; each plus quarter turns) and shifts of
   its centre by whole raster cells on a grid within half the site's size
   (:data:`SHIFTS`) are scored, all shifts of a turn at once (a
   correlation, :class:`_Board`), on
   a raster of the free land: the street length landing on free land (counted up to
   a cap) plus :data:`JUNCTION_WEIGHT` spacings per junction. Each
   neighbourhood's best placement (placed where its streets lie nearest the
   town) is then judged on what survives steps 2-3: of those whose district
   lands within :data:`CLOSE_ENOUGH` of the target length, the most typical
   (the first ranked) wins; if none does, the nearest miss. Judged on the
   length landing before the cutting, the fit took the neighbourhood that
   filled the raster best: Andorra's dense straight valley floor, and on
   Monaco's narrow slope a placement that lost nearly half its streets to
   the cut-back (its density below range on 3 seeds of 5). Of those near the
   target, the best fit is again the one that fills the raster best, a
   straight grid: an era of the engine's years on Andorra (seed 1) copied
   its valley floor whole (circuity 1.0, 10 measures off of 14), where the
   most typical one is off on 3.
2. **Clip.** The best placement's streets are clipped to the free land. A
   street the clip cut within the joining step's reach of the town (two
   spacings, :data:`~synth.patches.topology.JOIN_REACH`) runs on straight to
   the first street ahead, of the town or of the district, meeting it in a
   tee (:func:`~synth.patches.seams._tees`); every other cut street is cut
   back to its last junction, once (:func:`_cut_back`): no perimeter street,
   no seam links.
3. **Pieces and dead ends.** Fragments and pieces far from the rest and the
   town go, as in the quilt (:func:`~synth.patches.topology._keep_joinable`,
   :func:`~synth.patches.topology._connect_pieces`,
   :func:`~synth.patches.topology._without_scraps`), and the dead ends the
   cutting left are brought to the town's neighbourhoods' dead-end and 2-core
   shares (:func:`~synth.patches.topology._fewer_dead_ends`: without it
   north-bayreuth's 2-core share was below its range on 5 seeds of 5); the
   joining step after any pattern (:mod:`osm_expand.joins`) joins what is
   left to the town.
4. **Length.** For each neighbourhood, the cap starts at :data:`OVERFILL`
   times the target length; while its district misses the target by more
   than :data:`CLOSE_ENOUGH`, the cap is scaled by the miss and its best
   placement under it placed again (:data:`REFITS`; the fit's scores are
   made once, and placing costs 0.04 s on Monaco). The neighbourhoods are
   fitted and placed in rank order, and the first whose district lands near
   the target ends the search (no later one could win).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import scipy.fft
import scipy.ndimage
import shapely
from scipy.spatial import cKDTree

from osm_expand.model import StreetNetwork, network_from_lines
from osm_expand.model.topology import dangling_chains, segment_degree, without_segments
from synth.patches.options import PatchOptions
from synth.patches.placing import _cell_pieces, _cut_ends, _main_direction, _Transform
from synth.patches.quilt import _network, _planar, _Quilt
from synth.patches.seams import _tees
from synth.patches.source import _Source
from synth.patches.topology import (
    JOIN_REACH,
    _Aim,
    _connect_pieces,
    _fewer_dead_ends,
    _keep_joinable,
    _without_scraps,
)

#: Raster cells over the free land at most (the fit's lookup table) ...
RASTER_CELLS = 100_000
#: ... each at least this share of the junction spacing across (the fit's samples lie one cell apart).
RASTER_CELL = 0.1
#: ... and at least this many metres (a street's width: finer finds nothing a street could use).
RASTER_LEAST = 6.0
#: Shifts of a neighbourhood's centre tried across the site at most (a quarter spacing apart where that is
#: fewer), rounded to whole raster cells (the correlation's step). Every cell, which the FFT scores at the
#: same cost, was tried (session 42): of the many more placements near the best, the one nearest the town is
#: another, and the engine's Andorra (seeds 0-5, it on) went from 1.3 3.3 1.0 1.3 2.7 0.3 off to 6.7 2.0 1.0
#: 2.3 4.7 3.3, its table 3.0 -> 3.4; on this grid 1.3 3.3 1.7 1.3 5.3 5.3 and 3.0 (the grid is the raster's,
#: not turned with the neighbourhood as before: other placements again).
SHIFTS = 24
#: Ranked neighbourhoods tried (the most typical first).
TRIED = 6
#: Street length on free land counts up to this many times the target: cutting the cut streets back to their
#: last junction and the dead ends' topology take about a third of it (Krems seed 0: 6.1 -> 3.9 km).
OVERFILL = 1.4
#: A junction on free land scores as this many spacings of street (a neighbourhood is its blocks).
JUNCTION_WEIGHT = 0.5
#: Fits tried at most (the cap scaled each time by how far the district missed its target length) ...
REFITS = 3
#: ... until the district's street length is within this factor of the target.
CLOSE_ENOUGH = 1.15
#: Placements whose score is within this share of the best are as good: of them the most typical
#: neighbourhood's (the first ranked), placed nearest the town, wins.
NEAR_BEST = 0.95


@dataclasses.dataclass(frozen=True)
class _Placement:
    """Where the neighbourhood goes: its move, what the fit scored it, and which of the fit's placements it is."""

    move: _Transform
    score: float
    rank: int  #: of the ranked neighbourhoods
    index: int  #: in :class:`_Fits`


@dataclasses.dataclass(frozen=True)
class _Fits:
    """Every placement of one neighbourhood the fit tried: the street length and the junctions' score it lands on
    free land, the mean distance of that length to the town, and its move: the ``turns``' entry ``turn`` (the
    neighbourhood's centre, the site's middle, the turn) with its centre moved by ``shift`` (metres; :meth:`best`
    picks and makes the move)."""

    rank: int  #: of the ranked neighbourhoods
    streets: np.ndarray
    junctions: np.ndarray
    distance: np.ndarray
    turn: np.ndarray
    shift: np.ndarray
    turns: list[_Transform]

    def best(self, cap: float) -> _Placement:
        """The placement with the most street length on free land, counted up to ``cap`` metres, and junctions;
        of those within :data:`NEAR_BEST` of it the one placed nearest the town (of equals, the first tried)."""
        score = np.minimum(self.streets, cap) + self.junctions
        good = np.flatnonzero(score >= NEAR_BEST * score.max())
        k = int(good[np.argmin(self.distance[good])])
        base = self.turns[int(self.turn[k])]
        move = _Transform(base.source_centre + self.shift[k], base.target_centre, base.turn)
        return _Placement(move, float(score[k]), self.rank, k)


@dataclasses.dataclass(frozen=True)
class _Site:
    """The free land as the fit sees it (made once for the neighbourhoods tried): its raster ready to be
    correlated (with the shifts it scores), the raster's corner and cell, the site's middle and size, how far a
    street can lie from the middle and still land (the farthest free land plus the longest shift), and the
    town's streets around."""

    board: _Board
    corner: np.ndarray
    cell: float
    middle: np.ndarray
    size: float
    radius: float
    around: np.ndarray
    free: shapely.Geometry


@dataclasses.dataclass(frozen=True)
class _Board:
    """The free-land raster ready to be correlated with a neighbourhood's samples, all shifts at once.

    A sample on cell ``(ix, iy)`` of the raster, moved by ``(dx, dy)`` cells, lands on free land where
    ``inside[iy + dy, ix + dx]`` (nothing lands off the raster); the fit sums the samples' weights that land
    so and their weights times the cell's distance to the town (looking every sample up at every shift
    took Monaco's fit 13 s of its command's 27). That sum over the samples is the correlation of the samples'
    weights, added up on a box of cells, with the raster: FFTs of one fixed size, the raster's made once,
    over the window of it the box reaches at some shift (so no shift wraps round).
    """

    shifts: np.ndarray  #: (dx, dy) cells, (m, 2)
    lo: np.ndarray  #: the samples' box's lower corner (ix, iy)
    box: tuple[int, int]  #: the samples' box of cells (rows, columns)
    fft: tuple[int, int]  #: the FFTs' shape
    spectra: np.ndarray  #: conjugate rfft2 of the raster's window and of it times the distance to the town

    @classmethod
    def of(cls, inside: np.ndarray, far: np.ndarray, lo: np.ndarray, box: tuple[int, int], shifts: np.ndarray
           ) -> _Board:
        """``inside`` free land (bool) and ``far`` each cell's distance to the town, (ny, nx); the box of
        ``box`` cells from ``lo`` holding the samples; the ``shifts`` to score."""
        first = lo + shifts.min(axis=0)  # the window's lower corner (ix, iy): grid cell first + t is window cell t
        span = shifts.max(axis=0) - shifts.min(axis=0)
        rows, cols = box[0] + int(span[1]), box[1] + int(span[0])
        fft = (scipy.fft.next_fast_len(rows, real=True), scipy.fft.next_fast_len(cols, real=True))
        window = np.zeros((2, rows, cols))
        y0, y1 = max(int(first[1]), 0), min(int(first[1]) + rows, inside.shape[0])
        x0, x1 = max(int(first[0]), 0), min(int(first[0]) + cols, inside.shape[1])
        if y0 < y1 and x0 < x1:
            part = inside[y0:y1, x0:x1]
            rows_at, cols_at = slice(y0 - first[1], y1 - first[1]), slice(x0 - first[0], x1 - first[0])
            window[:, rows_at, cols_at] = [part, np.where(part, far[y0:y1, x0:x1], 0.0)]
        return cls(shifts, lo, box, fft, scipy.fft.rfft2(window, s=fft).conj())

    def scores(self, cells: np.ndarray, weight: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For each shift: the weight of the first ``count`` samples (the streets) landing on free land, of the
        others (the junctions), and the streets' mean distance to the town there. ``cells``: the samples'
        cells (ix, iy), in the box."""
        k = cells - self.lo
        spread = np.zeros((2, *self.box))
        np.add.at(spread, (np.repeat([0, 1], [count, len(k) - count]), k[:, 1], k[:, 0]), weight)
        spectra = scipy.fft.rfft2(spread, s=self.fft)
        both = np.empty((3, *spectra.shape[1:]), dtype=spectra.dtype)
        np.multiply(spectra[0], self.spectra[0], out=both[0])
        np.multiply(spectra[1], self.spectra[0], out=both[1])
        np.multiply(spectra[0], self.spectra[1], out=both[2])
        # the window's spectra conjugate: the correlation at shift m (from the window's corner) sits at -m
        on, junction, near = scipy.fft.irfft2(both, s=self.fft)
        m = self.shifts - self.shifts.min(axis=0)
        ey, ex = -m[:, 1] % self.fft[0], -m[:, 0] % self.fft[1]
        # the FFTs' rounding leaves ~1e-10 where nothing lands: below a millimetre of street is none
        streets, junctions, far = (np.where(grid[ey, ex] > 1e-3, grid[ey, ex], 0.0) for grid in (on, junction, near))
        # to the micrometre: shifts the direct look-up scores the same stay tied (the shortest wins), not
        # ordered by the FFTs' rounding
        return streets, junctions, np.round(far / np.maximum(streets, 1e-9), 6)


def _raster(free: shapely.Geometry, pad: float, least: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The free land as a boolean raster over its bounds and ``pad`` metres round them, its cells at least
    ``least`` metres: (cells, lower-left corner, cell size in m)."""
    x0, y0, x1, y1 = np.asarray(free.bounds) + np.array([-pad, -pad, pad, pad])
    cell = max(least, float(np.sqrt((x1 - x0) * (y1 - y0) / RASTER_CELLS)))
    nx, ny = int(np.ceil((x1 - x0) / cell)) + 1, int(np.ceil((y1 - y0) / cell)) + 1
    gx, gy = np.meshgrid(x0 + (np.arange(nx) + 0.5) * cell, y0 + (np.arange(ny) + 0.5) * cell)
    shapely.prepare(free)
    inside = shapely.contains_xy(free, gx.ravel(), gy.ravel()).reshape(ny, nx)
    return inside, np.array([x0, y0]), cell


def _to_town(old: shapely.Geometry, shape: tuple[int, int], corner: np.ndarray, cell: float) -> np.ndarray:
    """Each raster cell's distance (m) to the town's streets in the raster (inf where none is)."""
    if old.is_empty:
        return np.full(shape, np.inf)
    pts, _ = _samples(np.asarray(shapely.get_parts(old)), cell / 2)
    ix = np.floor((pts[:, 0] - corner[0]) / cell).astype(np.intp)
    iy = np.floor((pts[:, 1] - corner[1]) / cell).astype(np.intp)
    ok = (ix >= 0) & (ix < shape[1]) & (iy >= 0) & (iy < shape[0])
    if not ok.any():
        return np.full(shape, np.inf)
    street = np.ones(shape, dtype=bool)
    street[iy[ok], ix[ok]] = False
    return scipy.ndimage.distance_transform_edt(street) * cell


def _samples(lines: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points along ``lines`` about ``step`` apart (the middles of equal parts), and the length each stands for."""
    lengths = shapely.length(lines)
    keep = lengths > 0
    lines, lengths = lines[keep], lengths[keep]
    if not len(lines):
        return np.zeros((0, 2)), np.zeros(0)
    n = np.maximum(np.ceil(lengths / step).astype(np.intp), 1)
    which = np.repeat(np.arange(len(lines)), n)
    k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    at = (k + 0.5) / n[which] * lengths[which]
    pts = shapely.get_coordinates(shapely.line_interpolate_point(lines[which], at))
    return pts, (lengths / n)[which]


def _turns(patch: np.ndarray, around: np.ndarray, free: shapely.Geometry, peak: float) -> list[float]:
    """The turns tried (radians): none, the patch's grid onto the town's around the site, onto the free
    land's long axis; each with its quarter turns (a grid turned by 90° is the same grid)."""
    base = [0.0]
    a = _main_direction(patch, peak) if len(patch) else None
    if a is not None:
        b = _main_direction(around, peak) if len(around) else None
        if b is not None:
            base.append(b - a)
        box = np.asarray(shapely.minimum_rotated_rectangle(free).exterior.coords)
        sides = np.diff(box[:3], axis=0)
        long = sides[int(np.argmax(np.hypot(*sides.T)))]
        base.append(float(np.arctan2(long[1], long[0])) - a)
    turns: list[float] = []
    for t in base:
        for q in range(4):
            turn = float((t + q * np.pi / 2 + np.pi) % (2 * np.pi) - np.pi)
            if all(abs((turn - u + np.pi) % (2 * np.pi) - np.pi) > np.radians(2.0) for u in turns):
                turns.append(turn)
    return turns


def _site(free: shapely.Geometry, old: shapely.Geometry, spacing: float) -> _Site:
    """The ``free`` land rasterised for the fit, with its distances to the town's streets ``old``."""
    inside, corner, cell = _raster(free, JOIN_REACH * spacing, max(RASTER_CELL * spacing, RASTER_LEAST))
    to_town = _to_town(old, inside.shape, corner, cell)
    far = np.where(np.isfinite(to_town), to_town, float(to_town[np.isfinite(to_town)].max(initial=0.0)))
    around = np.asarray(shapely.get_parts(old)) if not old.is_empty else np.empty(0, dtype=object)
    middle = np.asarray(shapely.get_coordinates(free.centroid)[0])
    if not shapely.contains_xy(free, *middle):
        middle = np.asarray(shapely.get_coordinates(free.representative_point())[0])
    # the farthest free land from the middle: streets farther than that and a shift from the centre land nowhere
    reach = float(np.hypot(*(shapely.get_coordinates(free) - middle).T).max())
    size = float(np.sqrt(free.area))
    radius = reach + size / 2
    lo = np.floor((middle - radius - corner) / cell).astype(np.intp) - 1
    hi = np.floor((middle + radius - corner) / cell).astype(np.intp) + 1
    shifts = _shifts(size / 2 / cell, max(1, int(round(max(spacing / 4, cell, size / SHIFTS) / cell))))
    board = _Board.of(inside, far, lo, (int(hi[1] - lo[1]) + 1, int(hi[0] - lo[0]) + 1), shifts)
    return _Site(board, corner, cell, middle, size, radius, around, free)


def _fit(source: _Source, rank: int, c: np.ndarray, site: _Site, spacing: float, opts: PatchOptions
         ) -> _Fits | None:
    """Placements of the ranked neighbourhood centred at ``c`` on the site's free land (see the module), each
    scored on its raster: its street length and junctions there, and how far that length lies from the town on
    average (a district grows from the town's edge, where its cut streets become joins, not in the middle of
    its field). The site's shifts of the neighbourhood are scored all of one turn at once (:class:`_Board`)."""
    disc = shapely.Point(c).buffer(site.radius, 16)
    lines = shapely.intersection(source.lines[source.tree.query(disc)], disc)
    pts, weight = _samples(np.asarray(shapely.get_parts(lines)), site.cell)
    if not len(pts):
        return None
    junctions = source.junctions[np.hypot(*(source.junctions - c).T) <= site.radius]
    count = len(pts)  # the street samples, then the junctions
    pts = np.concatenate([pts, junctions])
    weight = np.concatenate([weight, np.full(len(junctions), JUNCTION_WEIGHT * spacing)])
    patch = source.lines[source.tree.query(shapely.Point(c).buffer(site.size / 2))]
    found: list[tuple[np.ndarray, ...]] = []
    turns: list[_Transform] = []
    for turn in _turns(patch, site.around, site.free, opts.orientation_peak):
        move = _Transform(c, site.middle, turn)
        cells = np.floor((move.forward(pts) - site.corner) / site.cell).astype(np.intp)  # centred on the site
        streets, junction, distance = site.board.scores(cells, weight, count)
        found.append((streets, junction, distance, np.full(len(site.board.shifts), len(turns))))
        turns.append(move)
    streets, junction, distance, which = (np.concatenate(part) for part in zip(*found))
    # moving the streets by d cells moves the neighbourhood's centre by -R^T d cells
    moved = np.concatenate([-(site.board.shifts * site.cell) @ move.rotation for move in turns])
    return _Fits(rank, streets, junction, distance, which, moved, turns)


def _shifts(most: float, every: int) -> np.ndarray:
    """The shifts tried (cells, (dx, dy)): every ``every`` cells each way, at most ``most`` cells long, the
    shortest first (it wins ties)."""
    r = int(np.floor(most / every)) * every
    grid = np.arange(-r, r + 1, every)
    shifts = np.stack(np.meshgrid(grid, grid, indexing="ij"), axis=-1).reshape(-1, 2)
    shifts = shifts[np.hypot(*shifts.T) <= most + 1e-9]
    return shifts[np.argsort(np.hypot(*shifts.T), kind="stable")]


@dataclasses.dataclass(frozen=True)
class _Tried:
    """One neighbourhood's district: how far its length missed the target (|log| of the ratio), the network, the
    tees its cut streets made, and its placement."""

    miss: float
    net: StreetNetwork
    tees: int
    placement: _Placement


def _transplant(source: _Source, centres: np.ndarray, free: shapely.Geometry, old: shapely.Geometry,
                occupied: shapely.Geometry, target: float, spacing: float, opts: PatchOptions,
                aim: _Aim | None = None) -> tuple[StreetNetwork, dict]:
    """The district: one neighbourhood of the town fitted to the free land, clipped, its cut streets run on
    to the town or trimmed (see the module). The network and what to report.

    The fit counts street length up to a cap, first :data:`OVERFILL` times the ``target``; what the cutting
    back and the topology leave differs by town (a grid keeps nearly all, a town of hairpins on a narrow
    slope a half), so while the district misses the target by more than :data:`CLOSE_ENOUGH`, the cap is
    scaled by the miss and the best placement under it taken again (the fit itself is made once), for each
    of the ranked neighbourhoods; the one chosen is the most typical of those landing near the target (step 1)."""
    site = _site(free, old, spacing)
    tried: list[_Tried] = []
    for rank, c in enumerate(centres[:TRIED]):  # each neighbourhood's best placement, judged on what survives
        fits = _fit(source, rank, c, site, spacing, opts)
        if fits is None:
            continue
        cap, last, mine = OVERFILL * target, None, None
        for _ in range(REFITS):
            placement = fits.best(cap)
            if last is not None and placement.index == last.index:  # the cap no longer binds: the same placement
                break
            last = placement
            net, tees = _placed(source, placement.move, free, old, occupied, spacing, opts, aim)
            length = net.total_length()
            miss = abs(float(np.log(max(length, 1.0) / target)))
            if mine is None or miss < mine.miss:
                mine = _Tried(miss, net, tees, placement)
            if miss <= np.log(CLOSE_ENOUGH):
                break
            cap *= target / max(length, 1.0)
        assert mine is not None  # the loop runs at least once
        tried.append(mine)
        if mine.miss <= np.log(CLOSE_ENOUGH):  # the most typical near the target: the later ones cannot win
            break
    if not tried:
        return network_from_lines([], []), {"transplanted": None}
    close = [t for t in tried if t.miss <= np.log(CLOSE_ENOUGH)]  # in rank order: the most typical first
    best = close[0] if close else min(tried, key=lambda t: t.miss)
    net, tees, placement = best.net, best.tees, best.placement
    return net, {"transplanted": placement.rank, "turn_deg": round(float(np.degrees(placement.move.turn)), 1),
                 "fit_km": round(placement.score / 1000, 2), "tees": tees}


def _placed(source: _Source, move: _Transform, free: shapely.Geometry, old: shapely.Geometry,
            occupied: shapely.Geometry, spacing: float, opts: PatchOptions, aim: _Aim | None
            ) -> tuple[StreetNetwork, int]:
    """The town's streets moved by ``move``, clipped to the free land, run on or cut back, pieces and dead ends
    seen to (steps 2-3 of the module): the network and the tees its cut streets made."""
    near = source.tree.query(shapely.transform(free, move.back))
    moved = shapely.transform(source.lines[near], move.forward)
    copied = _cell_pieces(source, near, shapely.intersection(moved, free))
    quilt = _Quilt()
    boundary = shapely.boundary(free)
    for (k, _), (xy, cut_at) in zip(copied, _cut_ends(source, move, boundary,
                                                      [np.asarray(part.coords) for _, part in copied])):
        piece = quilt.add(xy, source.highway[k], int(source.level[k]))
        for end, prev, is_cut in ((xy[0], xy[1], cut_at[0]), (xy[-1], xy[-2], cut_at[1])):
            if is_cut:
                d = end - prev
                quilt.cut_xy.append(end)
                quilt.cut_heading.append(d / max(float(np.hypot(*d)), 1e-12))
                quilt.cut_cell.append(0)
                quilt.cut_piece.append(piece)
    reach = JOIN_REACH * spacing
    cut = np.array(quilt.cut_xy).reshape(-1, 2)
    near_town = (shapely.distance(old, shapely.points(cut)) <= reach) if len(cut) and not old.is_empty \
        else np.zeros(len(cut), dtype=bool)
    # the cut ends near the town run on to the street ahead; the others wait to be trimmed
    far = [quilt.cut_xy[i] for i in np.flatnonzero(~near_town)]
    for name in ("cut_xy", "cut_heading", "cut_cell", "cut_piece"):
        setattr(quilt, name, [getattr(quilt, name)[i] for i in np.flatnonzero(near_town)])
    tees = _tees(quilt, old, spacing, dataclasses.replace(opts, tee_reach=JOIN_REACH), occupied)
    far.extend(quilt.cut_xy)
    net = _network(quilt)
    net = _cut_back(net, np.array(far).reshape(-1, 2))
    net = _keep_joinable(net, old, spacing, opts)
    net = _connect_pieces(net, old, occupied, opts.link_reach * spacing)
    net = _without_scraps(net, opts.min_land * spacing)
    if aim is not None:  # the town's neighbourhoods' dead-end and 2-core shares, as the quilt aims at them
        net = _fewer_dead_ends(net, old, occupied, spacing, opts, aim)
    return _planar(net), tees


def _cut_back(net: StreetNetwork, cut: np.ndarray) -> StreetNetwork:
    """``net`` with each street that ends at a cut point of ``cut`` taken back to its last junction, once:
    the junction it leaves keeps its other streets (unlike :func:`~synth.patches.topology._trim`, which
    trims on until only the town's own dead ends stay, and ate a clipped neighbourhood's tree-like
    fringes whole)."""
    if not len(cut) or not len(net.xy):
        return net
    dist, idx = cKDTree(net.xy).query(cut)
    degree = segment_degree(net.streets, len(net.xy))
    leaves = sorted({int(i) for i, d in zip(idx, dist) if d < 1e-6 and degree[i] == 1})
    drop: set[tuple[int, int]] = set()
    for chain in dangling_chains(net.streets, leaves).values():
        drop |= chain
    return net.replace(streets=without_segments(net.streets, drop)) if drop else net
