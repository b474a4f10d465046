"""Everything the engine grows, judged: the fidelity verdict and the Landscape Expansion Index (issue 20).

The engine's years add streets all over the city. Issue 20 asks that they
read as the town growing: alike to the town's real neighbourhoods, and at the
edge of the built-up land rather than leapfrogging into the fields.

The verdict
-----------
The streets with origin ``engine`` (overall, and per era) are judged like a
district (:mod:`osm_expand.fidelity`): measured inside a *window* made from
them, with the ends where they meet other streets *open* (an engine street
that runs from an old street into a field and stops is a dead end; one that
joins two old streets is part of a block), against real neighbourhoods of the
town of the window's area.

*What* is judged is the street growth: the engine's major roads (003's
trade routes and bypasses, :mod:`osm_expand.engine.roads.major_roads`: built
as ``primary`` or ``trunk`` at hierarchy 0 with the era's width) are left
out of the verdict (and are "there" where new streets end on them). A
bypass is a road across the fields between neighbour cities, not a
neighbourhood: judged with the streets, Monaco's 3.4 km bypass was half the
window's area and put density, curvature, orientation entropy and the
junction shares off. Their length is reported apart (``major_roads_km``).

*Against what*: the window's pieces (the engine grows districts in several
places, each a piece of the window) are each matched by a disc of the
piece's own area, and a reference part is the union of one such disc per
piece (the discs of a union kept apart where the town has room). Stroke
length, edge length, density and orientation entropy depend on the size of
what is measured: a union of four districts judged against one disc of four
times their area was judged against streets no district of that size can
have (four of north-bayreuth's own neighbourhoods, set apart, were too dense
against one 2 km² disc, mostly fields there: 9.99 km/km² against 3.5–7.0;
in range against unions of four discs). Pieces smaller than
``min_piece_area`` count with the district nearest them
(:func:`piece_areas`). Pooled discs average out, so the ranges are narrower
than one disc's: this yardstick is stricter on the shares.

The window is the streets' land: the lines buffered ``window_close`` metres
and shrunk back to ``window_margin`` metres around them (a morphological
closing: the blocks between new streets are inside, no more than a margin of
field around them is). A disc around scattered streets would count the
fields between them and make every density look rural; the bare buffer would
leave out the blocks between the streets and make it look dense. The
margin is half the side of the town's median block (``window_margin_from_town``;
``window_margin``, 50 m, half a 100 m block, where the town has no blocks):
a real neighbourhood disc cuts the blocks on its rim at a random place, so
the field between its rim and the first street inside is on average half a
block of *that town* deep, and a window around a district-like patch then
holds what a disc of its area holds. A fixed 50 m read a small-block town's
growth too sparse (Monaco: median block 1,666 m², half its side 20 m; Andorra
32 m, Krems 46 m, north-bayreuth 53 m).
The references' streets' land (below) is closed with the same margin, so
the growth and its references are measured the same way.

Each reference part is measured on its streets' land too
(:func:`streets_land`: the discs within the window of the town's streets,
their rim kept): a disc keeps the slopes, fields or sea across it that the
growth's window leaves out (Andorra's 1.3 km² neighbourhoods: 7.9 km/km² in
their discs, 12.5 on their streets' land; the engine's districts in its
valley read 15.8 against 7.7–12.5). Only the density changes: the same
streets are inside, cut at the same rim.

The Landscape Expansion Index
-----------------------------
Liu et al. (2010), "A new landscape index for quantifying urban expansion
using multi-temporal remotely sensed data", Landscape Ecology 25:671–682: for
each *new patch*, ``LEI = 100 · A_old / A_ring`` over a ring around the
patch; *infill* when LEI > 50, *edge expansion* when 0 < LEI ≤ 50,
*outlying* when LEI = 0. Here, on vector streets instead of raster cells:

- *new patches*: the new streets buffered ``patch_buffer`` (30 m) each side,
  merged; each connected piece is a patch (as the ``pieces`` of
  :mod:`osm_expand.measures`). 30 m is about a building lot's depth: a street
  with the lots along it is the land it makes urban.
- *old land*: the built-up land before, as the site search reads it
  (:func:`osm_expand.sites.distance_maps`' ``city`` raster: street frontage
  opened so that a lone road through the fields is not town, and the
  blocks), of the city before the years (the town as mapped, the district
  and its joins; blocks recomputed so the district's count). For an era,
  the engine's earlier eras are old too: the raster's cells within
  ``old_buffer`` (30 m, a lot's depth, as the patches) of their streets.
  Streets buffered alone were the other choice; they make every rural road
  "built-up", so a comb hung on a farm track would be edge expansion. The
  raster is the project's one definition of built-up land, so this index
  follows it when the land model changes.
- *ring*: ``ring_width`` around the patch, outside it: 30 m (one lot's
  depth), at least two raster cells. Its old share is counted on the
  raster's cells whose centres lie in the ring (a cell outside the raster
  was never built).

Reported: the shares of new street length lying in infill, edge-expansion
and outlying patches (each street lies in one patch), overall (the years'
streets against the city before them) and per era.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import shapely

from osm_expand.blocks import blocks
from osm_expand.errors import InputError
from osm_expand.fidelity import (
    DEFAULT_PARTS,
    FidelityOptions,
    FidelityReport,
    TownReference,
    judge,
    real_parts,
    reference_in,
)
from osm_expand.measures import (
    LineSet,
    MeasureOptions,
    NetworkMeasures,
    measure_network,
    piece_labels,
)
from osm_expand.model import City, Origin, Street, StreetNetwork, polyline_length
from osm_expand.model.options import require_positive
from osm_expand.sites import SiteOptions, distance_maps
from osm_expand.streets_closing import WINDOW_CLOSE, WINDOW_MARGIN, block_margin, closed_land, land_in_disc

__all__ = ["BuiltUp", "GrowthFidelity", "GrowthFidelityOptions", "LandscapeExpansion", "before_the_years",
           "built_up", "city_growth_fidelity", "growth_fidelity", "growth_window", "is_major_road",
           "landscape_expansion", "piece_areas", "piece_references", "streets_land", "town_margin"]


@dataclass(frozen=True)
class GrowthFidelityOptions:
    #: m: the new streets are buffered this much, then shrunk back to ``window_margin``: the blocks between
    #: them (up to 2 × 150 m across, a large town block) fall inside the window (module docstring).
    window_close: float = WINDOW_CLOSE
    #: m: the window reaches this far beyond the outermost new streets: half a 100 m town block, as a
    #: real neighbourhood disc cuts the blocks on its rim in half on average; used as it is when
    #: ``window_margin_from_town`` is off or the town has no block.
    window_margin: float = WINDOW_MARGIN
    #: Take the margin from the town judged against (:func:`town_margin`): half the side of its median
    #: block (the square root of the median block area over two), at most ``window_close``. Why: the
    #: disc's rim is on average half a block of the town from the first street inside (module docstring).
    window_margin_from_town: bool = True
    #: m each side: a new street's patch (Liu et al.'s new urban patch): about a building lot's depth.
    patch_buffer: float = 30.0
    #: m each side: an earlier era's streets are old land this far (the same lot depth as a patch).
    old_buffer: float = 30.0
    #: m: the ring around a patch whose old share is its LEI: one lot's depth of adjacency (and at
    #: least two cells of the built-up raster, so that the ring holds cells at all).
    ring_width: float = 30.0
    #: LEI above this is infill (Liu et al. 2010).
    infill_above: float = 50.0
    #: m²: a piece of the window smaller than this gets no reference disc of its own (:func:`piece_areas`):
    #: nine blocks of 67 m, the pipeline's smallest district (``MIN_BLOCKS``) at a typical European junction
    #: spacing (Krems 67 m). A lone street's piece is about ``2·m·length + π·m²`` for the window's margin ``m``
    #: (the town's, :func:`town_margin`: half its median block's side, at most ``window_close``; 50 m without
    #: blocks; the towns' 20–53 m, Monaco to north-bayreuth): a 100–300 m street is 0.005–0.013 km² at Monaco's
    #: 20 m, 0.018–0.038 at 50 m, so below this but for a 300 m one at north-bayreuth's 53 m (0.041).
    min_piece_area: float = 40_000.0
    #: Measure each reference part on its streets' land (:func:`streets_land`), as the growth is measured on its
    #: window; False: on the discs (the yardstick before; Andorra's valley neighbourhoods of 1.3 km² read
    #: 7.9 km/km² in their discs against 12.5 on their streets' land).
    references_on_streets_land: bool = True

    def __post_init__(self) -> None:
        require_positive(self, ("window_close", "window_margin", "patch_buffer", "old_buffer", "ring_width",
                                "min_piece_area"))
        if self.window_margin > self.window_close:
            raise InputError("growth fidelity option window_margin must not exceed window_close")
        if not 0 <= self.infill_above < 100:
            raise InputError(f"growth fidelity option infill_above must be in [0, 100), got {self.infill_above!r}")


@dataclass(frozen=True, eq=False)
class LandscapeExpansion:
    """The LEI of each new patch and the shares of new street length by growth type."""

    lei: np.ndarray  #: (P,) per patch, in [0, 100]
    patch_length: np.ndarray  #: (P,) m of new street in each patch
    infill_above: float

    @property
    def infill(self) -> float:
        return self._share(self.lei > self.infill_above)

    @property
    def edge(self) -> float:
        return self._share((self.lei > 0) & (self.lei <= self.infill_above))

    @property
    def outlying(self) -> float:
        return self._share(self.lei <= 0)

    def _share(self, mask: np.ndarray) -> float:
        total = float(self.patch_length.sum())
        return float(self.patch_length[mask].sum() / total) if total > 0 else float("nan")

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: shares of new street length by type, the patch count and the length-weighted mean LEI."""
        total = float(self.patch_length.sum())
        mean = float((self.lei * self.patch_length).sum() / total) if total > 0 else float("nan")
        return {"infill": _num(self.infill), "edge": _num(self.edge), "outlying": _num(self.outlying),
                "patches": len(self.lei), "mean_lei": _num(mean), "new_length_km": round(total / 1000, 3)}


@dataclass(frozen=True, eq=False)
class GrowthFidelity:
    """The engine's street growth judged overall and per era, and its LEI (overall and per era)."""

    overall: FidelityReport | None
    per_era: dict[str, FidelityReport | None]
    lei: LandscapeExpansion
    lei_per_era: dict[str, LandscapeExpansion]
    major_roads_m: float = 0.0  #: m of the engine's major roads, left out of the verdict and the LEI

    def to_dict(self) -> dict[str, object]:
        return {"overall": _report(self.overall),
                "per_era": {era: _report(r) for era, r in self.per_era.items()},
                "lei": {**self.lei.to_dict(), "per_era": {era: v.to_dict() for era, v in self.lei_per_era.items()}},
                "major_roads_km": round(self.major_roads_m / 1000, 3)}


def _report(r: FidelityReport | None) -> dict[str, object] | None:
    return None if r is None else r.to_dict()


def _num(x: float) -> float | None:
    return None if not math.isfinite(x) else round(float(x), 4)


def growth_window(lines: Sequence[np.ndarray] | LineSet,
                  options: GrowthFidelityOptions | None = None) -> shapely.Geometry:
    """The land of ``lines``: buffered ``window_close`` m, shrunk back to ``window_margin`` (module docstring).

    The margin is ``options.window_margin`` as given: with the default options that is the fixed
    :data:`~osm_expand.streets_closing.WINDOW_MARGIN` (50 m), not the town's; only :func:`growth_fidelity`
    resolves the town's margin (:func:`town_margin`) and passes it down in its options.
    """
    opts = options or GrowthFidelityOptions()
    return closed_land(lines, opts.window_close, opts.window_margin)


def town_margin(town: NetworkMeasures, options: GrowthFidelityOptions | None = None) -> float:
    """The window margin (m) for growth judged against ``town`` (measured whole): half the side of its median
    block, ``sqrt(median block area) / 2``, at most ``window_close``; ``window_margin`` when
    ``window_margin_from_town`` is off or the town has no block (module docstring: a disc's rim lies on
    average half a block of the town beyond the first street inside it)."""
    opts = options or GrowthFidelityOptions()
    if not opts.window_margin_from_town:
        return opts.window_margin
    return block_margin(town.block_area, opts.window_close, opts.window_margin)


def meeting_points(network: StreetNetwork, mine: np.ndarray, there: np.ndarray) -> np.ndarray:
    """``(K, 2)``: the nodes shared by a street of ``mine`` and a street of ``there`` (boolean masks over
    ``network.streets``), where the growth ``mine`` is open: it goes on into what was there."""
    streets = network.streets
    flat = np.fromiter((n for s in streets for n in s.nodes), dtype=np.int64)
    owner = np.repeat(np.arange(len(streets)), [len(s.nodes) for s in streets])
    return network.xy[np.intersect1d(flat[mine[owner]], flat[there[owner]])]


def is_major_road(street: Street) -> bool:
    """Whether ``street`` is one of the engine's major roads: origin ``engine``, a class of
    :data:`osm_expand.engine.roads.major_roads.ROAD_CLASS` at hierarchy 0 with a width (the era's A(t)):
    how :mod:`osm_expand.engine.roads.major_roads` builds them and no street pattern does (their streets
    carry no width)."""
    from osm_expand.engine.roads.major_roads import ROAD_CLASS  # the engine imports much; only this is needed

    return (street.origin == Origin.ENGINE and street.hierarchy == 0 and street.width is not None
            and street.highway in ROAD_CLASS.values())


def piece_areas(window: shapely.Geometry, min_area: float) -> np.ndarray:
    """The areas (m², largest first) of the discs that stand for ``window``'s pieces: one per piece of at
    least ``min_area``, each with the area of the smaller pieces nearest to it added (all in one disc when no
    piece is that large). A lone street hung on the town is no neighbourhood: a disc of its own sausage's
    area around one of the town's junctions is a scrap of its core (Krems ``european``: eight of thirteen
    pieces under 0.05 km² put the pooled dead-end range at 0.02–0.12 against 0.08–0.21 for the town's
    neighbourhoods); counted with the district beside it, it is judged as part of that."""
    pieces = shapely.get_parts(window)
    areas = shapely.area(pieces)
    large = np.flatnonzero(areas >= min_area)
    if len(large) == 0:
        return np.array([areas.sum()]) if areas.sum() > 0 else np.zeros(0)
    small = np.flatnonzero(areas < min_area)
    total = areas[large].copy()
    if len(small):
        nearest = np.argmin(shapely.distance(pieces[small][:, None], pieces[large][None, :]), axis=1)
        np.add.at(total, nearest, areas[small])
    return np.sort(total)[::-1]


def piece_references(town_lines: Sequence[np.ndarray] | LineSet, window: shapely.Geometry, *,
                     parts: int = DEFAULT_PARTS, rng: np.random.Generator, town: NetworkMeasures | None = None,
                     options: FidelityOptions | None = None, measure_options: MeasureOptions | None = None,
                     growth_options: GrowthFidelityOptions | None = None) -> TownReference:
    """Real neighbourhoods for a growth window of several pieces: per part, one disc per piece (module docstring).

    Parameters
    ----------
    town_lines : the town as mapped.
    window : the growth's window (:func:`growth_window`); each polygon of it is a piece (:func:`piece_areas`).
    parts : reference parts.
    rng : generator; each piece draws its discs from it in turn (largest piece first), as
        :func:`osm_expand.fidelity.real_parts` (so a window of one piece gets exactly the discs of
        :func:`osm_expand.fidelity.town_reference`).

    Returns
    -------
    :class:`~osm_expand.fidelity.TownReference` whose part ``j`` is the union of each piece's ``j``-th
    densest disc, or, where it overlaps the discs already chosen for that part, the next densest that does not
    (the pieces of a window lie apart; the ``j``-th is kept when none does); each part measured on its
    streets' land within those discs (:func:`streets_land`, unless ``references_on_streets_land`` is off).

    The streets' land is closed with ``growth_options.window_margin`` as given (the fixed 50 m with the default
    options): only :func:`growth_fidelity` resolves the town's margin (:func:`town_margin`); a caller judging
    as it does passes the margin it resolved.
    """
    fopts = options or FidelityOptions()
    if parts < fopts.min_parts:
        raise InputError(f"fidelity needs at least {fopts.min_parts} real parts, got {parts}")
    opts = growth_options or GrowthFidelityOptions()
    lines = LineSet.from_lines(town_lines)
    areas = piece_areas(window, opts.min_piece_area)
    discs = [np.asarray(real_parts(lines, float(a), n=parts, rng=rng, sides=fopts.disc_sides,
                                   draw_factor=fopts.draw_factor, options=measure_options), dtype=object)
             for a in areas]
    if len(discs) == 1:
        windows = list(discs[0])
    else:
        windows = []
        turn = np.arange(parts)
        for j in range(parts):
            chosen = discs[0][j]
            for d in discs[1:]:
                order = (j + turn) % len(d)
                apart = ~shapely.intersects(d[order], chosen)
                pick = d[order[int(np.argmax(apart))]] if apart.any() else d[j % len(d)]
                chosen = shapely.union(chosen, pick)
            windows.append(chosen)
    if opts.references_on_streets_land:
        land = growth_window(lines, opts)  # once for every part: Campo Grande's whole town in 0.3 s
        windows = [streets_land(lines, w, opts, land=land) for w in windows]
    return reference_in(lines, windows, area=float(window.area), town=town, measure_options=measure_options)


def streets_land(lines: LineSet | Sequence[np.ndarray], disc: shapely.Geometry,
                 options: GrowthFidelityOptions | None = None, *, land: shapely.Geometry | None = None
                 ) -> shapely.Geometry:
    """The land of the town's streets in ``disc``: ``disc`` within the :func:`growth_window` of the town's
    streets (``land``, when the caller has it), or ``disc`` itself where no street's land is in it.

    A real neighbourhood is measured as the growth it judges is: on its streets' land. The growth's window
    leaves out what lies more than ``window_margin`` beyond its streets; a disc keeps the mountainside, the
    fields or the sea across it. Andorra, a town along a valley: its neighbourhoods of 1.3 km² hold
    7.9 km/km² in their discs and 12.5 on their streets' land (0.25 km²: 12.6 and 15.1), so the engine's
    districts in the valley read too dense against discs that climb the slopes. Where the streets fill
    the disc (a town's core) this is the disc; its rim stays the disc's, so streets cut there stay open.
    The town's land is one closing of all its streets (not of each disc's streets): the same within the disc
    but where a street just outside closes a gap at the rim, and a thirtieth of the cost on Campo Grande.
    Its margin is ``options.window_margin`` as given (the fixed 50 m with the default options; only
    :func:`growth_fidelity` resolves the town's, :func:`town_margin`).
    """
    if land is None:
        land = growth_window(lines, options)
    return land_in_disc(disc, land)


@dataclass(frozen=True, eq=False)
class BuiltUp:
    """Built-up land as a raster: ``mask`` (rows = y, cols = x) of cells ``cell`` m from ``origin``."""

    mask: np.ndarray
    origin: np.ndarray
    cell: float

    def cells_in(self, ring: shapely.Geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centres ``x``, ``y`` of the cells whose centre lies in ``ring`` (within the raster's box or
        not) and whether each is built up."""
        x0, y0, x1, y1 = ring.bounds
        c = self.cell
        i0, i1 = math.floor((x0 - self.origin[0]) / c), math.ceil((x1 - self.origin[0]) / c)
        j0, j1 = math.floor((y0 - self.origin[1]) / c), math.ceil((y1 - self.origin[1]) / c)
        jj, ii = np.mgrid[j0:j1 + 1, i0:i1 + 1]
        xs, ys = self.origin[0] + (ii + 0.5) * c, self.origin[1] + (jj + 0.5) * c
        shapely.prepare(ring)
        inside = shapely.contains_xy(ring, xs, ys)
        ii, jj, xs, ys = ii[inside], jj[inside], xs[inside], ys[inside]
        rows, cols = self.mask.shape
        within = (ii >= 0) & (ii < cols) & (jj >= 0) & (jj < rows)
        built = np.zeros(len(ii), dtype=bool)
        built[within] = self.mask[jj[within], ii[within]]
        return xs, ys, built


def built_up(city: City, site: SiteOptions | None = None) -> BuiltUp:
    """The site search's built-up raster of ``city``, its blocks recomputed from its streets (a grown
    district's blocks count); no margin is needed (beyond the streets nothing was built)."""
    with_blocks = city.replace(blocks=tuple(blocks(city.network, year=None)))
    maps = distance_maps(with_blocks, site, beyond_bounds=True)
    return BuiltUp(mask=maps.city, origin=np.asarray(maps.origin, dtype=np.float64), cell=float(maps.cell))


def before_the_years(city: City) -> City:
    """``city`` without what the engine built (streets and buildings of origin ``engine``)."""
    net = city.network
    return city.replace(network=net.replace(streets=tuple(s for s in net.streets if s.origin != Origin.ENGINE)),
                        buildings=tuple(b for b in city.buildings if b.origin != Origin.ENGINE), blocks=(), lots=())


def landscape_expansion(new_lines: Sequence[np.ndarray], built: BuiltUp, *,
                        earlier_lines: Sequence[np.ndarray] = (),
                        options: GrowthFidelityOptions | None = None) -> LandscapeExpansion:
    """Liu et al.'s (2010) LEI of new street growth against the built-up land before (module docstring).

    Parameters
    ----------
    new_lines : the new streets, each ``(n_i, 2)`` metres.
    built : the built-up land before, as a raster.
    earlier_lines : streets built since the raster was made, before these: old land within ``old_buffer``.

    Returns
    -------
    :class:`LandscapeExpansion`; no patch when there is no new street.
    """
    opts = options or GrowthFidelityOptions()
    new = LineSet.from_lines(new_lines)
    earlier = LineSet.from_lines(earlier_lines)
    if len(new.geoms) == 0:
        return LandscapeExpansion(lei=np.zeros(0), patch_length=np.zeros(0), infill_above=opts.infill_above)
    label = piece_labels(new.geoms, opts.patch_buffer)
    n_patches = int(label.max()) + 1
    buffers = shapely.buffer(new.geoms, opts.patch_buffer, quad_segs=4)
    order = np.argsort(label, kind="stable")
    bounds = np.searchsorted(label[order], np.arange(n_patches + 1))
    ring_width = max(opts.ring_width, 2.0 * built.cell)
    lei = np.zeros(n_patches)
    for p in range(n_patches):  # one small union per patch: patches are few, and each sees only land near it
        patch = shapely.union_all(buffers[order[bounds[p]:bounds[p + 1]]])
        ring = shapely.difference(shapely.buffer(patch, ring_width, quad_segs=4), patch)
        xs, ys, old = built.cells_in(ring)
        if len(xs) == 0:
            continue
        near = earlier.tree.query(ring, predicate="dwithin", distance=opts.old_buffer) if len(earlier.geoms) else []
        if len(near):
            lines = shapely.multilinestrings(earlier.geoms[near])
            shapely.prepare(lines)
            old = old | shapely.dwithin(lines, shapely.points(xs, ys), opts.old_buffer)
        lei[p] = 100.0 * old.mean()
    length = np.bincount(label, weights=shapely.length(new.geoms), minlength=n_patches)
    return LandscapeExpansion(lei=lei, patch_length=length, infill_above=opts.infill_above)


def growth_fidelity(network: StreetNetwork, town_lines: Sequence[np.ndarray] | LineSet, *, built: BuiltUp,
                    rng: np.random.Generator | int, town: NetworkMeasures | None = None,
                    parts: int = DEFAULT_PARTS, options: GrowthFidelityOptions | None = None,
                    fidelity_options: FidelityOptions | None = None,
                    measure_options: MeasureOptions | None = None) -> GrowthFidelity | None:
    """The engine's streets of ``network`` judged against ``town_lines``' real neighbourhoods, and their LEI.

    Parameters
    ----------
    network : a city's streets after the years: those with origin ``engine`` but the major roads
        (:func:`is_major_road`) are the growth, their ``era`` says when; every other street (the major
        roads too) is what was there before.
    town_lines : the town as mapped (the yardstick's neighbourhoods are drawn from it).
    built : the built-up land before the years (:func:`built_up` of :func:`before_the_years`).
    rng : generator or seed; one stream for all the references (overall first, then eras by first year).
        An era's streets are open where they meet streets built before them (the town, the district and
        earlier eras): a stub a later era extends was still a stub when its era ended.
    town : ``town_lines`` measured whole, when the caller has it.

    Returns
    -------
    :class:`GrowthFidelity`, or None when the engine built no street.
    """
    opts = options or GrowthFidelityOptions()
    mopts = measure_options or MeasureOptions()
    streets = network.streets
    engine = np.array([s.origin == Origin.ENGINE for s in streets], dtype=bool)
    if not engine.any():
        return None
    major = np.array([is_major_road(s) for s in streets], dtype=bool)
    major_m = float(sum(polyline_length(network.street_xy(s)) for s, m in zip(streets, major) if m))
    engine &= ~major  # the street growth: major roads are not neighbourhoods (module docstring)
    gen = np.random.default_rng(rng)
    town_set = LineSet.from_lines(town_lines)
    if town is None:
        town = measure_network(town_set, options=mopts, pieces=False)
    # the growth's window and its references' streets' land with one margin, the town's (module docstring)
    opts = replace(opts, window_margin=town_margin(town, opts), window_margin_from_town=False)
    lines = [network.street_xy(s) for s in streets]
    era = np.array([s.era or "" for s in streets], dtype=object)
    year = np.array([s.year if s.year is not None else -(10 ** 9) for s in streets], dtype=np.int64)
    eras = sorted(set(era[engine]), key=lambda e: (year[engine & (era == e)].min(), e))

    def picked_lines(mask: np.ndarray) -> list[np.ndarray]:
        return [lines[k] for k in np.flatnonzero(mask)]

    def judged(mine: np.ndarray, there: np.ndarray) -> FidelityReport | None:
        """``mine`` judged, open where it meets ``there`` (the streets built before it)."""
        window = growth_window(picked_lines(mine), opts)
        if window.is_empty or not window.area > 0:
            return None
        measured = measure_network(picked_lines(mine), window=window, open_points=meeting_points(network, mine, there),
                                   options=mopts)
        reference = piece_references(town_set, window, parts=parts, rng=gen, town=town, options=fidelity_options,
                                     measure_options=mopts, growth_options=opts)
        return judge(measured, reference, options=fidelity_options)

    overall = judged(engine, ~engine)
    lei = landscape_expansion(picked_lines(engine), built, options=opts)
    per_era: dict[str, FidelityReport | None] = {}
    lei_per_era: dict[str, LandscapeExpansion] = {}
    before = ~engine
    for e in eras:
        mine = engine & (era == e)
        per_era[e] = judged(mine, before)
        lei_per_era[e] = landscape_expansion(picked_lines(mine), built, earlier_lines=picked_lines(before & engine),
                                             options=opts)
        before = before | mine
    return GrowthFidelity(overall=overall, per_era=per_era, lei=lei, lei_per_era=lei_per_era, major_roads_m=major_m)


def city_growth_fidelity(city: City, *, rng: np.random.Generator | int,
                         town_lines: Sequence[np.ndarray] | LineSet | None = None,
                         options: GrowthFidelityOptions | None = None) -> GrowthFidelity | None:
    """:func:`growth_fidelity` of a city after its years, against its own town as mapped.

    Parameters
    ----------
    city : the city after the years (or one read back from the tool's output: streets keep their origin).
    rng : generator or seed for the references.
    town_lines : the yardstick's town; default ``city``'s streets of origin ``source``.

    Returns
    -------
    :class:`GrowthFidelity`, or None when the engine built no street.
    """
    net = city.network
    if not any(s.origin == Origin.ENGINE for s in net.streets):
        return None
    if town_lines is None:
        town_lines = [net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE]
    return growth_fidelity(net, town_lines, built=built_up(before_the_years(city)), rng=rng, options=options)
