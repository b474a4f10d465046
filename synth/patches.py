"""Example patches: a district quilted from pieces of the town as mapped, its seams walked.

The growth pattern of Aliaga et al. 2008 and Nishida et al. 2016, which keep
the look of an example by copying *fragments of the real network* — their
streets, real shapes, dead ends, junction angles and blocks — and fixing the
seams between fragments procedurally; here the seams are walked with 004's
transition probability (§3.1). Seed 004 §6.2 says what its junction-cloud
walk loses (shapes, dead ends, the town's density); patches keep all three.

1. **Cells.** Cell centres are laid over the region's free land (not water,
   blocks, unbuildable land, nor within ``clearance`` of the town's streets),
   starting next to the town and growing outward ``cell_size`` junction
   spacings apart; each centre owns its Voronoi cell of the free land.
2. **How much.** A real district of the town holds open land too (fields,
   parks, water): its street density, measured on discs of the district's
   area centred on the town's streets, is the target. Cells are filled from
   the town outward until the district reaches the median of those densities;
   the rest stays open, as the town's own edges do.
3. **Patches.** Each filled cell takes the streets of a patch of the town
   around a point of its streets (drawn by length, patches of the town's
   typical local density only, so neither the dense core nor the fields),
   translated — never rotated, so the district keeps the town's orientations
   — by an offset of up to half a spacing chosen so that its streets continue
   those of the cells already filled, and clipped to the cell. Motorways,
   trunk roads, bridges and tunnels are not copied.
4. **Seams.** A street cut by a seam continues into a cut street of the
   neighbouring cell with probability
   ``exp(-½ (gap / σ_L)²) · exp(-½ (turn / σ_θ)²)``, most probable first,
   crossing nothing; one left over runs on to meet the first street ahead
   (of the district or the town) in a tee, at a fair angle; every other cut
   end meets its neighbour along the district's edge by a street that follows
   the edge a few metres inside it (a perimeter street, as real estates
   have, when the two are within ``seam_gap`` spacings along it); every
   other cut end is trimmed back to its last junction, so no street ends
   where a seam or the site's edge cut it.
5. **Pieces.** Fragments shorter than ``min_fragment`` spacings go, and so
   do pieces that can be joined neither to the rest nor to the town; each
   piece left is joined to the largest by the shortest straight street
   between their junctions and ends that crosses nothing (a district is one
   network, not a scatter); a piece still apart stays only when it holds a
   district's worth of street (``min_land`` spacings), and parts of the free
   land smaller than that are left open, but for the largest.
6. **Topology.** The district aims at its town's neighbourhoods' median
   dead-end share and 2-core share (:class:`_Aim`, measured on an even
   spread of the neighbourhoods) and at the town's median cul-de-sac
   length: cut streets stay as cul-de-sacs within that budget, too many
   dead ends run on to tees or go, too few reopen tees onto the district's
   own streets, and too little length on loops closes or prunes the longest
   cul-de-sacs. Dead ends are counted as the fidelity yardstick counts
   them: a road out on the site's outer edge runs on and is none.
"""
from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
import shapely.ops
from scipy.spatial import cKDTree

from osm_expand.model import City, Origin, StreetNetwork, chord_bends, highways, network_from_lines, polyline_length
from osm_expand.model.geometry import closest_on_segments, ray_meet
from osm_expand.model.topology import dangling_chains, segment_degree, without_segments
from simplify.example import Example
from synth.growth import Growth, NewStreet, streets_near

#: Highway classes never copied into a district: a piece of motorway in a housing estate is no street.
NOT_COPIED = highways.CORRIDORS


@dataclass(frozen=True)
class PatchOptions:
    #: Cells are at least this many junction spacings across ...
    cell_size: float = 5.0
    #: ... and the district has about this many of them: large patches keep the town's structure.
    cells: int = 3
    #: Candidate patches drawn from the town (street points, by length) ...
    candidates: int = 48
    #: ... of which those whose street density is within this factor band of the median are used.
    density_band: tuple[float, float] = (1.0, 2.5)
    #: A patch turns to match its neighbours' grid only when both have a clear main direction:
    #: the fullest 5° bin of bearings (mod 90°) holds this many times its share.
    orientation_peak: float = 2.0
    #: Discs of the district's area measured on the town for the target density.
    density_discs: int = 64
    #: Copied streets keep this many spacings from the town's streets (they meet them only in tees).
    clearance: float = 0.15
    #: A seam's cut ends this many spacings apart may continue into each other (in a smooth curve) ...
    seam_gap: float = 1.2
    #: ... if the street turns by at most this much there (degrees).
    seam_turn: float = 75.0
    #: Spread of the seam's transition probability: gap (in spacings) and bend (degrees).
    seam_sigma: tuple[float, float] = (0.4, 30.0)
    #: When set, a seam link is judged by how the street bends through it, chord by chord
    #: (:data:`BEND_STEP`), and bends no more sharply than this share of the town's own chord bends
    #: do: a link between two cut streets that do not line up is a zig-zag across the seam (Krems seed
    #: 0: a third of the district's bends over 45° were seam links). Off by default: over seeds 0-4 of
    #: the five benchmark towns neither the 90th nor the 99th percentile brought the curvature into
    #: range, and the cut streets trimmed instead cost Monaco and Krems measures (README, issue 20) ...
    seam_bend_quantile: float | None = None
    #: ... or this many degrees where the town's bends are not measured (no ``measure``).
    seam_bend: float = 20.0
    #: When set, a cut street whose trimming would leave its junction a corner sharper than this
    #: (degrees) is the first kept as a cul-de-sac (within the dead-end budget): an L where the town
    #: had a T. Off by default, for the same reason.
    corner_bend: float | None = None
    #: When set, perimeter streets run on past the cut streets they meet (which meet them in tees
    #: where they cross the edge's inset) and are pulled taut over the jagged edge of the free land
    #: (:func:`_perimeter_runs`), where by default one links each two cut ends along the edge, a U of
    #: two L-bends. Off by default: with ``seam_bend_quantile`` 0.9, over seeds 0-4 Campo Grande's
    #: curvature came into range on 5 of 5 seeds and Krems and north-bayreuth were off on fewer measures
    #: (0.8, 1.6 of 14), but Monaco's many short perimeter pieces put it off on 6.8 (edge and stroke
    #: length, circuity) and Andorra on 3.8; alone, Krems 0.4, north-bayreuth 2.2, Campo Grande 1.6,
    #: Andorra 5.4, Monaco 5.2, the curvature in range on 3, 0, 2 and 0 of 5 seeds for Krems,
    #: north-bayreuth, Campo Grande and Monaco (README, issue 20).
    perimeter_tees: bool = False
    #: A cut end left over runs on this many spacings to meet a street in a tee ...
    tee_reach: float = 0.6
    #: ... meeting it at this angle or more (degrees).
    tee_angle: float = 35.0
    #: Offsets tried per axis when fitting a patch to its placed neighbours (within half a spacing).
    offsets: int = 9
    #: A street cut by the site's edge stays (a road out of the district) when this many spacings long.
    keep_out: float = 1.0
    #: Connected pieces shorter than this many spacings are dropped.
    min_fragment: float = 2.0
    #: A piece is kept only if a street of the rest or of the town lies this many spacings from it.
    link_reach: float = 2.0
    #: Parts of the free land under this many squares of the junction spacing are left open, but for the
    #: largest: the pipeline's smallest district (``MIN_BLOCKS``); a sliver between the town's roads holds
    #: a scrap of streets, a second piece on the map, not a neighbourhood (Monaco: 0.01 km² beside 0.7).
    min_land: float = 9.0
    #: Dead ends closed for the 2-core share's sake leave at least this share of the dead ends the aimed
    #: dead-end share allows: the town's neighbourhoods' 10th percentile is about 0.3-0.5 of their
    #: median (Krems 0.03-0.05 of 0.10, Monaco 0.05-0.10 of 0.13; district_fidelity.py --table).
    dead_end_floor: float = 0.5


@dataclass(frozen=True)
class _Source:
    """The town's copyable streets: polylines, their class and level, an index, and the points where
    they met a street that is not copied (those ends are cut ends in a copy, not dead ends)."""

    lines: np.ndarray  #: shapely LineStrings
    highway: tuple[str, ...]
    level: np.ndarray
    tree: shapely.STRtree
    broken: cKDTree | None = None
    #: bridges and tunnels: copied as ordinary streets where, in the copy, they cross nothing
    layered: np.ndarray | None = None
    #: (J, 2) the town's junctions (degree ≥ 3): neighbourhoods are centred on them
    junctions: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


@dataclass
class _Quilt:
    """The district being quilted: pieces (polylines with class and level) and the cut ends still open."""

    xy: list[np.ndarray] = field(default_factory=list)
    highway: list[str] = field(default_factory=list)
    level: list[int] = field(default_factory=list)
    #: per cut end: position, heading out of the street, cell, piece
    cut_xy: list[np.ndarray] = field(default_factory=list)
    cut_heading: list[np.ndarray] = field(default_factory=list)
    cut_cell: list[int] = field(default_factory=list)
    cut_piece: list[int] = field(default_factory=list)
    #: points to insert into a piece (a tee from another street lands there)
    splits: dict[int, list[np.ndarray]] = field(default_factory=dict)
    #: the patch centres (in the town) the cells take, in order
    grid: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    #: the tees made from cut ends onto streets of the district: (cut end, foot) pairs
    tees: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)

    def add(self, xy: np.ndarray, highway: str, level: int) -> int:
        self.xy.append(xy)
        self.highway.append(highway)
        self.level.append(level)
        return len(self.xy) - 1


@dataclass(frozen=True)
class ExamplePatches:
    """The default growth pattern: patches of the town as mapped, quilted, seams walked."""

    example: Example
    options: PatchOptions = field(default_factory=PatchOptions)
    #: ``measure(lines)`` returns a function measuring those lines in a window (the caller wraps
    #: :func:`osm_expand.measures.measure_network`, as ``synth`` knows only the model); without it patches
    #: are not ranked by how typical of the town they are.
    measure: Callable | None = None
    name: str = "example"
    #: Ranked patch centres by patch size, kept between districts grown by this object (the year loop
    #: grows many from one town: ranking the town's patches is the slow part, and the town is the same).
    cache: dict = field(default_factory=dict, compare=False, repr=False)

    def grow(self, city: City, region: shapely.Geometry, rng: np.random.Generator) -> Growth:
        opts, spacing = self.options, self.example.spacing
        source = self._source(city)
        old = streets_near(city.network, region.buffer(opts.tee_reach * spacing + 1.0))
        old_geom = shapely.MultiLineString(old) if old else shapely.MultiLineString()
        occupied = city.occupied_within(region.buffer(2.0 * opts.tee_reach * spacing + 50.0))
        free = _free_land(occupied, region, old_geom, opts.clearance * spacing, spacing, opts.min_land)
        if free.is_empty or not len(source.lines):
            return Growth(streets=(), footprint=free)
        size = max(opts.cell_size * spacing, float(np.sqrt(free.area / opts.cells)))
        centres = _centres(free, old_geom, size)
        cells = _cells(free, centres)
        everything = self._source(city, everything=True)
        radius = float(np.sqrt(free.area / np.pi))
        around = _neighbourhood_points(everything, opts.density_discs, radius, rng)
        target = float(np.median(_density(everything, around, radius))) * float(free.area)
        aim = self._aim(everything, around, radius, city.network)
        bend = self._bend_limit(everything)
        key = round(float(np.log(size)) / 0.05)  # sizes within 5 % share a ranking
        if key not in self.cache:
            self.cache[key] = _candidate_patches(source, size, opts, rng, self.measure)
        patches = self.cache[key]
        best = None
        for attempt in range(ATTEMPTS):  # other patches when even every cell filled left too little
            quilt = _Quilt(grid=np.roll(patches, -attempt * len(centres), axis=0))
            result = _quilt(source, quilt, centres, cells, region, old_geom, target, spacing, opts, occupied, aim,
                            bend)
            if best is None or _misfit(result[0].total_length(), target) < _misfit(best[0].total_length(), target):
                best = result
            if result[0].total_length() >= 0.9 * target:
                break
        assert best is not None  # the loop runs at least once
        net, placed, links, tees = best
        streets = tuple(NewStreet(xy=net.street_xy(s), hierarchy=max(s.hierarchy, 0), highway=s.highway)
                        for s in net.streets)
        return Growth(streets=streets, footprint=free,
                      debug={"cells": len(centres), "filled": placed, "target_km": round(target / 1000, 2),
                             "seam_links": links, "tees": tees,
                             "target_dead_end_share": None if aim is None else round(aim.dead_end_share, 3),
                             "target_two_core_share": None if aim is None else round(aim.two_core_share, 3)})

    def _source(self, city: City, everything: bool = False) -> _Source:
        """:func:`_source` of ``city``, kept for the next district grown on the same network (the engine
        tries up to five sites a year on one city, and reading the town's streets was 5 % of a try)."""
        key = ("source", everything)
        hit = self.cache.get(key)
        if hit is not None and hit[0] is city.network:
            return hit[1]
        made = _source(city, self.example, everything=everything)
        self.cache[key] = (city.network, made)
        return made

    def _bend_limit(self, source: _Source) -> float:
        """The sharpest bend (degrees per :data:`BEND_STEP` chord) a seam link may make: the town's own
        ``seam_bend_quantile`` (``seam_bend`` without a ``measure``; inf, no limit, when it is None)."""
        opts = self.options
        if opts.seam_bend_quantile is None:
            return float("inf")
        if self.measure is None or not len(source.lines):
            return opts.seam_bend
        if "bend" not in self.cache:
            lines = [np.asarray(ln.coords) for ln in source.lines]
            hull = shapely.MultiLineString(lines).convex_hull.buffer(1.0)
            bends = np.asarray(self.measure(lines)(hull).value("curvature"))
            self.cache["bend"] = float(np.quantile(bends, opts.seam_bend_quantile)) if len(bends) else opts.seam_bend
        return self.cache["bend"]

    def _aim(self, source: _Source, centres: np.ndarray, radius: float, town: StreetNetwork) -> _Aim | None:
        """The median dead-end and 2-core shares of the town's neighbourhoods around ``centres`` (None
        without a ``measure``): what the district's own should come to."""
        if self.measure is None or not len(centres):
            return None
        if "in_window" not in self.cache:
            self.cache["in_window"] = self.measure([np.asarray(ln.coords) for ln in source.lines])
        in_window = self.cache["in_window"]
        # ``centres`` come densest first: an even spread over them is the yardstick's sample (the denser
        # half of random junctions), where the first few would be the town's core, with its fewest dead ends
        pick = np.unique(np.linspace(0, len(centres) - 1, min(DEAD_END_DISCS, len(centres))).round().astype(int))
        measured = [in_window(shapely.Point(c).buffer(radius, 16)) for c in centres[pick]]
        shares = np.array([[_level(m, "dead_end_share"), _level(m, "two_core_share")] for m in measured])
        finite = np.isfinite(shares).all(axis=1)
        if not finite.any():
            return None
        dead, core = np.median(shares[finite], axis=0)
        if "cul_de_sac" not in self.cache:
            self.cache["cul_de_sac"] = _cul_de_sac_length(town)
        return _Aim(dead_end_share=float(dead), two_core_share=float(core), cul_de_sac=self.cache["cul_de_sac"])


@dataclass(frozen=True)
class _Aim:
    """What the district's topology aims at: its town's neighbourhoods' median dead-end share (of
    junctions and dead ends) and 2-core share (of street length)."""

    dead_end_share: float
    two_core_share: float
    #: the town's median cul-de-sac (m, from its dead end back to its junction): the length kept stubs
    #: come nearest first (0: shortest first)
    cul_de_sac: float = 0.0

    def off_core_room(self, net: StreetNetwork, anchored: np.ndarray) -> float:
        """Metres of ``net`` that may still lie off its 2-core (on dead-end trees) for its 2-core share
        to stay at or above the aim's; ``anchored`` nodes (roads out, ends the joining step takes, cut
        ends still open) are never pruned, as the yardstick never prunes open ends."""
        total = net.total_length()
        return (1.0 - self.two_core_share) * total - (total - _core_length(net, anchored))


#: Neighbourhoods measured for the district's target dead-end share (spread evenly over the ranked ones).
DEAD_END_DISCS = 16
#: Times the cells are filled with other patches when the first patches left the district too sparse.
ATTEMPTS = 3


def _misfit(length: float, target: float) -> float:
    """How far a district's street length is from the target, as |log ratio| (inf for nothing)."""
    return abs(float(np.log(length / target))) if length > 0 and target > 0 else float("inf")


def _quilt(source: _Source, quilt: _Quilt, centres: np.ndarray, cells: list, region: shapely.Geometry,
           old: shapely.Geometry, target: float, spacing: float, opts: PatchOptions,
           occupied: shapely.Geometry, aim: _Aim | None = None, bend: float = float("inf")
           ) -> tuple[StreetNetwork, int, int, int]:
    """Fill cells, stitch and trim; fill more while trimming left too little. The network and counts."""
    placed, keep = 0, 1.0
    for _ in range(MAX_FILLS):
        placed = _place(source, quilt.grid, centres, cells, quilt, placed, target / keep, spacing, old, opts)
        stitched = copy.deepcopy(quilt)
        links = _walk_seams(stitched, spacing, opts, occupied, old, bend)
        tees = _tees(stitched, old, spacing, opts, occupied)
        tees += _edge_streets(stitched, region, spacing, opts, occupied, old)
        stitched_net = _network(stitched)
        edge = _outer_edge(region)
        stubs, room = _stub_budget(stitched_net, stitched, aim, old, opts.tee_reach * spacing, edge)
        net = _trim(stitched_net, stitched, edge, opts.keep_out * spacing, keep=stubs, stub=STUB_LENGTH * spacing,
                    room=room, like=aim.cul_de_sac if aim is not None else 0.0,
                    corner_bend=float("inf") if opts.corner_bend is None else opts.corner_bend)
        net = _keep_joinable(net, old, spacing, opts)
        net = _connect_pieces(net, old, occupied, opts.link_reach * spacing)
        net = _without_scraps(net, opts.min_land * spacing)
        if aim is not None:
            net = _fewer_dead_ends(net, old, occupied, spacing, opts, aim, edge)
            net = _more_dead_ends(net, stitched.tees, old, edge, spacing, opts, aim)
        net = _planar(net)
        length = net.total_length()
        if length >= target or placed >= len(centres):
            break
        keep = max(min(length / max(float(_lengths(quilt.xy).sum()), 1.0), keep), 0.05)
    return net, placed, links, tees


#: Rounds of filling more cells when trimming the seams took too much street away.
MAX_FILLS = 4


def _lengths(lines: list[np.ndarray]) -> np.ndarray:
    return np.array([float(np.hypot(*np.diff(xy, axis=0).T).sum()) for xy in lines])


def _source(city: City, example: Example, everything: bool = False) -> _Source:
    """The town's streets that may be copied (``everything``: all its streets, as the fidelity measures
    them), with the Gravelius level of the example street holding each way."""
    level_of: dict[int, int] = {}
    for s in example.network.streets:
        for osm_id in s.osm_ids:
            level_of[osm_id] = min(level_of.get(osm_id, s.hierarchy), s.hierarchy)
    deepest = max(level_of.values(), default=0) + 1
    net = city.network
    copied = [s.origin == Origin.SOURCE and (everything or s.highway not in NOT_COPIED) for s in net.streets]
    keep = [s for s, c in zip(net.streets, copied) if c]
    lines = net.street_lines()[np.asarray(copied, dtype=bool)]
    level = np.array([min((level_of.get(i, deepest) for i in s.osm_ids), default=deepest) for s in keep])
    left_out = {n for s, c in zip(net.streets, copied) if not c for n in s.nodes}
    broken = sorted({n for s in keep for n in s.nodes} & left_out)
    junctions = net.xy[segment_degree(keep, len(net.xy)) >= 3]
    return _Source(lines=lines, highway=tuple(s.highway for s in keep), level=level, tree=shapely.STRtree(lines),
                   broken=cKDTree(net.xy[broken]) if broken else None,
                   layered=np.array([s.bridge or s.tunnel or s.layer != 0 for s in keep], dtype=bool),
                   junctions=junctions)


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


def _street_points(source: _Source, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points on the town's streets, drawn uniformly by length."""
    lengths = shapely.length(source.lines)
    cum = np.cumsum(lengths)
    at = rng.uniform(0.0, cum[-1], n)
    k = np.searchsorted(cum, at, side="right").clip(max=len(cum) - 1)
    pts = shapely.line_interpolate_point(source.lines[k], at - (cum[k] - lengths[k]))
    return shapely.get_coordinates(pts)


def _density(source: _Source, centres: np.ndarray, radius: float) -> np.ndarray:
    """Street length per m² in discs around ``centres``."""
    discs = shapely.buffer(shapely.points(centres), radius)
    return np.array([shapely.length(shapely.intersection(source.lines[source.tree.query(d)], d)).sum()
                     for d in discs]) / (np.pi * radius ** 2)


def _neighbourhood_points(source: _Source, n: int, radius: float, rng: np.random.Generator) -> np.ndarray:
    """Centres of the town's *neighbourhoods*: ``2n`` junctions drawn at random, the denser half of them
    by junctions within ``radius`` kept (the fidelity yardstick's rule: on an extract that is mostly
    countryside, a random point of its streets is a country road, a dense junction is the town).
    Streets points by length when the town has too few junctions."""
    junctions = source.junctions
    if len(junctions) < 8:
        return _street_points(source, n, rng)
    drawn = junctions[rng.choice(len(junctions), size=min(2 * n, len(junctions)), replace=len(junctions) < 2 * n)]
    count = np.array([len(hit) for hit in cKDTree(junctions).query_ball_point(drawn, radius)])
    order = np.argsort(-count, kind="stable")
    return drawn[order[:max(len(drawn) // 2, 1)]]


def _target_density(source: _Source, area: float, n: int, rng: np.random.Generator) -> float:
    """The median street density (m per m²) of the town's own neighbourhoods of ``area`` m²."""
    radius = float(np.sqrt(area / np.pi))
    return float(np.median(_density(source, _neighbourhood_points(source, n, radius, rng), radius)))


#: What makes a patch typical of its town (measured on each candidate patch, in this order).
TYPICAL = ("curvature", "circuity", "edge_length", "dead_end_share", "three_way_share")


def _candidate_patches(source: _Source, size: float, opts: PatchOptions, rng: np.random.Generator,
                       measure: Callable | None = None) -> np.ndarray:
    """Patch centres on the town's streets, most typical of the town first.

    Candidates are discs on the town's streets (drawn by length) whose street
    density is within ``density_band`` of the median candidate's. Each is
    measured (:data:`TYPICAL`: the median of a distribution, or a scalar) and
    ranked by its distance to the median candidate, each measure scaled by
    the candidates' spread, so the district is made of the town's ordinary
    fabric rather than its oddities. A candidate within one patch of a better
    one goes to the back, so neighbouring cells differ.
    """
    centres = _neighbourhood_points(source, opts.candidates, size / 2, rng)
    local = _density(source, centres, size / 2)
    median = float(np.median(local))
    lo, hi = opts.density_band
    good = np.flatnonzero((local >= lo * median) & (local <= hi * median))
    if not len(good):
        good = np.argsort(np.abs(local - median))[:1]
    if measure is not None and len(good) > 1:
        in_window = measure([np.asarray(ln.coords) for ln in source.lines])
        values = np.array([[_level(in_window(shapely.Point(centres[i]).buffer(size / 2)), m) for m in TYPICAL]
                           for i in good])
        centre = np.nanmedian(values, axis=0)
        spread = np.nanpercentile(values, 75, axis=0) - np.nanpercentile(values, 25, axis=0)
        z = np.nan_to_num(np.abs(values - centre) / np.where(spread > 0, spread, 1.0), nan=3.0)
        good = good[np.argsort(np.sqrt((z ** 2).sum(axis=1)), kind="stable")]
    first: list[int] = []
    later: list[int] = []
    for i in good.tolist():
        (later if any(np.hypot(*(centres[i] - centres[j])) < size for j in first) else first).append(i)
    return centres[first + later]


def _level(measures, name: str) -> float:
    value = measures.value(name)
    if np.ndim(value):
        return float(np.median(value)) if len(value) else float("nan")
    return float(value)


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
    """The lines' dominant bearing mod 90° (radians), or None when no 5° bin stands out by ``peak``."""
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
    i = start
    while i < len(centres) and total < length:
        centre, cell = centres[i], cells[i]
        i += 1
        if cell.is_empty:
            continue
        src = patches[(i - 1) % len(patches)]
        around = shapely.buffer(cell, size / 2)
        nearby = np.concatenate([town[town_tree.query(around)],
                                 [ln for ln in map(shapely.LineString, quilt.xy) if ln.intersects(around)]])
        turn = _turn(source, src, cell, nearby, size, opts.orientation_peak)
        boundary = shapely.boundary(cell)
        waiting = [k for k, xy in enumerate(quilt.cut_xy) if shapely.distance(boundary, shapely.Point(xy)) < 1.0]
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
        for k, part in _cell_pieces(source, near, shapely.intersection(moved, cell)):
            xy = np.asarray(part.coords)
            piece = quilt.add(xy, source.highway[k], int(source.level[k]))
            total += part.length
            for end, prev in ((xy[0], xy[1]), (xy[-1], xy[-2])):
                if shapely.distance(boundary, shapely.Point(end)) < 1e-6 or _was_broken(source, move, end):
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


def _was_broken(source: _Source, move: _Transform, end: np.ndarray) -> bool:
    """Did this end meet a street that is not copied (a motorway, a bridge) in the town?"""
    return (source.broken is not None
            and source.broken.query(move.back(end[None, :]), distance_upper_bound=1e-6)[0][0] < 1e-6)


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
    for off in offsets:
        at = move.back(probe - off)
        _, dist = source.tree.query_nearest(shapely.points(at), return_distance=True, all_matches=False)
        score = float(np.exp(-0.5 * (dist / sigma) ** 2).sum())
        if score > best_score + 1e-9:
            best, best_score = off, score
    return best


class _Board:
    """What a seam link or a tee must not touch: the quilt's pieces, the links added, what is occupied."""

    def __init__(self, quilt: _Quilt, occupied: shapely.Geometry, old: shapely.Geometry | None = None):
        self.tree = shapely.STRtree([shapely.LineString(xy) for xy in quilt.xy])
        self.added: list[shapely.LineString] = []
        self.occupied, self.old = occupied, old

    def clear(self, path: np.ndarray) -> bool:
        """Does the polyline ``path`` touch streets only at its two ends, and nothing occupied?"""
        a, b = path[0], path[-1]
        line = shapely.LineString(path)
        if line.length > 2.0:
            inner = shapely.ops.substring(line, 1.0, line.length - 1.0)
            if self.occupied.intersects(inner) or (self.old is not None and self.old.intersects(inner)):
                return False
        if not line.is_simple:
            return False
        hits = self.tree.geometries.take(self.tree.query(line, predicate="intersects"))
        touches = shapely.intersection(line, [*hits, *self.added])
        ends = shapely.MultiPoint([a, b]).buffer(1e-6)
        return bool((shapely.is_empty(touches) | shapely.covers(ends, touches)).all())


def _lay(board: _Board, quilt: _Quilt, path: np.ndarray, end: int) -> None:
    """Lay ``path`` from the cut street ``end`` into the quilt, of that street's class and level, and on the
    board so that later links keep clear of it."""
    board.added.append(shapely.LineString(path))
    quilt.add(path, quilt.highway[quilt.cut_piece[end]], quilt.level[quilt.cut_piece[end]])


def _walk_seams(quilt: _Quilt, spacing: float, opts: PatchOptions, occupied: shapely.Geometry,
                old: shapely.Geometry, bend: float = float("inf")) -> int:
    """Continue cut streets across the seams, most probable transition first; returns the links made.

    A transition is judged by how the street bends on its way through the link (:func:`_link_bend`,
    read chord by chord as the town's streets are), not by the angle between the two cut streets
    alone: two parallel streets cut side by side have no angle between them, but the link that joins
    them turns across the seam and back, a zig-zag. Links bending more than ``bend`` degrees are not
    made; those cut ends run on to a tee, along the edge, or are trimmed.
    """
    if len(quilt.cut_xy) < 2:
        return 0
    xy, heading = np.array(quilt.cut_xy), np.array(quilt.cut_heading)
    cell = np.array(quilt.cut_cell)
    pairs = cKDTree(xy).query_pairs(opts.seam_gap * spacing, output_type="ndarray")
    pairs = pairs[cell[pairs[:, 0]] != cell[pairs[:, 1]]]
    if not len(pairs):
        return 0
    gap = np.hypot(*(xy[pairs[:, 1]] - xy[pairs[:, 0]]).T)
    turn = np.degrees(np.arccos(np.clip(-(heading[pairs[:, 0]] * heading[pairs[:, 1]]).sum(axis=1), -1.0, 1.0)))
    if np.isfinite(bend):
        bends = np.array([_link_bend(xy[a], heading[a], xy[b], heading[b]) for a, b in pairs.tolist()])
    else:  # no limit: 004's transition on the angle between the two cut streets
        bends = turn
    sg, st = opts.seam_sigma
    p = np.exp(-0.5 * (gap / (sg * spacing)) ** 2) * np.exp(-0.5 * (bends / st) ** 2)
    board = _Board(quilt, occupied, old)
    used = np.zeros(len(xy), dtype=bool)
    links = 0
    for k in np.argsort(-p, kind="stable").tolist():
        a, b = pairs[k]
        if used[a] or used[b] or turn[k] > opts.seam_turn or bends[k] > bend:
            continue
        if gap[k] > 1e-6:
            path = _connector(xy[a], heading[a], xy[b], heading[b])
            if not board.clear(path):
                continue
            _lay(board, quilt, path, a)
        used[a] = used[b] = True
        links += 1
    _close(quilt, used)
    return links


#: Metres between the points of a curved seam connector.
CONNECTOR_STEP = 10.0


def _connector(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> np.ndarray:
    """A smooth curve from cut end ``a`` (heading ``da`` out of its street) to ``b`` (heading ``db``):
    the cubic Bézier whose inner control points lie a third of the gap ahead of each end."""
    gap = float(np.hypot(*(b - a)))
    n = max(int(np.ceil(gap / CONNECTOR_STEP)), 1)
    if n == 1:
        return np.array([a, b])
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    p1, p2 = a + da * gap / 3, b + db * gap / 3
    pts = (1 - t) ** 3 * a + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t ** 2 * p2 + t ** 3 * b
    pts[0], pts[-1] = a, b
    return pts


#: Metres of chord over which a street's bends are read (the fidelity yardstick's curvature step,
#: ``osm_expand.measures.MeasureOptions.curvature_step``).
BEND_STEP = 20.0


def _link_bend(a: np.ndarray, da: np.ndarray, b: np.ndarray, db: np.ndarray) -> float:
    """The sharpest bend (degrees per :data:`BEND_STEP` chord) of the street that runs into cut end
    ``a`` (heading ``da`` out of it), through the seam link to ``b`` and on into ``b``'s street: read
    at the two cut ends and at every point of the link, the streets behind taken straight."""
    link = _connector(a, da, b, db)
    path = np.vstack([a - da * BEND_STEP, link, b - db * BEND_STEP])
    at = BEND_STEP + np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(link, axis=0).T))])
    return float(chord_bends(path, at, BEND_STEP).max())


def _close(quilt: _Quilt, used: np.ndarray) -> None:
    """Forget the cut ends that are no longer open."""
    keep = np.flatnonzero(~used).tolist()
    for name in ("cut_xy", "cut_heading", "cut_cell", "cut_piece"):
        values = getattr(quilt, name)
        setattr(quilt, name, [values[k] for k in keep])


def _tees(quilt: _Quilt, old: shapely.Geometry, spacing: float, opts: PatchOptions,
          occupied: shapely.Geometry) -> int:
    """Cut streets left over run on to the first street ahead, of the district or of the town; tees made."""
    board = _Board(quilt, occupied, old)
    reach = opts.tee_reach * spacing
    town = shapely.get_parts(old)
    town_tree = shapely.STRtree(town)
    used = np.zeros(len(quilt.cut_xy), dtype=bool)
    tees = 0
    for k, (p, d, own) in enumerate(zip(quilt.cut_xy, quilt.cut_heading, quilt.cut_piece)):
        ray = shapely.LineString([p + d * 1e-3, p + d * reach])
        hits = [(_meet(ray, quilt.xy[j], p, d, opts.tee_angle), j)
                for j in board.tree.query(ray, predicate="intersects").tolist() if j != own]
        hits += [(_meet(ray, np.asarray(town[i].coords), p, d, opts.tee_angle), -1)
                 for i in town_tree.query(ray, predicate="intersects").tolist()]
        met = [(meet, j) for meet, j in hits if meet is not None]
        if not met:
            continue
        (at, fair), j = min(met, key=lambda h: float(np.hypot(*(h[0][0] - p))))
        if not fair or not board.clear(np.array([p, at])):  # the first street ahead, met too flat, blocks it
            continue
        board.added.append(shapely.LineString([p, at]))
        quilt.add(np.array([p, at]), quilt.highway[own], quilt.level[own])
        if j >= 0:
            quilt.splits.setdefault(j, []).append(at)
            quilt.tees.append((p, at))
        used[k] = True
        tees += 1
    _close(quilt, used)
    return tees


def _meet(ray: shapely.LineString, line: np.ndarray, p: np.ndarray, d: np.ndarray,
          min_angle: float) -> tuple[np.ndarray, bool] | None:
    """Where ``ray`` first meets ``line``, and whether at ``min_angle`` or more; None if it does not."""
    met = ray_meet(p, d, line, ray.length + 1e-3)
    return None if met is None else (met[1], met[2] >= min_angle)


def _network(quilt: _Quilt) -> StreetNetwork:
    """The quilt as a network: tees inserted into the pieces they land on; shared points shared nodes."""
    lines = []
    for j, xy in enumerate(quilt.xy):
        extra = quilt.splits.get(j)
        if extra:
            xy = _insert_points(xy, np.array(extra))
        lines.append(xy)
    attrs = [{"highway": hw, "hierarchy": lv, "origin": Origin.GROWN} for hw, lv in zip(quilt.highway, quilt.level)]
    return network_from_lines(lines, attrs)


def _insert_points(xy: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The polyline with ``points`` (which lie on it) inserted in order along it."""
    a, b = xy[:-1], xy[1:]
    where = []
    for q in points:
        t, _, d = closest_on_segments(q[None, :], a, b)
        i = int(np.argmin(d))
        where.append((i, float(t[i]), q))
    out = []
    for i in range(len(xy)):
        out.append(xy[i])
        for _, _, q in sorted((w for w in where if w[0] == i), key=lambda w: w[1]):
            if not (np.array_equal(q, xy[i]) or (i + 1 < len(xy) and np.array_equal(q, xy[i + 1]))):
                out.append(q)
    return np.array(out)


#: A cut street this many junction spacings long or more may stay as a cul-de-sac (see :func:`_trim`).
STUB_LENGTH = 0.3


def _outer_edge(region: shapely.Geometry) -> shapely.Geometry:
    """The site's edge to the country: the outer rings of the region. A hole in it (a mapped building and
    its margin, taken land) is no way out: a street that the clip ended there is a cut street like
    any other, trimmed or kept as a cul-de-sac, not a road out."""
    rings = [poly.exterior for poly in shapely.get_parts(region) if poly.geom_type == "Polygon"]
    return shapely.MultiLineString(rings) if rings else shapely.boundary(region)


def _stub_budget(net: StreetNetwork, quilt: _Quilt, aim: _Aim | None, old: shapely.Geometry,
                 reach: float, edge: shapely.Geometry) -> tuple[int, float]:
    """How many cut streets may stay as cul-de-sacs, and how many metres they may hold together, so
    that the district's dead-end share comes to its town's neighbourhoods' and its 2-core share stays
    at or above theirs (:class:`_Aim`): the dead ends it has besides its cut ends, those on its ``edge``
    and those within ``reach`` of the town (the joining step takes them), are fewer."""
    if aim is None or not 0.0 < aim.dead_end_share < 1.0 or not len(net.xy):
        return 0, 0.0
    share = aim.dead_end_share
    degree = segment_degree(net.streets, len(net.xy))
    cut = np.zeros(len(net.xy), dtype=bool)
    loose = np.array(quilt.cut_xy).reshape(-1, 2)
    if len(loose):
        dist, idx = cKDTree(net.xy).query(loose)
        cut[idx[dist < 1e-6]] = True
    ends = np.flatnonzero((degree == 1) & ~cut)
    anchored = cut.copy()
    if len(ends):
        out = _leaves_out(net.xy[ends], old, reach, edge)
        anchored[ends[out]] = True
        ends = ends[~out]
    room = max(aim.off_core_room(net, anchored), 0.0)
    return max(int(share / (1.0 - share) * int((degree >= 3).sum())) - len(ends), 0), room


def _leaves_out(xy: np.ndarray, old: shapely.Geometry, reach: float, edge: shapely.Geometry | None) -> np.ndarray:
    """Which of the ends at ``xy`` leave the district: within ``reach`` of the town (the joining step
    joins them) or on its ``edge`` (roads out); the others are its cul-de-sacs."""
    out = np.zeros(len(xy), dtype=bool)
    if len(xy) and not old.is_empty:
        out |= shapely.distance(old, shapely.points(xy)) <= reach
    if len(xy) and edge is not None:
        out |= shapely.distance(edge, shapely.points(xy)) < ON_EDGE
    return out


def _cul_de_sac_length(town: StreetNetwork) -> float:
    """The median length (m) of the town's cul-de-sacs as mapped: from each dead end of its own
    streets back to the nearest junction (0 when it has none)."""
    mapped = [st for st in town.streets if st.origin == Origin.SOURCE]
    degree = segment_degree(mapped, len(town.xy))
    chains = dangling_chains(mapped, np.flatnonzero(degree == 1).tolist())
    lengths = [_chain_length(town, c) for c in chains.values()]
    return float(np.median(lengths)) if lengths else 0.0


def _core_length(net: StreetNetwork, anchored: np.ndarray) -> float:
    """Metres of ``net`` on its 2-core: what is left after pruning dead ends (never an ``anchored``
    node) and the ends that leaves, until none is left (the yardstick's 2-core share, in metres)."""
    seg = np.array([(a, b) for st in net.streets for a, b in zip(st.nodes[:-1], st.nodes[1:])], dtype=np.intp)
    if not len(seg):
        return 0.0
    alive = np.ones(len(seg), dtype=bool)
    while True:
        degree = np.bincount(seg[alive].ravel(), minlength=len(net.xy))
        leaf = (degree == 1) & ~anchored
        cut = alive & (leaf[seg[:, 0]] | leaf[seg[:, 1]])
        if not cut.any():
            break
        alive &= ~cut
    return float(np.hypot(*(net.xy[seg[alive, 0]] - net.xy[seg[alive, 1]]).T).sum())


def _trim(net: StreetNetwork, quilt: _Quilt, edge: shapely.Geometry, keep_out: float, *, keep: int = 0,
          stub: float = 0.0, room: float = float("inf"), like: float = 0.0,
          corner_bend: float = float("inf")) -> StreetNetwork:
    """Cut ends still open are trimmed back to their last junction, except a street of ``keep_out``
    metres or more that leaves the district at the site's ``edge`` (a road out into the country), and
    up to ``keep`` cut streets of ``stub`` metres or more ending inside the district, which stay as
    cul-de-sacs (a district whose every cut end was closed or trimmed has fewer dead ends than its
    town's neighbourhoods; a stub left where the edge cut it would stop at the field's margin),
    those nearest ``like`` metres long first (the town's own cul-de-sacs; a district of 30 m nubs has
    the town's dead-end share but not its edge lengths), and ``room`` metres of them at most (the
    length its 2-core may lose). Those whose trimming would leave their junction a corner sharper
    than ``corner_bend`` degrees (a T cut in its arm is an L) stay first: the seams cut the town's
    tees wherever they fall, and the L-bends left were the district's sharpest (Krems seed 0: 16 of
    its 28 bends over 45°), where a T with a short arm is what the town has.

    A junction whose other streets were all trimmed becomes an end itself and is trimmed in turn:
    only the town's own dead ends stay dead ends.
    """
    loose = np.array(quilt.cut_xy).reshape(-1, 2)
    if not len(loose) or not len(net.xy):
        return net
    dist, idx = cKDTree(net.xy).query(loose)
    degree = segment_degree(net.streets, len(net.xy))
    leaves = {int(i): p for i, d, p in zip(idx, dist, loose) if d < 1e-6 and degree[i] == 1}
    streets = net.streets
    while leaves:
        drop: set[tuple[int, int]] = set()
        chains = dangling_chains(streets, leaves)
        length = {leaf: _chain_length(net, chain) for leaf, chain in chains.items()}
        corner = {leaf: np.isfinite(corner_bend) and _leaves_corner(net, streets, chain) > corner_bend
                  for leaf, chain in chains.items()}
        for leaf, chain in sorted(chains.items(), key=lambda c: (not corner[c[0]], abs(length[c[0]] - like), c[0])):
            out_of_town = shapely.distance(edge, shapely.Point(leaves[leaf])) < ON_EDGE
            if out_of_town and length[leaf] >= keep_out:
                continue
            if keep > 0 and stub <= length[leaf] <= room and not out_of_town:
                keep -= 1
                room -= length[leaf]
                continue
            drop |= chain
        if not drop:
            break
        before = segment_degree(streets, len(net.xy))
        streets = without_segments(streets, drop)
        after = segment_degree(streets, len(net.xy))
        leaves = {int(n): net.xy[n] for n in np.flatnonzero((after == 1) & (before > 1))}
    return net.replace(streets=streets)


def _leaves_corner(net: StreetNetwork, streets: tuple, chain: set[tuple[int, int]]) -> float:
    """How sharply the streets left at the junction of a dangling ``chain`` turn (degrees) once it is
    trimmed, when that leaves the junction with two segments; 0 otherwise (a junction still, or none)."""
    ends = {n for seg in chain for n in seg}
    around: dict[int, list[int]] = {}
    for st in streets:
        for a, b in zip(st.nodes[:-1], st.nodes[1:]):
            if (min(a, b), max(a, b)) in chain:
                continue
            if a in ends:
                around.setdefault(a, []).append(b)
            if b in ends:
                around.setdefault(b, []).append(a)
    for node, other in around.items():
        if len(other) == 2:
            d1, d2 = net.xy[node] - net.xy[other[0]], net.xy[other[1]] - net.xy[node]
            turn = np.arctan2(d2[1], d2[0]) - np.arctan2(d1[1], d1[0])
            return float(np.degrees(abs((turn + np.pi) % (2 * np.pi) - np.pi)))
    return 0.0


def _keep_joinable(net: StreetNetwork, old: shapely.Geometry, spacing: float, opts: PatchOptions) -> StreetNetwork:
    """Drop fragments too short to be streets, and pieces far from both the rest and the town."""
    if not net.streets:
        return net
    import networkx as nx

    graph = nx.Graph()
    for k, s in enumerate(net.streets):
        graph.add_edges_from((a, b, {"street": k}) for a, b in zip(s.nodes[:-1], s.nodes[1:]))
    length = {k: float(np.hypot(*np.diff(net.street_xy(s), axis=0).T).sum()) for k, s in enumerate(net.streets)}
    parts = []
    for comp in nx.connected_components(graph):
        streets = sorted({d["street"] for _, _, d in graph.subgraph(comp).edges(data=True)})
        parts.append((sum(length[k] for k in streets), streets))
    parts.sort(key=lambda p: -p[0])
    keep: list[int] = list(parts[0][1])
    kept = [shapely.MultiLineString([net.street_xy(net.streets[k]) for k in keep])]
    for total, streets in parts[1:]:
        if total < opts.min_fragment * spacing:
            continue
        geom = shapely.MultiLineString([net.street_xy(net.streets[k]) for k in streets])
        near_rest = min(shapely.distance(geom, g) for g in kept) <= opts.link_reach * spacing
        near_town = not old.is_empty and shapely.distance(geom, old) <= opts.link_reach * spacing
        if near_rest or near_town:
            keep += streets
            kept.append(geom)
    return net.replace(streets=tuple(net.streets[k] for k in sorted(keep)))


def _connect_pieces(net: StreetNetwork, old: shapely.Geometry, occupied: shapely.Geometry,
                    reach: float) -> StreetNetwork:
    """Join each smaller piece of the district to the largest, by the shortest straight street (of at
    most ``reach`` metres) between their nodes that touches no street, nothing occupied and no other
    link on the way; pieces it cannot reach stay as they are."""
    if len(net.streets) < 2:
        return net
    from osm_expand.model.components import component_labels

    ends = np.array([(a, b) for s in net.streets for a, b in zip(s.nodes[:-1], s.nodes[1:])], dtype=np.intp)
    label = component_labels(len(net.xy), ends[:, 0], ends[:, 1])
    used = np.unique(ends)
    sizes = np.bincount(label[used], minlength=int(label.max()) + 1)
    main = int(np.argmax(sizes))
    lines = [net.street_xy(st) for st in net.streets]
    quilt = _Quilt(xy=list(lines))
    board = _Board(quilt, occupied, old)
    links: list[np.ndarray] = []
    joined = {main}
    for piece in np.argsort(-sizes, kind="stable").tolist():
        if piece in joined or sizes[piece] == 0:
            continue
        mine = used[label[used] == piece]
        rest = used[np.isin(label[used], list(joined))]
        dist, near = cKDTree(net.xy[rest]).query(net.xy[mine], k=min(3, len(rest)))
        dist, near = np.atleast_2d(dist.T).T, np.atleast_2d(near.T).T
        order = np.argsort(dist, axis=None, kind="stable")
        for flat in order[:24].tolist():
            i, j = np.unravel_index(flat, dist.shape)
            if not dist[i, j] <= reach:
                break
            path = np.array([net.xy[mine[i]], net.xy[rest[near[i, j]]]])
            if board.clear(path):
                board.added.append(shapely.LineString(path))
                links.append(path)
                joined.add(piece)
                break
    if not links:
        return net
    attrs = [{"highway": st.highway, "hierarchy": st.hierarchy, "origin": Origin.GROWN} for st in net.streets]
    attrs += [{"highway": "residential", "hierarchy": max((st.hierarchy for st in net.streets), default=0),
               "origin": Origin.GROWN}] * len(links)
    return network_from_lines(lines + links, attrs)


def _without_scraps(net: StreetNetwork, least: float) -> StreetNetwork:
    """The district less the pieces that the joining of pieces left apart from the largest and that hold
    under ``least`` metres of street: a piece apart is a neighbourhood of its own across a barrier only
    when it is one (Monaco, seed 2: 0.2 km of streets beside 10 km, a second piece on the map)."""
    if len(net.streets) < 2:
        return net
    from osm_expand.model.components import component_labels

    seg = np.array([(a, b) for st in net.streets for a, b in zip(st.nodes[:-1], st.nodes[1:])], dtype=np.intp)
    label = component_labels(len(net.xy), seg[:, 0], seg[:, 1])
    length = np.bincount(label[seg[:, 0]], weights=np.hypot(*(net.xy[seg[:, 0]] - net.xy[seg[:, 1]]).T),
                         minlength=int(label.max()) + 1)
    keep = (length >= least) | (np.arange(len(length)) == int(np.argmax(length)))
    return net.replace(streets=tuple(st for st in net.streets if keep[label[st.nodes[0]]]))


def _fewer_dead_ends(net: StreetNetwork, old: shapely.Geometry, occupied: shapely.Geometry, spacing: float,
                     opts: PatchOptions, aim: _Aim, edge: shapely.Geometry | None = None) -> StreetNetwork:
    """Bring the district's dead-end share down to its town's neighbourhoods' median, and its 2-core
    share up to theirs (``aim``).

    Copied patches bring the town's cul-de-sacs, and clipping and trimming
    leave more; a neighbourhood has as many as its town's. Dead ends within
    ``tee_reach`` of the town are left to the joining step, and a road out
    that ends on the district's ``edge`` leaves it (the yardstick reads it
    as a street running on, as it does a real neighbourhood's streets cut by
    its disc) and is no cul-de-sac of the district. The others, in
    order of their chain's length (shortest first), first run on to the
    first street ahead within ``tee_reach`` in a tee (at a fair angle,
    crossing nothing); while the share is still too high, those whose chain
    is shorter than a spacing go. A district whose dead-end share is right
    can still hang too much of its length on dead-end trees (the town's
    long cul-de-sacs copied whole, Monaco's hairpins): while its 2-core
    share is short of the aim, the longest chains run on to a tee too, as
    long as its dead ends stay at ``dead_end_floor`` of the aimed share.
    """
    share = aim.dead_end_share
    reach = opts.tee_reach * spacing
    ends, junctions = _dead_ends(net, old, reach, edge)
    leaves = np.flatnonzero(segment_degree(net.streets, len(net.xy)) == 1)
    anchored = np.zeros(len(net.xy), dtype=bool)
    anchored[leaves[_leaves_out(net.xy[leaves], old, reach, edge)]] = True
    room = aim.off_core_room(net, anchored)
    over = _excess(len(ends), junctions, share) > 0
    if not over and room >= 0:
        return net
    chains = dangling_chains(net.streets, {int(e): net.xy[e] for e in ends})
    length = {e: _chain_length(net, chains[e]) for e in chains}
    # too many dead ends: the shortest chains first; only too little on loops: the longest
    order = sorted(chains, key=lambda e: (length[e], e) if over else (-length[e], e))
    ratio = share / (1.0 - share) if share < 1.0 else float("inf")
    quilt = _Quilt(xy=[net.street_xy(st) for st in net.streets], highway=[st.highway for st in net.streets],
                   level=[st.hierarchy for st in net.streets])
    board = _Board(quilt, occupied, old)
    where = {n: k for k, st in enumerate(net.streets) for n in (st.nodes[0], st.nodes[-1])}
    made = 0
    for e in order:
        if _excess(len(ends) - made, junctions + made, share) <= 0 and (
                room >= 0 or len(ends) - made - 1 < opts.dead_end_floor * ratio * (junctions + made + 1)):
            break
        st = net.streets[where[e]]
        inner = st.nodes[1] if st.nodes[0] == e else st.nodes[-2]
        p = net.xy[e]
        d = (p - net.xy[inner]) / max(float(np.hypot(*(p - net.xy[inner]))), 1e-12)
        ray = shapely.LineString([p + d * 1e-3, p + d * reach])
        hits = [(_meet(ray, quilt.xy[j], p, d, opts.tee_angle), j)
                for j in board.tree.query(ray, predicate="intersects").tolist() if j != where[e]]
        met = [(m, j) for m, j in hits if m is not None]
        if not met:
            continue
        (at, fair), j = min(met, key=lambda h: float(np.hypot(*(h[0][0] - p))))
        if fair and board.clear(np.array([p, at])):
            board.added.append(shapely.LineString([p, at]))
            quilt.add(np.array([p, at]), st.highway, st.hierarchy)
            quilt.splits.setdefault(j, []).append(at)
            made += 1
            room += length[e]
    if made:
        net = _network(quilt)
    ends, junctions = _dead_ends(net, old, reach, edge)
    excess = _excess(len(ends), junctions, share)
    if excess > 0:
        chains = dangling_chains(net.streets, {int(e): net.xy[e] for e in ends})
        drop: set[tuple[int, int]] = set()
        for e in sorted(chains, key=lambda e: (_chain_length(net, chains[e]), e)):
            if excess <= 0 or _chain_length(net, chains[e]) >= spacing:
                break
            drop |= chains[e]
            excess -= 1
        net = net.replace(streets=without_segments(net.streets, drop)) if drop else net
    return _shorter_trees(net, old, reach, edge, aim, opts.dead_end_floor)


def _shorter_trees(net: StreetNetwork, old: shapely.Geometry, reach: float, edge: shapely.Geometry | None,
                   aim: _Aim, floor: float) -> StreetNetwork:
    """Prune cul-de-sacs that met nothing while the district's 2-core share is short of ``aim``'s and
    its dead ends stay at ``floor`` of those the aimed share allows: each time the shortest that
    makes up the shortfall, else the longest (the least street length lost for the 2-core gained)."""
    ratio = aim.dead_end_share / (1.0 - aim.dead_end_share) if aim.dead_end_share < 1.0 else float("inf")
    for _ in range(len(net.streets)):
        ends, junctions = _dead_ends(net, old, reach, edge)
        if not len(ends) or len(ends) - 1 < floor * ratio * junctions:
            break
        leaves = np.flatnonzero(segment_degree(net.streets, len(net.xy)) == 1)
        anchored = np.zeros(len(net.xy), dtype=bool)
        anchored[leaves[_leaves_out(net.xy[leaves], old, reach, edge)]] = True
        room = aim.off_core_room(net, anchored)
        if room >= 0:
            break
        chains = dangling_chains(net.streets, {int(e): net.xy[e] for e in ends})
        length = {e: _chain_length(net, c) for e, c in chains.items()}
        enough = [e for e in sorted(chains) if length[e] >= -room]
        e = min(enough, key=lambda e: length[e]) if enough else max(sorted(chains), key=lambda e: length[e])
        net = net.replace(streets=without_segments(net.streets, chains[e]))
    return net


#: The joining step links the district to the town within this many spacings (``osm_expand.joins``: two):
#: a cul-de-sac made nearer would be joined.
JOIN_REACH = 2.0


def _more_dead_ends(net: StreetNetwork, tees: list[tuple[np.ndarray, np.ndarray]], old: shapely.Geometry,
                    edge: shapely.Geometry, spacing: float, opts: PatchOptions, aim: _Aim) -> StreetNetwork:
    """Bring the district's dead-end share up towards its town's neighbourhoods' median (``aim``).

    The seams close almost every cut street (in a tee onto the street ahead,
    or into a neighbour's), so a small district can end with no cul-de-sac
    at all and every metre of it on a loop, where its town's neighbourhoods
    have a tenth to a quarter of their nodes at dead ends. While the share
    is short of ``share``, a tee onto the district's own streets is taken
    back, so that its cut street stays a cul-de-sac: only where the
    district stays one network without it, where the cul-de-sac is at
    least :data:`STUB_LENGTH` spacings long, and farther than
    :data:`JOIN_REACH` spacings from the town (the joining step would join
    it) and off the district's edge (there it would be a road out);
    the cul-de-sac nearest the town's median length first, and only while
    the district's 2-core share stays at or above the neighbourhoods' median.
    """
    share = aim.dead_end_share
    if not tees or not len(net.xy) or not 0.0 < share < 1.0:
        return net
    import networkx as nx

    ratio, reach = share / (1.0 - share), opts.tee_reach * spacing
    tree = cKDTree(net.xy)
    cut_end, foot = np.array([t[0] for t in tees]), np.array([t[1] for t in tees])
    da, a = tree.query(cut_end)
    db, b = tree.query(foot)
    ok = (da < 1e-6) & (db < 1e-6) & (a != b)
    ok &= shapely.distance(edge, shapely.points(cut_end)) >= ON_EDGE
    if not old.is_empty:
        ok &= shapely.distance(old, shapely.points(cut_end)) > JOIN_REACH * spacing
    # each tee as its segment (smaller node first) -> the cut end it leaves open
    open_end = {(int(min(i, j)), int(max(i, j))): int(i) for i, j in zip(a[ok], b[ok])}
    while open_end:
        ends, junctions = _dead_ends(net, old, reach, edge)
        if len(ends) + 1 > ratio * (junctions - 1) + 0.5:  # one more would overshoot more than it helps
            break
        graph = nx.Graph([(u, v) for st in net.streets for u, v in zip(st.nodes[:-1], st.nodes[1:])])
        bridges = {(min(u, v), max(u, v)) for u, v in nx.bridges(graph)}
        degree = segment_degree(net.streets, len(net.xy))
        leaves = np.flatnonzero(degree == 1)
        anchored = np.zeros(len(net.xy), dtype=bool)
        anchored[leaves[_leaves_out(net.xy[leaves], old, reach, edge)]] = True
        room = aim.off_core_room(net, anchored)
        best = None
        for seg, end in sorted(open_end.items()):
            if seg in bridges or not graph.has_edge(*seg) or degree[end] != 2:
                continue
            rest = without_segments(net.streets, {seg})
            length = _chain_length(net, dangling_chains(rest, [end]).get(end, set()))
            if STUB_LENGTH * spacing <= length <= room and (
                    best is None or abs(length - aim.cul_de_sac) < abs(best[0] - aim.cul_de_sac)):
                best = (length, seg, rest)
        if best is None:
            break
        _, seg, rest = best
        del open_end[seg]
        net = net.replace(streets=rest)
    return net


def _dead_ends(net: StreetNetwork, old: shapely.Geometry, reach: float, edge: shapely.Geometry | None = None
               ) -> tuple[np.ndarray, int]:
    """The district's dead ends farther than ``reach`` from the town and not on its ``edge`` (roads out),
    and its junction count."""
    degree = segment_degree(net.streets, len(net.xy))
    ends = np.flatnonzero(degree == 1)
    ends = ends[~_leaves_out(net.xy[ends], old, reach, edge)]
    return ends, int((degree >= 3).sum())


def _excess(dead: int, junctions: int, share: float) -> int:
    """Dead ends beyond ``share`` of dead ends and junctions together."""
    allowed = share / (1.0 - share) * junctions if share < 1.0 else float("inf")
    return int(np.ceil(dead - allowed))


def _chain_length(net: StreetNetwork, chain: set[tuple[int, int]]) -> float:
    return sum(float(np.hypot(*(net.xy[a] - net.xy[b]))) for a, b in chain)


#: An end this close to the district's edge (m) lies on it: a road out, as :func:`_trim` keeps them.
ON_EDGE = 1.0
#: Metres inside the district's edge that a perimeter street runs.
EDGE_INSET = 4.0


def _edge_start(quilt: _Quilt, region: shapely.Geometry, occupied: shapely.Geometry, old: shapely.Geometry
                ) -> tuple[list, np.ndarray, np.ndarray, _Board] | None:
    """What both ways of walking the site's edge start from: the edge's rings drawn ``EDGE_INSET``
    inside the region, the cut streets' ends, which of them lie at the edge, and the board new
    streets are laid on (None: fewer than two cut ends, or no ring)."""
    if len(quilt.cut_xy) < 2:
        return None
    inner = shapely.buffer(region, -EDGE_INSET)
    rings = [r for poly in shapely.get_parts(inner) if poly.geom_type == "Polygon" for r in [poly.exterior]]
    if not rings:
        return None
    xy = np.array(quilt.cut_xy)
    at_edge = shapely.distance(shapely.boundary(region), shapely.points(xy)) < EDGE_INSET + 1.0
    return rings, xy, at_edge, _Board(quilt, occupied, old)


def _edge_streets(quilt: _Quilt, region: shapely.Geometry, spacing: float, opts: PatchOptions,
                  occupied: shapely.Geometry, old: shapely.Geometry) -> int:
    """Join cut ends left at the district's edge to their neighbour along it by a perimeter street that
    follows the edge :data:`EDGE_INSET` metres inside; returns the streets made.

    Trimming them back instead leaves combs of cul-de-sacs along the edge
    and loses a third of the district's street length; joined, they close
    the edge blocks, as a housing estate's ring road does.
    """
    if opts.perimeter_tees:
        return _perimeter_runs(quilt, region, spacing, opts, occupied, old)
    start = _edge_start(quilt, region, occupied, old)
    if start is None:
        return 0
    rings, xy, at_edge, board = start
    used = np.zeros(len(xy), dtype=bool)
    made = 0
    for ring in rings:
        near = np.flatnonzero(at_edge & (shapely.distance(ring, shapely.points(xy)) < EDGE_INSET + 1.0))
        if len(near) < 2:
            continue
        where = shapely.line_locate_point(ring, shapely.points(xy[near]))
        order = near[np.argsort(where, kind="stable")]
        where = np.sort(where)
        total = ring.length
        pairs = [(k, k + 1) for k in range(len(order) - 1)] + ([(len(order) - 1, 0)] if len(order) > 2 else [])
        for i, j in pairs:
            a, b = int(order[i]), int(order[j])
            if used[a] or used[b] or quilt.cut_piece[a] == quilt.cut_piece[b]:
                continue
            along = (where[j] - where[i]) % total
            if along > opts.seam_gap * spacing:
                continue
            run = _ring_run(ring, float(where[i]), along)
            raw = np.vstack([xy[a], run, xy[b]])
            # the edge is a union of buffers, jagged at a few metres: a street follows it smoothly
            smooth = shapely.get_coordinates(shapely.simplify(shapely.LineString(raw), EDGE_INSET))
            path = smooth if len(smooth) >= 2 and board.clear(smooth) else raw
            if len(path) < 2 or not board.clear(path):
                continue
            _lay(board, quilt, path, a)
            used[a] = used[b] = True
            made += 1
    _close(quilt, used)
    return made


def _perimeter_runs(quilt: _Quilt, region: shapely.Geometry, spacing: float, opts: PatchOptions,
                  occupied: shapely.Geometry, old: shapely.Geometry) -> int:
    """:func:`_edge_streets` with ``perimeter_tees``: perimeter streets that each cut street meets in a
    tee where it crosses the edge :data:`EDGE_INSET` metres inside, pulled taut (:func:`_taut`); returns
    the perimeter streets made.

    The perimeter
    runs on past each cut street it meets (cut ends consecutive along the
    edge within ``seam_gap`` spacings form one run), so a cut street meets
    it in a tee, as streets meet a ring road, and only the run's two ends
    turn a corner: a perimeter link per pair of cut ends turned two corners
    per pair, a U of L-bends along the edge, the sharpest bends of the
    district (north-bayreuth seed 0: 15 of its 34).
    """
    start = _edge_start(quilt, region, occupied, old)
    if start is None:
        return 0
    rings, xy, at_edge, board = start
    inside = shapely.buffer(region, 0.5)
    shapely.prepare(inside)
    used = np.zeros(len(xy), dtype=bool)
    made = 0
    for ring in rings:
        near = np.flatnonzero(at_edge & (shapely.distance(ring, shapely.points(xy)) < EDGE_INSET + 1.0))
        meets = {int(k): at for k in near.tolist()
                 if (at := _meets_ring(quilt.xy[quilt.cut_piece[k]], xy[k], ring)) is not None}
        if len(meets) < 2:
            continue
        ends = np.array(sorted(meets))
        where = shapely.line_locate_point(ring, shapely.points([meets[k] for k in ends]))
        order = np.argsort(where, kind="stable")
        ends, where = ends[order], where[order]
        total = ring.length
        pairs = [(k, k + 1) for k in range(len(ends) - 1)] + [(len(ends) - 1, 0)]
        if len(ends) == 2:  # two ends: the shorter way round the ring
            pairs = [pairs[int((where[1] - where[0]) % total > (where[0] - where[1]) % total)]]
        for i, j in pairs:
            a, b = int(ends[i]), int(ends[j])
            if quilt.cut_piece[a] == quilt.cut_piece[b]:
                continue
            along = (where[j] - where[i]) % total
            if along > opts.seam_gap * spacing:
                continue
            run = _ring_run(ring, float(where[i]), along)
            raw = np.vstack([meets[a], run[1:-1], meets[b]]) if len(run) > 2 else np.array([meets[a], meets[b]])
            path = _taut(raw, board, inside)
            if path is None:
                continue
            for k in (a, b):
                if not used[k]:  # the cut street meets the perimeter where it crosses it; its last metres go
                    quilt.splits.setdefault(quilt.cut_piece[k], []).append(meets[k])
            _lay(board, quilt, path, a)
            used[a] = used[b] = True
            made += 1
    # the cut ends stay open: the few metres of each cut street past the perimeter are trimmed
    return made


def _taut(raw: np.ndarray, board: _Board, inside: shapely.Geometry) -> np.ndarray | None:
    """The perimeter street along ``raw`` (the edge, inset) pulled taut: from each point on to the
    farthest point of ``raw`` that a straight street reaches ``inside`` the district crossing nothing
    on the ``board`` (a string pulled along the edge); None when even ``raw`` is not clear.

    The free land's edge is the outline of buffers around buildings, land use and streets, jagged at
    every house: a street that follows it within a few metres wiggles at every plot (north-bayreuth
    seed 0: most of the district's bends over 20° were on its perimeter), where a road laid along
    such an edge runs straight from corner to corner and bends only where the edge makes it.
    """
    def reach(p: np.ndarray, q: np.ndarray) -> bool:
        line = shapely.LineString([p, q])
        return bool(inside.covers(line)) and board.clear(np.array([p, q]))

    path, i = [raw[0]], 0
    while i < len(raw) - 1:
        j = len(raw) - 1
        while j > i + 1 and not reach(raw[i], raw[j]):
            j -= 1
        path.append(raw[j])
        i = j
    out = np.array(path)
    return out if board.clear(out) else (raw if board.clear(raw) else None)


def _meets_ring(piece: np.ndarray, end: np.ndarray, ring: shapely.LinearRing) -> np.ndarray | None:
    """Where the cut street ``piece`` crosses ``ring`` nearest its cut end at ``end``, when within
    :data:`EDGE_INSET` metres and a few along the street from it; None otherwise."""
    line = shapely.LineString(piece)
    hit = shapely.get_coordinates(shapely.intersection(line, ring))
    if not len(hit):
        return None
    along = np.abs(shapely.line_locate_point(line, shapely.points(hit)) - line.line_locate_point(shapely.Point(end)))
    k = int(np.argmin(along))
    return hit[k] if along[k] <= 3.0 * EDGE_INSET else None


def _ring_run(ring: shapely.LinearRing, start: float, along: float) -> np.ndarray:
    """Points of ``ring`` from ``start`` metres along it, ``along`` metres onward (wrapping), every
    :data:`CONNECTOR_STEP` metres or so."""
    n = max(int(np.ceil(along / CONNECTOR_STEP)), 1)
    at = (start + np.linspace(0.0, along, n + 1)) % ring.length
    return shapely.get_coordinates(shapely.line_interpolate_point(ring, at))


def _planar(net: StreetNetwork) -> StreetNetwork:
    """The district with no two streets touching away from a node they share: of each such pair the
    shorter street goes (the seams, tees and perimeter streets each check what stood when they were
    made; two cut ends of neighbouring cells can still end a few decimetres past each other)."""
    if len(net.streets) < 2:
        return net
    pairs = [(a, b, k) for k, st in enumerate(net.streets) for a, b in zip(st.nodes[:-1], st.nodes[1:])]
    seg = np.array([(a, b) for a, b, _ in pairs], dtype=np.intp)
    owner = np.array([k for _, _, k in pairs])
    lines = shapely.linestrings(net.xy[seg])
    left, right = shapely.STRtree(lines).query(lines, predicate="intersects")
    keep = left < right
    left, right = left[keep], right[keep]
    shared = (seg[left][:, :, None] == seg[right][:, None, :]).any(axis=(1, 2))
    left, right = left[~shared], right[~shared]
    if not len(left):
        return net
    length = np.array([polyline_length(net.street_xy(st)) for st in net.streets])
    drop = set()
    for i, j in zip(owner[left].tolist(), owner[right].tolist()):
        if i != j and i not in drop and j not in drop:
            drop.add(i if (length[i], i) < (length[j], j) else j)
    return net.replace(streets=tuple(st for k, st in enumerate(net.streets) if k not in drop))
