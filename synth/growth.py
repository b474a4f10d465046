"""The growth-pattern interface, and the random walk of 004 as its first pattern.

A growth pattern takes the city, a region and a random generator and
returns new streets; it never edits the city. Joining the new streets to the
town is one shared step after any pattern (:mod:`osm_expand.joins`). A new
street that ends on a node of the town carries that node's exact
coordinates, which is how the joining step recognises it.

Patterns: :class:`RandomWalk` (004 §3.1, learning from the town's example);
the Beneš street patterns and space colonisation follow behind the same
interface.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import shapely

from osm_expand.model import City, StreetNetwork
from osm_expand.model.topology import MAX_DEGREE, segment_degree, street_counts
from simplify.example import Example
from synth.grow import grow
from synth.walk import WalkOptions


@dataclass(frozen=True)
class NewStreet:
    """A street a pattern proposes: its shape and what kind of street it is."""

    xy: np.ndarray  #: (n, 2) metres
    hierarchy: int = 0  #: Gravelius level (0: the district's main streets)
    highway: str = "residential"
    bridge: bool = False
    layer: int = 0


@dataclass(frozen=True)
class Growth:
    """What a pattern returns: new streets, the land they were grown on, and what to show for debugging."""

    streets: tuple[NewStreet, ...]
    #: The area the pattern grew in (metres): what the district is judged over.
    footprint: shapely.Geometry | None = None
    debug: dict[str, Any] = field(default_factory=dict)


class GrowthPattern(Protocol):
    """Grows streets in a region of a city."""

    @property
    def name(self) -> str:
        """The pattern's name, in progress lines and reports (read-only: a class attribute will do)."""

    def grow(self, city: City, region: shapely.Geometry, rng: np.random.Generator) -> Growth:
        """New streets inside ``region`` that touch nothing in ``city.occupied`` and cross no street."""
        ...


def for_a_run(pattern: GrowthPattern) -> GrowthPattern:
    """``pattern`` with none of what it kept from earlier runs: what a caller grows a run of districts with.

    A pattern may keep what it computed between the districts of one run (the example patches keep the
    town's ranked patches: the engine's years and the pipeline's sites reuse them), and what it keeps was
    drawn with the first district's generator, so it shapes the later ones. A run that starts from a
    pattern object that grew before must start from none of it, or the same seed gives another district
    than a fresh object does (``district_fidelity.py --option`` reused one object over its seeds: Krems
    seed 1 grew 84 streets at another site instead of 77). A pattern with a ``fresh()`` method gives its
    copy with empty caches; one without keeps nothing and is returned as is.
    """
    fresh = getattr(pattern, "fresh", None)
    return fresh() if callable(fresh) else pattern


def border_nodes(net: StreetNetwork, near: shapely.Geometry, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes of the town within ``reach`` metres of ``near`` where a new street may end.

    Junctions and street ends (not shape points) with fewer than
    :data:`~osm_expand.model.topology.MAX_DEGREE` segments.

    Returns
    -------
    xy : (b, 2) float array
    slots : (b,) int array
        How many more segments each can take.
    """
    n = len(net.xy)
    ends = np.zeros(n, dtype=bool)
    for s in net.streets:
        ends[s.nodes[0]] = ends[s.nodes[-1]] = True
    candidate = (street_counts(net.streets, n) >= 2) | ends
    slots = np.maximum(MAX_DEGREE - segment_degree(net.streets, n), 0)
    pick = np.flatnonzero(candidate & (slots > 0))
    close = shapely.dwithin(near, shapely.points(net.xy[pick]), reach)
    pick = pick[close]
    return net.xy[pick], slots[pick]


def streets_near(net: StreetNetwork, near: shapely.Geometry) -> list[np.ndarray]:
    """Polylines of the streets that touch ``near``."""
    hits = shapely.STRtree(net.street_lines()).query(near, predicate="intersects")
    return [net.street_xy(net.streets[k]) for k in sorted(hits.tolist())]


@dataclass(frozen=True)
class RandomWalk:
    """004's random walk over copies of the town's junction cloud (:func:`synth.grow.grow`)."""

    example: Example
    options: WalkOptions = field(default_factory=lambda: WalkOptions(complete=True))
    name: str = "walk"

    def grow(self, city: City, region: shapely.Geometry, rng: np.random.Generator) -> Growth:
        spacing = self.example.spacing
        radius = float(np.sqrt(shapely.area(region) / np.pi))
        border_xy, slots = border_nodes(city.network, region, 2 * spacing)
        old = streets_near(city.network, region.buffer(0.5 * radius))
        result = grow(self.example, region, obstacles=city.occupied, border_xy=border_xy, border_slots=slots,
                      seed=rng, options=self.options, old_streets=old)
        highway = _class_by_level(self.example.network)
        streets = tuple(NewStreet(xy=pts, hierarchy=int(level), highway=highway.get(int(level), "residential"))
                        for level, pts in result.polylines())
        return Growth(streets=streets, footprint=shapely.difference(region, city.occupied),
                      debug={"junctions_placed": len(result.cloud) - len(border_xy), "border_nodes": len(border_xy)})


def _class_by_level(net: StreetNetwork) -> dict[int, str]:
    """The most common highway class of each Gravelius level."""
    counts: dict[int, Counter] = {}
    for s in net.streets:
        counts.setdefault(s.hierarchy, Counter())[s.highway] += 1
    return {lv: c.most_common(1)[0][0] for lv, c in counts.items()}
