"""The town's neighbourhoods as the growth verdict pools them, measured once a run: what a named pattern's era
aims its connectedness at (issue 20; :attr:`~osm_expand.engine.growth.minor_streets.GrowthOptions.pattern_aim`).

An era's street growth (the grid, organic or suburban patterns) has no idea of the town's connectedness of its
own; each year its dead-end and 2-core shares are set beside the medians of the town's real neighbourhoods, as
the growth verdict would pool them for that growth, and the year's run-ons and stubs are taken back or dropped
towards them (:func:`~osm_expand.engine.growth.minor_streets._withheld`). Judging whole candidate districts by
the same yardstick and drawing again was measured and not adopted (``docs/tried.md``).

The measuring is the growth verdict's (:mod:`osm_expand.growth_fidelity`) on
three of its scalars, of everything the engine grew so far
(its streets and joining streets; the major roads left out, as the verdict
does):

- the growth is measured on its streets' land, the closing of its streets
  with the town's margin (:func:`osm_expand.streets_closing.block_margin`),
  open where it meets a street that is not engine growth;
- its pieces (:func:`osm_expand.growth_fidelity.piece_areas`) each stand for
  a disc of their area around a denser junction of the town as mapped
  (:func:`osm_expand.fidelity.real_parts`), measured on the town's streets'
  land within it (:func:`osm_expand.streets_closing.land_in_disc`); a
  reference part pools one disc per piece, as the verdict's
  (:func:`osm_expand.growth_fidelity.piece_references`) do: its street
  length, area, dead ends, junctions and 2-core length summed, and the
  medians are taken over :data:`~osm_expand.fidelity.DEFAULT_PARTS` parts.

A disc's counts depend on its area, rounded to a bin (:data:`AREA_STEP`),
and are measured once a run per bin (a few bins per run), from the run's seed,
not per year; a year costs its growth's measures in one
window (the scalars alone: no distributions, strokes, blocks or alignment).
What this leaves to the verdict: the discs of a part are the j-th of each
bin (the i-th piece of one bin takes the bin's next disc), not checked for
overlap, and the eight distributions and three other scalars are not read.

Pure: no files, no printing.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely

from osm_expand.fidelity import DEFAULT_PARTS, FidelityOptions, real_parts
from osm_expand.growth_fidelity import GrowthFidelityOptions, is_major_road, meeting_points, piece_areas
from osm_expand.measures import LineSet, Measure, NetworkMeasures, measure_network
from osm_expand.model import City, Origin
from osm_expand.streets_closing import WINDOW_CLOSE, block_margin, closed_land, land_in_disc

__all__ = ["AREA_STEP", "JUDGED", "DistrictYardstick", "growth_lines"]

#: The scalars an era's growth is measured on: the growth verdict's street density, dead-end share and
#: 2-core share (issue 20: "its street density, dead-end share and 2-core share within the range of the town's
#: neighbourhoods"). The other scalars and the distributions are left to the verdict: they cost the strokes,
#: blocks and alignment of every year's window.
JUDGED: tuple[Measure, ...] = (Measure.DENSITY, Measure.DEAD_END_SHARE, Measure.TWO_CORE_SHARE)
#: Growth whose pieces' areas lie within this factor of each other is set beside the same neighbourhood discs
#: (bins of a factor √2, the discs of a bin's geometric middle): density and the shares move with the size of
#: what is measured, but slowly (the verdict's ranges span 0.3 of a share; a disc √2 larger holds a few more
#: junctions), and a bin's 32 discs cost one reference (Campo Grande: about a second).
AREA_STEP = math.sqrt(2.0)
#: The third entropy word of a bin's discs beside the run's seed: the discs never draw on the growth's stream
#: (so measuring the neighbourhoods moves no street's draws).
YARDSTICK_STREAM = 0x7A2D


@dataclass
class DistrictYardstick:
    """The town as mapped, measured once a run, and its neighbourhood discs' counts per bin of area."""

    town: LineSet  #: the town's streets as mapped (origin ``source``)
    land: shapely.Geometry  #: their land: closed with ``margin`` (the growth verdict's streets' land)
    margin: float  #: m, the town's margin: half the side of its median block
    seed: int  #: the run's seed: each bin's discs are drawn from ``[seed, YARDSTICK_STREAM, bin]``
    parts: int = DEFAULT_PARTS
    #: per area bin: ``(parts, 5)`` per disc (densest first) its street length (m), area (m²), dead ends,
    #: junctions and dead ends counted, and 2-core length (m), on the town's streets' land in it
    discs: dict[int, np.ndarray] = field(default_factory=dict)
    #: m²: a piece of the growth's window smaller than this counts with the piece nearest it (the verdict's)
    min_piece_area: float = GrowthFidelityOptions().min_piece_area

    @classmethod
    def of_town(cls, city: City, *, seed: int, parts: int = DEFAULT_PARTS) -> DistrictYardstick:
        """The yardstick of ``city``'s town as mapped: its streets of origin ``source``, their margin and land."""
        net = city.network
        town = LineSet.from_lines([net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE])
        margin = block_margin(measure_network(town, pieces=False, wanted=(Measure.BLOCK_AREA,)).block_area)
        return cls(town=town, land=closed_land(town, WINDOW_CLOSE, margin), margin=margin, seed=seed, parts=parts)

    def _counts(self, k: int) -> np.ndarray:
        """Bin ``k``'s discs' counts (measured the first time the bin is asked for)."""
        if k not in self.discs:
            opts = FidelityOptions()
            discs = real_parts(self.town, AREA_STEP ** k, n=self.parts,
                               rng=np.random.default_rng([self.seed, YARDSTICK_STREAM, k]),
                               sides=opts.disc_sides, draw_factor=opts.draw_factor)
            self.discs[k] = np.array([_counts(measure_network(self.town, window=land_in_disc(d, self.land),
                                                              pieces=False, wanted=JUDGED)) for d in discs])
        return self.discs[k]

    def pooled(self, areas: Sequence[float] | np.ndarray) -> np.ndarray:
        """``(parts, len(JUDGED))``: the judged scalars of the town's neighbourhood discs pooled per part for a
        growth whose pieces stand for discs of ``areas`` m² (the i-th piece of a bin takes the bin's discs from
        its i-th on), as the verdict pools them."""
        pooled = np.zeros((self.parts, 5))
        seen: dict[int, int] = {}
        for area in areas:
            k = round(math.log(max(float(area), 1.0)) / math.log(AREA_STEP))
            pooled += np.roll(self._counts(k), -seen.get(k, 0), axis=0)
            seen[k] = seen.get(k, 0) + 1
        return _scalars(pooled)

    def measured(self, lines: Sequence[np.ndarray], open_points: np.ndarray) -> tuple[np.ndarray, list[float]] | None:
        """A growth's counts ``(5,)`` (street length m, area m², dead ends, junctions and dead ends, 2-core length m)
        on its streets' land, open at ``open_points``, and the areas (m²) of the pieces that land makes
        (:func:`osm_expand.growth_fidelity.piece_areas`); None when the streets make no land."""
        window = closed_land(lines, WINDOW_CLOSE, self.margin)
        if window.is_empty or not window.area > 0:
            return None
        measured = measure_network(lines, window=window, open_points=open_points, pieces=False, wanted=JUDGED)
        return _counts(measured), list(piece_areas(window, self.min_piece_area))

    def aim(self, lines: Sequence[np.ndarray], open_points: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray] | None:
        """A growth's counts (:meth:`measured`) and the town's pooled neighbourhoods' median of each judged scalar
        for it (NaN-skipping): what an era's growth aims at, as the district's topology aims at its town's
        neighbourhoods' medians (:mod:`synth.patches.topology`); None when the streets make no land."""
        got = self.measured(lines, open_points)
        if got is None:
            return None
        counts, areas = got
        pooled = self.pooled(areas)
        finite = np.isfinite(pooled)
        medians = np.array([float(np.median(pooled[finite[:, j], j])) if finite[:, j].any() else float("nan")
                            for j in range(pooled.shape[1])])
        return counts, medians


def _counts(m: NetworkMeasures) -> np.ndarray:
    """``(5,)``: street length (m), area (m²), dead ends, junctions and dead ends, 2-core length (m)."""
    core = m.two_core_share * m.length if m.length > 0 else 0.0
    return np.array([m.length, m.area, m.dead_ends, m.junctions + m.dead_ends, core], dtype=np.float64)


def _scalars(counts: np.ndarray) -> np.ndarray:
    """``(n, len(JUDGED))`` from ``(n, 5)`` counts: density (km/km², as :mod:`osm_expand.measures`), dead-end share,
    2-core share; NaN where undefined (no area, no node counted, no length), as the measures make them."""
    length, area, dead, counted, core = counts.T
    with np.errstate(divide="ignore", invalid="ignore"):
        density = np.where(area > 0, length * 1000.0 / area, np.nan)
        dead_end = np.where(counted > 0, dead / counted, np.nan)
        two_core = np.where(length > 0, core / length, np.nan)
    return np.column_stack([density, dead_end, two_core])


def growth_lines(city: City, era: str | None = None) -> tuple[list[np.ndarray], np.ndarray]:
    """The engine's street growth in ``city`` (streets of origin ``engine`` but its major roads, as the growth
    verdict judges it: :func:`osm_expand.growth_fidelity.is_major_road`), or with ``era`` that era's alone (as the
    verdict judges an era), as polylines, and the points ``(K, 2)`` where it meets the other streets (where it is
    open)."""
    net = city.network
    mine = np.array([s.origin == Origin.ENGINE and not is_major_road(s) and (era is None or s.era == era)
                     for s in net.streets], dtype=bool)
    return [net.street_xy(s) for s, m in zip(net.streets, mine) if m], meeting_points(net, mine, ~mine)
