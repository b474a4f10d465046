"""Placing a district: sites in order, a growth pattern on each, joined to the town, the first accepted kept.

One loop for the pipeline's district (:func:`osm_expand.pipeline.expand`)
and the engine's districts (:func:`osm_expand.engine.growth.minor_streets.grow_district`),
so the two never drift apart (issue 23). What differs between them is a
parameter:

- the order of the sites (the pipeline's ranking, or re-ranked by the
  engine's nuclei of growth, 003 §3.3.2);
- the random stream of each attempt (the pipeline gives each site its own,
  ``default_rng([seed, attempt])``, so a site's district does not depend on
  the sites tried before it; the engine draws every attempt from the year's
  one stream);
- the acceptance rule (the pipeline counts every join; the engine counts
  joins near the built-up land, so a district hung on a country road in the
  fields is not built);
- what the new streets are stamped with (origin, year, era);
- whether, when no site's district is accepted, the districts grown are
  joined again across the town's presumed frontage
  (:attr:`~osm_expand.model.land.Land.taken`): the pipeline must grow a
  district, the engine can wait for another year.

Pure: no files, no printing (progress is a callback).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from osm_expand.joins import JoinReport, Occupied, join_candidates, join_growth, occupied_near
from osm_expand.model import City, Origin
from osm_expand.sites import Site, district_region
from synth.growth import Growth, GrowthPattern


@dataclass(frozen=True)
class Tried:
    """A site whose district was not accepted."""

    rank: int  #: position of the site in ``sites`` (the caller's ranking)
    growth: Growth  #: what the pattern grew there
    joins: int  #: places the grown streets met the town (0 when not joined)
    #: False: not joined, since even every place it could join at (:func:`osm_expand.joins.join_places`)
    #: is not accepted, or nothing grew
    joinable: bool = True
    #: True: joinable, but not joined, since the places its joining streets could reach past the occupied
    #: land (the town's presumed frontage among it) are not accepted
    blocked: bool = False


@dataclass(frozen=True)
class Placed:
    """The accepted district."""

    rank: int  #: position of its site in ``sites``
    site: Site
    growth: Growth
    city: City  #: the city with the district's streets and its joining streets
    joins: JoinReport
    crossed: bool  #: joined only when its joining streets may cross the town's presumed frontage


@dataclass(frozen=True)
class Placement:
    """What :func:`place_district` did: the district placed (or None) and the sites tried before it."""

    placed: Placed | None
    tried: tuple[Tried, ...]

    def describe_tried(self) -> str:
        """The sites tried, for an error message: ``site 1: 40 streets, 1 joins; ...``."""
        return "; ".join(f"site {t.rank + 1}: {len(t.growth.streets)} streets, "
                         + (f"{t.joins} joins" if t.joinable and not t.blocked
                            else "too few places to join clear of the town's land" if t.joinable
                            else "too few places to join") for t in self.tried)


def at_least(joins: int) -> Callable[[JoinReport], bool]:
    """The acceptance rule that counts every join: ``joins`` places at least."""
    return lambda report: report.joins >= joins


def place_district(city: City, sites: Sequence[Site], pattern: GrowthPattern, *, spacing: float,
                   accept: Callable[[JoinReport], bool], rng: Callable[[int], np.random.Generator],
                   bounds: shapely.Geometry | None, order: Sequence[int] | None = None,
                   origin: Origin = Origin.GROWN, year: int | None = None, era: str | None = None,
                   cross_taken_last: bool = False, progress: Callable[[int], None] = lambda attempt: None
                   ) -> Placement:
    """Grow a district at each site in turn and keep the first whose joins are accepted.

    Parameters
    ----------
    city : City
        The town (and whatever grew before), with its land model.
    sites : sequence of Site
        Candidate sites (:func:`osm_expand.sites.choose_sites`).
    pattern : GrowthPattern
        What grows in a site's region (:func:`osm_expand.sites.district_region`).
    spacing : float
        The town's junction spacing (m), for the joining step.
    accept : callable
        ``JoinReport -> bool``: whether the district is joined well enough. It must hold for a report
        with more places whenever it holds for one with fewer; it reads the count and ``at`` only
        (the report of every possible place has ``links`` and ``tees`` 0): a
        district whose every possible place to join (:func:`osm_expand.joins.join_places`) is not
        accepted is then not joined at all (the join was a third of a failed site's cost on Campo
        Grande), the same as joining and rejecting it; so is one whose every place a joining street can
        reach past the occupied land is not accepted (``blocked``).
    rng : callable
        ``attempt -> Generator``: the random stream of the n-th site tried (0-based, in ``order``).
    bounds : Geometry or None
        Where the region is cut (the map's data bounds), or None for no cut.
    order : sequence of int, optional
        The order in which ``sites`` are tried (default: as given).
    origin, year, era
        Stamped on the district's streets and its joining streets.
    cross_taken_last : bool
        When no district is accepted, join the grown ones again, in order, with joining streets allowed
        across the town's presumed frontage, and keep the first accepted (``crossed`` set).
    progress : callable
        Told the attempt number (0-based) before each growth.

    Returns
    -------
    Placement
        The district placed, or None, and the sites whose districts were not accepted, in the order tried.
    """
    tried: list[Tried] = []
    for attempt, rank in enumerate(range(len(sites)) if order is None else order):
        progress(attempt)
        region = district_region(city, sites[rank], bounds=bounds)
        growth = pattern.grow(city, region, rng(attempt))
        joined = 0
        joinable, clear, occupied = _joinable(city, growth, spacing, accept)
        if clear:
            grown, joins = join_growth(city, growth.streets, spacing=spacing, origin=origin, year=year, era=era,
                                       occupied=occupied)
            if accept(joins):
                return Placement(Placed(rank, sites[rank], growth, grown, joins, crossed=False), tuple(tried))
            joined = joins.joins
        tried.append(Tried(rank, growth, joined, joinable, blocked=joinable and not clear))
    if cross_taken_last:  # the town's frontage wraps every site: join between its presumed houses
        for t in tried:
            if not t.joinable:  # the places to join do not depend on the frontage: none would do
                continue
            grown, joins = join_growth(city, t.growth.streets, spacing=spacing, origin=origin, year=year, era=era,
                                       cross_taken=True)
            if accept(joins):
                return Placement(Placed(t.rank, sites[t.rank], t.growth, grown, joins, crossed=True), tuple(tried))
    return Placement(None, tuple(tried))


def _joinable(city: City, growth: Growth, spacing: float, accept: Callable[[JoinReport], bool]
              ) -> tuple[bool, bool, Occupied | None]:
    """Whether ``accept`` holds for every place the grown streets could join the town at (when it does not,
    no join of them is accepted: ``accept`` holds for more places whenever for fewer); whether it holds for
    those whose joining streets no occupied land blocks (:func:`osm_expand.joins.join_places` with
    ``occupied``: when not, no join is accepted either, unless joining streets may cross the town's presumed
    frontage); and the occupied land read, for the join."""
    if not growth.streets:  # an empty growth joins nowhere
        return False, False, None
    lines = [s.xy for s in growth.streets]
    candidates = join_candidates(city, growth.streets, spacing=spacing)  # found once, asked twice
    places = candidates.places()
    if not accept(JoinReport(joins=len(places), links=0, tees=0, at=places)):
        return False, False, None
    occupied = occupied_near(city, lines, reach=2 * spacing, spread=2 * spacing)
    clear = candidates.places(occupied)
    return True, accept(JoinReport(joins=len(clear), links=0, tees=0, at=clear)), occupied
