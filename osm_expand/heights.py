"""Heights of the town's buildings, from their tags, calibrated on the town itself.

A building's height is its ``height`` tag; else ``building:levels`` times
the town's storey height; else the town's typical height. The storey height
is the median of height / levels over buildings tagged with both (at least
:data:`MIN_TAGGED` of them), else :data:`STOREY_M`; the typical height is the
median of the heights so found (at least :data:`MIN_TAGGED`), else
:data:`DEFAULT_LEVELS` storeys. Tags stay as mapped; only the typed
``Building.height`` is filled, for the outputs that need a number (the
``<urbanenvironment>`` XML requires one).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from osm_expand.model import Building, City

#: Storey height (m) when the town does not tell: a common residential storey with its slab.
STOREY_M = 3.0
#: Storeys of a building with neither tag, when the town does not tell: a house of two floors.
DEFAULT_LEVELS = 2
#: Tagged buildings needed before the town's own figures are trusted.
MIN_TAGGED = 10


@dataclass(frozen=True)
class TownHeights:
    storey_m: float  #: metres per storey
    typical_m: float  #: a building with no tag gets this height
    tagged: int  #: buildings with a usable height or levels tag


def calibrate(buildings: tuple[Building, ...]) -> TownHeights:
    """The town's storey height and typical building height from its tags."""
    height = np.array([b.height if b.height and b.height > 0 else np.nan for b in buildings], dtype=float)
    levels = np.array([b.levels if b.levels and b.levels > 0 else np.nan for b in buildings], dtype=float)
    both = np.isfinite(height) & np.isfinite(levels)
    storey = float(np.median(height[both] / levels[both])) if both.sum() >= MIN_TAGGED else STOREY_M
    known = np.where(np.isfinite(height), height, levels * storey)
    known = known[np.isfinite(known)]
    typical = float(np.median(known)) if len(known) >= MIN_TAGGED else DEFAULT_LEVELS * storey
    return TownHeights(storey_m=storey, typical_m=typical, tagged=int(len(known)))


def with_heights(city: City) -> City:
    """The city with every building's ``height`` set (tags first, then the town's figures)."""
    town = calibrate(city.buildings)
    out = []
    for b in city.buildings:
        if b.height and b.height > 0:
            out.append(b)
        elif b.levels and b.levels > 0:
            out.append(replace(b, height=float(b.levels) * town.storey_m))
        else:
            out.append(replace(b, height=town.typical_m))
    return city.replace(buildings=tuple(out))
