"""The land as the town uses it: what every stage asks before it builds (DESIGN.md, "the land").

:mod:`osm_expand.land` reads it from the map once (frontage learned from the
town's own buildings, mapped settlement land use, land cover with its
development cost); this module holds the result and the one rule every
stage shares for blocks, so that the sites, the growth patterns, the
engine's growth and the build-out all see the same free land.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import shapely

#: m²: a block (a face of the street graph) larger than this is town only when buildings cover
#: :data:`BUILT_SHARE` of it. In the fixtures the faces above 0.2 km² are fields and woods between
#: villages (north-bayreuth: 12 of them, 10.4 km², buildings on 0.4–1.9 %) unless they are industrial
#: estates (Krems: 4, 10–19 %).
OPEN_BLOCK = 200_000.0
#: Share of a large block that buildings must cover for it to be town.
BUILT_SHARE = 0.05


@dataclass(frozen=True, eq=False)
class Land:
    """What the map says of the land around the town (metres; arrays of shapely polygons).

    ``taken`` is land the town uses though the map may show nothing there:
    the frontage of its streets and its mapped settlement land use, less
    what mapped buildings show to be empty (a part of the town whose
    buildings are drawn and where none stands). ``town`` is the built-up
    land as a whole (frontage, settlement, buildings): what "next to the
    town" means for a site. ``cover`` holds mapped land cover with its
    development cost in [0, 1) (0 the usual greenfield).
    """

    taken: np.ndarray
    town: np.ndarray
    #: the part of ``taken`` no mapped building is near: presumed occupied, since the map cannot tell.
    #: Where buildings are mapped they speak for themselves (a street pattern may pass a garden, never a house)
    presumed: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=object))
    cover: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=object))
    cover_kind: tuple[str, ...] = ()
    cover_cost: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: metres of frontage behind each street, by class group (``major``, ``minor``)
    frontage_depth: dict[str, float] = field(default_factory=dict)
    #: ``learned`` from the town's buildings, or ``default`` (too few buildings mapped)
    depth_source: str = "default"
    #: metres around a mapped building within which the map is taken to show every building
    survey_radius: float = 0.0

    @cached_property
    def taken_tree(self) -> shapely.STRtree:
        return shapely.STRtree(self.taken)

    @cached_property
    def town_tree(self) -> shapely.STRtree:
        return shapely.STRtree(self.town)

    def taken_near(self, box: shapely.Geometry) -> list[shapely.Geometry]:
        """The parts of ``taken`` that meet ``box``."""
        if not len(self.taken):
            return []
        return self.taken[self.taken_tree.query(box, predicate="intersects")].tolist()

    def to_dict(self) -> dict[str, object]:
        return {"frontage_depth_m": {k: round(v, 1) for k, v in self.frontage_depth.items()},
                "depth_source": self.depth_source, "survey_radius_m": self.survey_radius,
                "taken_km2": round(float(shapely.area(self.taken).sum()) / 1e6, 3) if len(self.taken) else 0.0}


def town_blocks(polygons: np.ndarray, footprints: np.ndarray, *, open_block: float = OPEN_BLOCK,
                built_share: float = BUILT_SHARE,
                overlap: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """Per block, whether it is town: every block up to ``open_block`` m², a larger one only when
    buildings cover ``built_share`` of it (larger faces are mostly fields between villages).

    Parameters
    ----------
    polygons : (B,) block polygons.
    footprints : (F,) building polygons.
    overlap : callable, optional
        ``overlap(blocks, buildings)``: the areas (m²) of the pairs' intersections, as
        ``shapely.area(shapely.intersection(blocks, buildings))`` gives them (a caller that asks every year
        keeps those of last year's very pairs).

    Returns
    -------
    (B,) bool.
    """
    if not len(polygons):
        return np.zeros(0, dtype=bool)
    area = shapely.area(polygons)
    large = np.flatnonzero(area > open_block)
    covered = np.zeros(len(polygons))
    if len(large) and len(footprints):
        block, building = shapely.STRtree(footprints).query(polygons[large], predicate="intersects")
        pairs = (polygons[large[block]], footprints[building])
        areas = shapely.area(shapely.intersection(*pairs)) if overlap is None else overlap(*pairs)
        np.add.at(covered, large[block], areas)
    return (area <= open_block) | (covered >= built_share * area)
