"""What the build-out made, measured against the town and the goals (issue 11's "done when").

:func:`buildout_report` gives a JSON-ready dict:

- ``land_use``: per type its goal, its share of the city's land-use area at
  the end (002 Eq. 3: the old town's units and the lots), the share among
  the generated lots alone, and the largest deviation from the goals;
- ``lots``: count, and per type the count, the lot-area quartiles and the
  configured bounds (its lot class's ``min_area``/``max_area``);
- ``buildings``: generated and town counts, the generated footprint-area
  median against the town's own, the generated height median against the
  town's tagged median (or the default target when untagged), storey height;
- ``similarity``: Weber's texture similarity (002 §6, Eq. 12–13) of the real
  land use (the town's mapped polygons, rasterised; untagged cells are
  no-data) against the simulated land use of the old town's units, and the
  same for the simulated types shuffled among the units (same shares, no
  spatial sense): the valuation defaults earn their keep when the first
  beats the second. None when the town maps no land use, or when not asked
  (:attr:`ReportOptions.similarity`).
- ``calibration``: centres, coverage, the town's mapped shares and how much
  they weigh in the goals.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from osm_expand.engine.buildout.landuse_types import UNASSIGNED
from osm_expand.engine.buildout.lot_values import area_shares
from osm_expand.engine.buildout.lots import land_use
from osm_expand.engine.buildout.similarity import rasterise_lots, rasterise_polygons, similarity
from osm_expand.errors import InputError
from osm_expand.model import City, Origin

if TYPE_CHECKING:
    from osm_expand.engine.buildout.calibration import TownCalibration
    from osm_expand.engine.history import History

__all__ = ["BuildoutMemory", "ReportOptions", "buildout_report"]


class BuildoutMemory(Protocol):
    """What the report reads of the build-out's memory (:class:`osm_expand.engine.buildout.year.BuildoutMemory`).

    A protocol, so that this module does not import :mod:`osm_expand.engine.buildout.year`, which imports it (the
    circle the two modules once closed with an import at the bottom of ``buildout.py``).
    """

    @property
    def town(self) -> TownCalibration: ...  #: the town's calibration: its units, outlines and sizes
    @property
    def town_types(self) -> NDArray[np.int64]: ...  #: (U,) simulated land-use type of each town unit


@dataclass(frozen=True)
class ReportOptions:
    """How the similarity check is measured (002 §6 compares 1-pixel neighbourhoods of land-use maps)."""

    #: m, raster cell of the land-use images: the town unit's size (40 m) halved, so a unit spans a few cells.
    cell: float = 20.0
    #: Neighbourhood side n (cells) of Eq. 12–13: 8 × 20 m = 160 m, a few blocks.
    n: int = 8
    #: Pixels of the real image sampled (standard error ≤ 0.5/√samples ≈ 0.02).
    samples: int = 600
    #: Cells a side of the window around the main centre that is compared (3.2 km at 20 m):
    #: the old town, and a bound on the time (~0.3 s).
    max_cells: int = 160
    #: Whether the similarity is measured at all (False: ``similarity`` None): a verdict read only from the
    #: ``--json`` report, as the growth's fidelity is (:attr:`osm_expand.maturation.MatureOptions.fidelity`);
    #: Krems' default run without it: 0.10-0.14 → 0.004 s CPU of the report.
    similarity: bool = True

    def __post_init__(self) -> None:
        if not self.cell > 0 or self.n < 1 or self.samples < 1 or self.max_cells < self.n:
            raise InputError(f"report options out of range: {self}")


def _r(x: float, digits: int = 3) -> float:
    return round(float(x), digits)


def _quartiles(values: np.ndarray) -> list[float] | None:
    if not len(values):
        return None
    return [_r(v, 1) for v in np.percentile(values, [25, 50, 75])]


def buildout_report(city: City, memory: BuildoutMemory, history: History, *,
                    options: ReportOptions | None = None) -> dict[str, Any]:
    """The build-out's measures (module docstring).

    Parameters
    ----------
    city : City
        The city after the last :func:`~osm_expand.engine.buildout.year.buildout_year`.
    memory : BuildoutMemory
        The memory returned with it.
    history : History
    options : ReportOptions, optional

    Returns
    -------
    dict
        JSON-ready (plain floats, ints, lists, None).
    """
    opts = options or ReportOptions()
    town = memory.town
    types = town.types
    names = [t.name for t in types]
    index = {n: i for i, n in enumerate(names)}
    goals = np.array([t.goal for t in types], dtype=float)
    goals = goals / goals.sum()
    lots = list(city.lots)
    lot_area = np.array([lot.polygon.area for lot in lots])
    lot_lut = np.array([index.get(lot.land_use, UNASSIGNED) for lot in lots], dtype=np.int64)
    area = np.concatenate([town.unit_area, lot_area])
    lut = np.concatenate([memory.town_types, lot_lut])
    shares = area_shares(area, lut, len(types))
    lot_shares = area_shares(lot_area, lot_lut, len(types))
    land = {n: {"goal": _r(g), "share": _r(s), "lots_share": _r(ls)}
            for n, g, s, ls in zip(names, goals, shares, lot_shares)}

    per_type = {}
    for t, name in enumerate(names):
        a = lot_area[lot_lut == t]
        cls = land_use(types[t].lot_size_key)
        rule = town.lot_options[cls]
        per_type[name] = {"count": int(len(a)), "area_quartiles_m2": _quartiles(a),
                          "bounds_m2": [_r(rule.min_area, 1), _r(rule.max_area, 1)], "lot_class": cls.value}

    generated = [b for b in city.buildings if b.origin == Origin.ENGINE and b.lot is not None]
    gen_area = np.array([b.polygon.area for b in generated])
    gen_height = np.array([b.height or 0.0 for b in generated])
    heights = town.heights
    own_area = town.sizes.samples[:, 0] if town.sizes.count else np.zeros(0)
    report = {
        "land_use": {"types": land, "max_share_deviation": _r(np.abs(shares - goals).max()) if len(goals) else 0.0,
                     "town_units": int(len(town.unit_xy))},
        "lots": {"count": len(lots), "types": per_type},
        "buildings": {
            "generated": len(generated),
            "town": int(len(town.footprints)),
            "footprint_median_m2": {"generated": _r(np.median(gen_area), 1) if len(gen_area) else None,
                                    "town": _r(np.median(own_area), 1) if len(own_area) else None},
            "height_median_m": {"generated": _r(np.median(gen_height), 2) if len(gen_height) else None,
                                "town": _r(heights.median, 2) if heights.from_tags else None,
                                "target": _r(heights.median, 2)},
            "heights_from_tags": bool(heights.from_tags),
            "tagged_buildings": int(heights.n_tagged),
            "storey_height_m": _r(heights.storey_height, 2),
        },
        "similarity": _similarity(memory, opts) if opts.similarity else None,
        "calibration": {
            "centres": [[_r(x, 1), _r(y, 1)] for x, y in town.centres.tolist()],
            "ground_coverage": _r(town.coverage),
            "mapped_shares": ({n: _r(s) for n, s in zip(names, town.landuse.shares)}
                              if town.landuse is not None else None),
            "mapped_coverage": _r(town.landuse.coverage) if town.landuse is not None else None,
            "mapped_weight": _r(town.landuse.weight) if town.landuse is not None else None,
        },
    }
    return report


def _similarity(memory: BuildoutMemory, options: ReportOptions) -> dict[str, Any] | None:
    """Weber's similarity of the real land use and the simulated one over the old town (002 §6)."""
    town = memory.town
    if town.landuse is None or len(town.unit_xy) < 2:
        return None
    xy = town.unit_xy
    pad = float(town.unit_area.max()) ** 0.5  # a unit's side
    half = 0.5 * options.max_cells * options.cell  # the window around the main centre
    lo = np.maximum(xy.min(axis=0) - pad, town.centres[0] - half)
    hi = np.minimum(xy.max(axis=0) + pad, town.centres[0] + half)
    cell = options.cell
    if not (hi - lo > options.n * cell).all():
        return None
    bounds = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
    real = rasterise_polygons(list(town.polygons), bounds=bounds, cell=cell, types=town.types,
                              buildings=list(town.footprints))
    n = min(options.n, *real.shape)
    if (real != UNASSIGNED).sum() == 0 or n < 1:
        return None
    reach = 0.75 * pad
    simulated = rasterise_lots(xy, memory.town_types, bounds=bounds, cell=cell, max_distance=reach)
    rng = np.random.default_rng(0)
    shuffled = rasterise_lots(xy, rng.permutation(memory.town_types), bounds=bounds, cell=cell, max_distance=reach)
    value = similarity(real, simulated, n, samples=options.samples, rng=np.random.default_rng(1), nodata=UNASSIGNED)
    base = similarity(real, shuffled, n, samples=options.samples, rng=np.random.default_rng(1), nodata=UNASSIGNED)
    both = (real != UNASSIGNED) & (simulated != UNASSIGNED)  # mapped, and near a unit of the old town
    agree = float((real[both] == simulated[both]).mean()) if both.any() else None
    return {"simulated": _r(value), "shuffled": _r(base), "cellwise_agreement": None if agree is None else _r(agree),
            "n": int(n), "cell_m": _r(cell, 1)}
