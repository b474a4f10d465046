"""One year's working state of the build-out (:class:`_Year`, mutable, local to
:func:`~osm_expand.engine.buildout.year.buildout_year`) and its land-use units (:class:`_Units`) with
the attributes every step reads of them (traffic, centres, water, green).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from itertools import chain

import numpy as np
import shapely
from numpy.typing import NDArray

from osm_expand.engine.buildout.calibration import TownCalibration
from osm_expand.engine.buildout.lot_values import lot_attributes
from osm_expand.engine.buildout.memory import BuildoutMemory, BuildoutYear, LotState
from osm_expand.engine.buildout.streets import _Streets
from osm_expand.engine.history import History, YearValues
from osm_expand.model import Block, Building, City

# ============================================================================ the year


@dataclass
class _Year:
    """Working state of one year (mutable, local to :func:`buildout_year`)."""

    city: City
    memory: BuildoutMemory
    history: History
    now: YearValues
    rng: np.random.Generator
    year: int
    traffic: Mapping[int, float]
    streets: _Streets
    blocks: tuple[Block, ...]
    states: dict[int, LotState]
    lot_block: dict[int, int]  #: lot id → index into ``blocks``
    buildings: dict[int, Building]  #: lot id → its generated building
    keys: list[tuple[int, int, int]]  #: each block's key (:func:`_block_keys`)
    report: BuildoutYear = field(default_factory=BuildoutYear)
    substituted: set[int] = field(default_factory=set)  #: lots whose building was replaced this year

    def footprint(self, lot_id: int) -> tuple[shapely.Polygon, float]:
        """The polygon and area (m²) of the generated building on a lot."""
        return self.memory.memo.footprint(self.buildings[lot_id])

    @property
    def town(self) -> TownCalibration:
        return self.memory.town

    def count(self, **changes: int) -> None:
        self.report = self.report + BuildoutYear(**changes)


@dataclass(frozen=True, eq=False)
class _Units:
    """This year's land-use units: the town's (first ``n_town``), then the lots in ``ids`` order."""

    ids: tuple[int, ...]
    n_town: int
    area: NDArray[np.float64]
    attrs: NDArray[np.float64]
    lut: NDArray[np.int64]
    luv: NDArray[np.float64]

    def __post_init__(self) -> None:
        object.__setattr__(self, "_rows", {k: self.n_town + j for j, k in enumerate(self.ids)})

    def row(self, lot_id: int) -> int:
        """The unit row of a lot."""
        # set in __post_init__ (a frozen dataclass), so not a declared field
        return self._rows[lot_id]  # type: ignore[attr-defined]


def _unit_traffic(work: _Year) -> NDArray[np.float64]:
    """Traffic of every unit: a town unit's nearest street's, a lot's summed over the streets it fronts (002 §4.3).

    The lots' sums in one ``bincount`` over all their streets: a Python sum per lot was most of this on
    Campo Grande's 36,000 lot-years. ``bincount`` adds each lot's streets naively, left to right from 0, as
    Python 3.11's ``sum`` did (the outputs' bytes held); 3.12's ``sum`` of floats is compensated and may
    differ in the last bit.
    """
    get = work.traffic.get
    town = np.array([get(s, 0.0) for s in work.town.unit_street.tolist()])
    streets = [work.states[k].streets for k in sorted(work.states)]
    sizes = np.fromiter((len(x) for x in streets), dtype=np.int64, count=len(streets))
    values = np.array([get(s, 0.0) for s in chain.from_iterable(streets)], dtype=np.float64)
    lots = np.bincount(np.repeat(np.arange(len(streets)), sizes), weights=values, minlength=len(streets))
    return np.concatenate([town, lots])


def _attributes(work: _Year, xy: NDArray[np.float64], water: NDArray[np.float64], green: NDArray[np.float64],
                traffic: NDArray[np.float64], *, reference: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """:func:`lot_attributes` with the town's centres and extent; traffic normalised together with ``reference``."""
    town = work.town
    n = len(xy)
    tr = traffic if reference is None else np.concatenate([traffic, reference])
    if reference is not None:
        pad = len(reference)
        xy = np.vstack([xy, np.zeros((pad, 2))])
        water = np.concatenate([water, np.zeros(pad)])
        green = np.concatenate([green, np.zeros(pad)])
    attrs = lot_attributes(xy, centres=town.centres, extent=town.extent, water_distance=water,
                           green_distance=green, traffic=tr, options=work.history.options.land_use)
    return attrs[:n]
