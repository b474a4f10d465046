"""The example-patches growth pattern: cells filled with patches until the district is as dense as its
town's neighbourhoods, then seams, pieces and topology (:class:`ExamplePatches`)."""
from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
import shapely.ops

from osm_expand.model import City, StreetNetwork
from simplify.example import Example
from synth.growth import Growth, NewStreet, streets_near
from synth.patches.edges import _edge_streets
from synth.patches.options import PatchOptions
from synth.patches.placing import _cells, _centres, _free_land, _place
from synth.patches.quilt import _network, _planar, _Quilt
from synth.patches.seams import _tees, _walk_seams
from synth.patches.source import (
    _candidate_patches,
    _density,
    _lengths,
    _level,
    _line_xy,
    _neighbourhood_points,
    _Source,
    _source,
)
from synth.patches.topology import (
    STUB_LENGTH,
    _Aim,
    _connect_pieces,
    _cul_de_sac_length,
    _fewer_dead_ends,
    _keep_joinable,
    _more_dead_ends,
    _outer_edge,
    _roads_out,
    _stub_budget,
    _trim,
    _without_scraps,
)
from synth.patches.transplant import _transplant


@dataclass(frozen=True)
class ExamplePatches:
    """The default growth pattern: a whole neighbourhood of the town as mapped, transplanted; the quilt of
    patches, seams walked, where it falls short of the town's density or with ``transplant`` off."""

    example: Example
    options: PatchOptions = field(default_factory=PatchOptions)
    #: ``measure(lines)`` returns a function measuring those lines in a window (the caller wraps
    #: :func:`osm_expand.measures.measure_network`, as ``synth`` knows only the model); without it patches
    #: are not ranked by how typical of the town they are.
    measure: Callable | None = None
    name: str = "example"
    #: Ranked patch centres by patch size, kept between districts grown by this object (the year loop
    #: grows many from one town: ranking the town's patches is the slow part, and the town is the same).
    #: They were drawn with the first district's generator and so shape the later ones: a run starts from
    #: :meth:`fresh` (:func:`synth.growth.for_a_run`; :func:`osm_expand.pipeline.expand` does).
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
        everything = self._source(city, everything=True)
        radius = float(np.sqrt(free.area / np.pi))
        around = _neighbourhood_points(everything, opts.density_discs, radius, rng)
        density = _density(everything, around, radius)
        target = float(np.median(density)) * float(free.area)
        aim = self._aim(everything, around, radius, city.network)
        fell_back, quilt_rng = None, rng
        if opts.transplant:  # one neighbourhood of the site's size, whole (synth.patches.transplant)
            # the quilt a fallback grows draws what the default's would on this site (its patch ranking)
            quilt_rng = copy.deepcopy(rng)
            whole = self._patches(source, float(np.sqrt(free.area)), rng)
            net, debug = _transplant(source, whole, free, old_geom, occupied, target, spacing, opts, aim)
            floor = float(np.percentile(density, DENSITY_FLOOR)) * float(free.area)
            if not (opts.transplant_fallback and net.total_length() < floor):
                return Growth(streets=tuple(NewStreet(xy=net.street_xy(s), hierarchy=max(s.hierarchy, 0),
                                                      highway=s.highway) for s in net.streets),
                              footprint=free, debug={"target_km": round(target / 1000, 2), **debug})
            # too sparse for a neighbourhood of the town: the quilt below, which fills to the target
            fell_back = {"transplant_km": round(net.total_length() / 1000, 2), "floor_km": round(floor / 1000, 2)}
        patches = self._patches(source, size, quilt_rng)
        centres = _centres(free, old_geom, size)
        cells = _cells(free, centres)
        best = None
        for attempt in range(ATTEMPTS):  # other patches when even every cell filled left too little
            quilt = _Quilt(grid=np.roll(patches, -attempt * len(centres), axis=0))
            result = _quilt(source, quilt, centres, cells, region, old_geom, target, spacing, opts, occupied, aim)
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
                             "target_two_core_share": None if aim is None else round(aim.two_core_share, 3),
                             **({} if fell_back is None else {"fell_back": fell_back})})

    def _patches(self, source: _Source, size: float, rng: np.random.Generator) -> np.ndarray:
        """The town's candidate patches of ``size`` ranked (:func:`_candidate_patches`), kept in :attr:`cache`:
        sizes within 5 % share a ranking."""
        key = round(float(np.log(size)) / 0.05)
        if key not in self.cache:
            self.cache[key] = _candidate_patches(source, size, self.options, rng, self.measure)
        return self.cache[key]

    def fresh(self) -> ExamplePatches:
        """This pattern with empty caches (:func:`synth.growth.for_a_run`): the ranked patches in
        :attr:`cache` were drawn with the generator of the first district that needed them; a new run must
        draw its own."""
        return dataclasses.replace(self, cache={})

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

    def _aim(self, source: _Source, centres: np.ndarray, radius: float, town: StreetNetwork) -> _Aim | None:
        """The median dead-end and 2-core shares of the town's neighbourhoods
        around ``centres`` (None without a ``measure``): what the district's own should come to."""
        if self.measure is None or not len(centres):
            return None
        if "in_window" not in self.cache:
            self.cache["in_window"] = self.measure(_line_xy(source.lines))
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


#: Neighbourhoods measured for the district's target dead-end share (spread evenly over the ranked ones).
DEAD_END_DISCS = 16
#: Times the cells are filled with other patches when the first patches left the district too sparse.
ATTEMPTS = 3
#: Percentile of the town's neighbourhood densities a transplanted district must reach, else the quilt grows
#: instead (:attr:`PatchOptions.transplant_fallback`): the floor of the fidelity verdict's density range,
#: :attr:`osm_expand.fidelity.FidelityOptions.scalar_low` (10th-90th percentile of the real parts; a test
#: holds the two equal, as ``synth`` does not import the verdict).
DENSITY_FLOOR = 10.0


def _misfit(length: float, target: float) -> float:
    """How far a district's street length is from the target, as |log ratio| (inf for nothing)."""
    return abs(float(np.log(length / target))) if length > 0 and target > 0 else float("inf")


def _quilt(source: _Source, quilt: _Quilt, centres: np.ndarray, cells: list, region: shapely.Geometry,
           old: shapely.Geometry, target: float, spacing: float, opts: PatchOptions,
           occupied: shapely.Geometry, aim: _Aim | None = None) -> tuple[StreetNetwork, int, int, int]:
    """Fill cells, stitch and trim; fill more while trimming left too little. The network and counts."""
    placed, keep = 0, 1.0
    for _ in range(MAX_FILLS):
        placed = _place(source, quilt.grid, centres, cells, quilt, placed, target / keep, spacing, old, opts)
        stitched = copy.deepcopy(quilt)
        links = _walk_seams(stitched, spacing, opts, occupied, old)
        tees = _tees(stitched, old, spacing, opts, occupied)
        tees += _edge_streets(stitched, region, spacing, opts, occupied, old)
        stitched_net = _network(stitched)
        edge = _outer_edge(region)
        counted = _roads_out(edge, opts)
        stubs, room = _stub_budget(stitched_net, stitched, aim, old, opts.tee_reach * spacing, counted)
        net = _trim(stitched_net, stitched, edge, opts.keep_out * spacing, keep=stubs, stub=STUB_LENGTH * spacing,
                    room=room, like=aim.cul_de_sac if aim is not None else 0.0)
        net = _keep_joinable(net, old, spacing, opts)
        net = _connect_pieces(net, old, occupied, opts.link_reach * spacing)
        net = _without_scraps(net, opts.min_land * spacing)
        if aim is not None:
            net = _fewer_dead_ends(net, old, occupied, spacing, opts, aim, counted)
            net = _more_dead_ends(net, stitched.tees, old, counted, spacing, opts, aim)
        net = _planar(net)
        length = net.total_length()
        if length >= target or placed >= len(centres):
            break
        keep = max(min(length / max(float(_lengths(quilt.xy).sum()), 1.0), keep), 0.05)
    return net, placed, links, tees


#: Rounds of filling more cells when trimming the seams took too much street away.
MAX_FILLS = 4
