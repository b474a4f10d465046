"""A grown engine district judged against the town's neighbourhoods on the verdict's cheap scalars (issue 20).

Example-based synthesis matches the example's statistics by drawing again
until a sample fits: an engine district whose street density, dead-end share
or 2-core share lies outside the range of the town's real neighbourhoods is
a draw a town would not have made, so :func:`~osm_expand.engine.growth.minor_streets.grow_district`
grows another candidate and keeps the best
(:attr:`~osm_expand.engine.growth.minor_streets.GrowthOptions.district_candidates`).

The judging is the growth verdict's (:mod:`osm_expand.growth_fidelity`) on one
district and three of its scalars:

- the district (its streets and joining streets) is measured on its
  streets' land, the closing of its streets with the town's margin
  (:func:`osm_expand.streets_closing.block_margin`), open where it meets a
  street that stood before;
- the ranges are those the verdict allows (:func:`osm_expand.fidelity.scalar_range`:
  the 10th–90th percentile of the real neighbourhoods, shares widened by
  0.02) over :data:`~osm_expand.fidelity.DEFAULT_PARTS` discs around the denser
  junctions of the town as mapped (:func:`osm_expand.fidelity.real_parts`),
  each measured on the town's streets' land within it
  (:func:`osm_expand.streets_closing.land_in_disc`).

Density and the shares depend on the size of what is measured, so the discs
have the district's area, rounded to a bin (:data:`AREA_STEP`): a run measures
the town once (its streets, their land, its margin) and the neighbourhoods
once per bin of district area it meets (a few per run), not once per year or
per district. The scalars alone, without the distributions, strokes, blocks
and alignment: a candidate costs one window's measures (the example patches'
cheap set, :func:`osm_expand.growth_patterns.measure_in_windows`).

Pure: no files, no printing.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely

from osm_expand.fidelity import DEFAULT_PARTS, FidelityOptions, real_parts, scalar_range
from osm_expand.measures import LineSet, Measure, measure_network
from osm_expand.model import City, Origin
from osm_expand.streets_closing import WINDOW_CLOSE, block_margin, closed_land, land_in_disc

__all__ = ["AREA_STEP", "JUDGED", "DistrictScore", "DistrictYardstick", "district_lines"]

#: The scalars a candidate district is judged on: the growth verdict's street density, dead-end share and
#: 2-core share (issue 20: "its street density, dead-end share and 2-core share within the range of the town's
#: neighbourhoods"). The other scalars and the distributions are left to the verdict: they cost the strokes,
#: blocks and alignment of every candidate's window.
JUDGED: tuple[Measure, ...] = (Measure.DENSITY, Measure.DEAD_END_SHARE, Measure.TWO_CORE_SHARE)
#: Districts whose areas lie within this factor of each other are judged against the same neighbourhood discs
#: (bins of a factor √2, the discs of a bin's geometric middle): density and the shares move with the size of
#: what is measured, but slowly (the verdict's ranges span 0.3 of a share; a disc √2 larger holds a few more
#: junctions), and a bin's 32 discs cost one reference (Campo Grande: about a second).
AREA_STEP = math.sqrt(2.0)
#: The third entropy word of a bin's discs beside the run's seed: the discs never draw on the growth's stream
#: (so judging moves no district's draws).
YARDSTICK_STREAM = 0x7A2D


@dataclass(frozen=True, order=True)
class DistrictScore:
    """How far a candidate district lies outside the town's neighbourhoods; smaller is better (ordered)."""

    out: int  #: measures of :data:`JUDGED` out of range (NaN counts as out)
    #: how far outside, summed: in widths of each range (in the measure's own units where a range has no
    #: width; 1 per NaN)
    distance: float
    values: tuple[float, ...] = field(compare=False, default=())  #: the district's value of each of :data:`JUDGED`

    @property
    def within(self) -> bool:
        return self.out == 0


@dataclass
class DistrictYardstick:
    """The town as mapped, measured once a run, and the neighbourhoods' ranges per bin of district area."""

    town: LineSet  #: the town's streets as mapped (origin ``source``)
    land: shapely.Geometry  #: their land: closed with ``margin`` (the growth verdict's streets' land)
    margin: float  #: m, the town's margin: half the side of its median block
    seed: int  #: the run's seed: each bin's discs are drawn from ``[seed, YARDSTICK_STREAM, bin]``
    parts: int = DEFAULT_PARTS
    #: per area bin: ``(len(JUDGED), 2)`` low and high of each judged scalar
    ranges: dict[int, np.ndarray] = field(default_factory=dict)

    @classmethod
    def of_town(cls, city: City, *, seed: int, parts: int = DEFAULT_PARTS) -> DistrictYardstick:
        """The yardstick of ``city``'s town as mapped: its streets of origin ``source``, their margin and land."""
        net = city.network
        town = LineSet.from_lines([net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE])
        margin = block_margin(measure_network(town, pieces=False, wanted=(Measure.BLOCK_AREA,)).block_area)
        return cls(town=town, land=closed_land(town, WINDOW_CLOSE, margin), margin=margin, seed=seed, parts=parts)

    def limits(self, area: float) -> np.ndarray:
        """``(len(JUDGED), 2)``: the range the verdict allows each judged scalar for a district of ``area`` m²
        (its bin's; measured the first time a bin is asked for)."""
        k = round(math.log(max(area, 1.0)) / math.log(AREA_STEP))
        if k not in self.ranges:
            discs = real_parts(self.town, AREA_STEP ** k, n=self.parts,
                               rng=np.random.default_rng([self.seed, YARDSTICK_STREAM, k]),
                               sides=FidelityOptions().disc_sides, draw_factor=FidelityOptions().draw_factor)
            values = np.array([[measure_network(self.town, window=land_in_disc(d, self.land), pieces=False,
                                                wanted=JUDGED).value(m) for m in JUDGED] for d in discs])
            self.ranges[k] = np.array([scalar_range(m, values[:, j]) for j, m in enumerate(JUDGED)])
        return self.ranges[k]

    def score(self, lines: Sequence[np.ndarray], open_points: np.ndarray) -> DistrictScore:
        """A district's streets (each ``(n_i, 2)`` m), open at ``open_points`` ``(K, 2)`` (where they meet the
        streets that stood before), judged on its streets' land against the neighbourhoods of its area."""
        window = closed_land(lines, WINDOW_CLOSE, self.margin)
        if window.is_empty or not window.area > 0:
            return DistrictScore(out=len(JUDGED), distance=float(len(JUDGED)))
        measured = measure_network(lines, window=window, open_points=open_points, pieces=False, wanted=JUDGED)
        values = np.array([float(measured.value(m)) for m in JUDGED])
        low, high = self.limits(float(window.area)).T
        beyond = np.where(values < low, low - values, np.where(values > high, values - high, 0.0))
        width = high - low
        far = np.where(width > 0, beyond / np.where(width > 0, width, 1.0), beyond)
        unknown = np.isnan(values) | np.isnan(low) | np.isnan(high)
        far = np.where(unknown, 1.0, far)
        out = int(((far > 0) | unknown).sum())
        return DistrictScore(out=out, distance=float(far.sum()), values=tuple(values.tolist()))


def district_lines(city: City, first: int) -> tuple[list[np.ndarray], np.ndarray]:
    """The streets ``city.network.streets[first:]`` (a district and its joining streets) as polylines, and the
    points ``(K, 2)`` where they meet the streets before them (where they are open)."""
    net = city.network
    new, old = net.streets[first:], net.streets[:first]
    lines = [net.street_xy(s) for s in new]
    mine = np.fromiter((n for s in new for n in s.nodes), dtype=np.int64)
    theirs = np.fromiter((n for s in old for n in s.nodes), dtype=np.int64)
    return lines, net.xy[np.intersect1d(mine, theirs)]
