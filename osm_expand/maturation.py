"""The city lives through the years of a history: the engine as one step, City → City.

``osm-expand CITY`` runs :func:`osm_expand.pipeline.expand` (a district grown
and joined), then :func:`mature`::

    result = expand(city, ExpandOptions(seed=0))
    history = load_history("european")
    grown = mature(result.city, history, MatureOptions(years=20), seed=0,
                   learned=result.learned, join_points=result.joins.at)
    # or, the expand result with the city after the years and both reports: mature_result(result, history, ...)

:func:`mature` is :func:`osm_expand.engine.loop.start` and one
:func:`osm_expand.engine.loop.step` per year; it sums the years per era and
takes the snapshots. Of 0 years it gives the city back as it is. The history
is loaded by the caller, once (:func:`osm_expand.engine.history.load_history`).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from osm_expand.engine.history import History
from osm_expand.engine.loop import EngineOptions, EngineState, EraReport, start, step, summary
from osm_expand.model import City, demolished_ways
from osm_expand.pipeline import ExpandResult, Learned, Progress, district_pattern, learn

__all__ = ["Maturation", "MatureOptions", "Snapshot", "YearProgress", "mature", "mature_result"]

#: Called with the city, the calendar year, the era and traffic per street id when a snapshot is due.
Snapshot = Callable[[City, int, str, dict[int, float]], None]
#: Told after every year: (years done, years in all, the era's name).
YearProgress = Callable[[int, int, str], None]


@dataclass(frozen=True)
class MatureOptions:
    """How long the city lives and what is measured on the way (keyword-only; defaults are the CLI's)."""

    years: int | None = None  #: years to simulate; None: the history's own ``years``; 0: none
    #: judge what the years grew against the town's own neighbourhoods (:mod:`osm_expand.growth_fidelity`) and
    #: their land use against the town's mapped one (the build-out report's ``similarity``); changes no output
    #: file, only the report
    fidelity: bool = True
    snapshot_every: int | None = None  #: years between snapshots; None: one at the end of each era
    engine: EngineOptions = field(default_factory=EngineOptions)


@dataclass(frozen=True)
class Maturation:
    """A city after its years, and what they did."""

    city: City  #: its :attr:`~osm_expand.model.City.year` is the last year lived
    #: JSON-ready: ``engine`` (the run, :func:`osm_expand.engine.loop.summary`), ``demolished_osm_ways`` and
    #: ``growth_fidelity``; empty after 0 years
    report: dict


def mature(city: City, history: History, options: MatureOptions | None = None, seed: int = 0, *,
           learned: Learned | None = None, join_points: np.ndarray | None = None,
           snapshot: Snapshot | None = None, progress: Progress = lambda message: None,
           each_year: YearProgress | None = None) -> Maturation:
    """``city`` after ``options.years`` years of ``history`` (003 Algorithm 1 with 002 §2.2).

    Parameters
    ----------
    city : City
        The town as mapped and any district grown (:func:`osm_expand.pipeline.expand`'s city).
    history : History
        A loaded history (:func:`osm_expand.engine.history.load_history`).
    options : MatureOptions
    seed : int
        The run's seed. The engine's stages draw from streams of it alone
        (:data:`osm_expand.engine.loop.STREAMS`) rather than from a generator
        handed in, so a run's years do not depend on what drew before them.
    learned : Learned, optional
        How the town was learned (``expand``'s ``result.learned``): the example the district patterns
        grow from and the town's spacing. Learned from ``city`` when not given (a town as mapped).
    join_points : ndarray, shape (J, 2), optional
        Where a grown district joins the town (``result.joins.at``): nuclei of growth (003 §3.3.2).
    snapshot : callable, optional
        ``snapshot(city, year, era, traffic)`` at the end of each era, or every ``options.snapshot_every``
        years.
    progress : callable
        Told once per era as the run enters it.
    each_year : callable, optional
        Told after every year: ``(years done, years in all, era)``.

    Returns
    -------
    Maturation
        The city after the years (``city`` itself after 0 years) and the report.

    Raises
    ------
    HistoryError
        The history's numbers fail on the way (a year before its first era).
    """
    opts = options or MatureOptions()
    years = history.years if opts.years is None else int(opts.years)
    if years <= 0:
        return Maturation(city, {})
    town = learned if learned is not None else learn(city)
    state, context = start(city, history, seed=seed, spacing=town.example.spacing,
                           patterns=district_pattern(town), join_points=join_points, options=opts.engine,
                           years=years)
    eras: list[EraReport] = []
    every = opts.snapshot_every
    for k in range(years):
        year = context.clock.calendar_year(k)
        if context.starts_era(year, eras[-1].name if eras else None):
            if eras and snapshot is not None and every is None:
                _take(snapshot, state, eras[-1])
            name = context.history.era_at(year - context.clock.offset).name
            progress(f"simulating {years} years of '{history.name}': era {name}")
            eras.append(EraReport(name, year, year))
        state, done = step(state, context, year)
        eras[-1].add(done)
        if snapshot is not None and every and (k + 1) % every == 0:
            snapshot(state.city, year, done.era, state.traffic_by_street())
        if each_year is not None:
            each_year(k + 1, years, done.era)
    if snapshot is not None and every is None:
        _take(snapshot, state, eras[-1])
    # the mapped ways a history demolished: the OSM output leaves them out, the report lists them
    report = {"engine": summary(state, context, eras, judge=opts.fidelity),
              "demolished_osm_ways": demolished_ways(state.city)}
    if opts.fidelity:
        from osm_expand.growth_fidelity import city_growth_fidelity

        progress("judging what the years grew against the town's neighbourhoods")
        grown = city_growth_fidelity(state.city, rng=np.random.default_rng([seed, 0xF1DE, 1]))
        if grown is not None:
            report["growth_fidelity"] = grown.to_dict()
    return Maturation(state.city, report)


def mature_result(result: ExpandResult, history: History, options: MatureOptions | None = None, seed: int = 0, *,
                  snapshot: Snapshot | None = None, progress: Progress = lambda message: None,
                  each_year: YearProgress | None = None) -> ExpandResult:
    """:func:`mature` of an expanded city, as the command line runs it: ``result`` with the city after the
    years and the report of both (the district's, then ``engine``, ``demolished_osm_ways``,
    ``growth_fidelity``). ``seed`` is the expand's."""
    grown = mature(result.city, history, options, seed, learned=result.learned, join_points=result.joins.at,
                   snapshot=snapshot, progress=progress, each_year=each_year)
    return replace(result, city=grown.city, report={**result.report, **grown.report})


def _take(snapshot: Snapshot, state: EngineState, era: EraReport) -> None:
    """The snapshot at the end of ``era``."""
    snapshot(state.city, era.last_year, era.name, state.traffic_by_street())
