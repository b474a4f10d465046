"""One run's request: the options as the user gave them (:class:`ExpandRequest`) and what can be
checked of them before any work (:func:`check_options`; ``batch`` calls it before its first job).
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

from osm_expand.errors import OptionError

if TYPE_CHECKING:
    from osm_expand.clip import ClipOptions
    from osm_expand.engine.history import History
    from osm_expand.land import LandOptions

#: The largest ``--area`` accepted, m²: 10,000 km², far past any district the engine can grow in a run
#: (Berlin is 891 km²); larger values are typos or fuzz and would only fail later, with a 300-digit number.
MAX_AREA_M2 = 1e10


@dataclass(frozen=True)
class ExpandRequest:
    """One run of the main command: its options as the user gave them (text where the user typed text).

    The fields are :data:`EXPAND_ARGUMENTS`' destinations plus ``city``, the
    input; :meth:`from_namespace` takes them from a parsed command line.
    """

    city: str
    output: str | None = None
    format: str | None = None
    preview: str | None = None
    preview_frame: str = "town"  #: ``town`` or ``all`` (:class:`osm_expand.export.preview.Frame`)
    seed: int = 0
    direction: str = "auto"
    at: str | None = None  #: ``X,Y`` in metres
    at_lonlat: str | None = None  #: ``LON,LAT`` in degrees
    area: float | None = None  #: m²
    pattern: str = "example"
    beyond_bounds: bool | None = None
    unbuildable: str | None = None  #: ``KEY=VALUE,...``; None the default list, '' none
    history: str = "example"  #: a bundled history's name or a TOML file
    years: int | None = None
    snapshots: str | None = None  #: a folder
    snapshot_every: int | None = None
    debug_layers: bool = False
    service: bool = False
    paths: bool = False
    bbox: str | None = None  #: ``W,S,E,N`` in degrees
    around: str | None = None  #: ``LON,LAT`` in degrees, with ``radius``
    radius: float | None = None  #: metres
    clip_index: str | None = None
    #: judge what grew against the town's neighbourhoods (the report's ``fidelity`` and
    #: ``growth_fidelity``) and its land use against the town's (the build-out's ``similarity``); it changes
    #: no output file, only the report
    judge: bool = True

    @classmethod
    def from_namespace(cls, namespace: argparse.Namespace) -> ExpandRequest:
        """The request of a parsed main command (attributes it lacks keep their defaults).

        The verdicts are read only from the ``--json`` report, so a command
        line without ``--json`` (and a batch's job, which keeps the report's
        counts only) does not judge: 12 s of CPU of Campo Grande's default
        run, 2 s of Krems'.
        """
        given = {f.name: getattr(namespace, f.name) for f in fields(cls) if hasattr(namespace, f.name)}
        return cls(**{**given, "judge": bool(getattr(namespace, "json", False))})


@dataclass(frozen=True)
class CheckedOptions:
    """What :func:`check_options` found: the options parsed and checked before any work."""

    land: LandOptions
    history: History
    years: int  #: years to simulate
    at: tuple[float, float] | None = None  #: metres; checked against the map once it is read
    at_lonlat: tuple[float, float] | None = None  #: degrees; checked against the map once it is read
    box: Any = None  #: the ``--bbox``/``--around`` box to clip, if any (:func:`osm_expand.clip.requested_box`)
    clip: ClipOptions | None = None


def _pair(text: str, flag: str) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise OptionError(f"{flag} expects two numbers separated by a comma, got {text!r}") from None
    return a, b


def _points(request: ExpandRequest) -> tuple[tuple[float, float] | None, tuple[float, float] | None]:
    """``--at`` and ``--at-lonlat`` parsed (before any work); their bounds are checked once the map is read."""
    at = at_lonlat = None
    if request.at is not None:
        at = _pair(request.at, "--at")
        if not all(math.isfinite(v) for v in at):
            raise OptionError(f"--at expects two finite numbers (metres), got {at[0]:g},{at[1]:g}")
    if request.at_lonlat is not None:
        at_lonlat = lon, lat = _pair(request.at_lonlat, "--at-lonlat")
        if not (-180 <= lon <= 180 and -90 <= lat <= 90):
            if -180 <= lat <= 180 and -90 <= lon <= 90:
                raise OptionError(f"--at-lonlat {lon:g},{lat:g}: latitude and longitude look swapped; "
                                  f"give longitude first: {lat:g},{lon:g}")
            raise OptionError(f"--at-lonlat {lon:g},{lat:g} is not a longitude,latitude")
    return at, at_lonlat


def check_clip(bbox: str | None, around: str | None, radius: float | None, clip_index: str | None
               ) -> tuple[Any, ClipOptions | None]:
    """``--bbox`` / ``--around --radius`` / ``--clip-index`` checked before any work: the box and the clip options
    (both None when nothing is clipped)."""
    if bbox is None and around is None and radius is None:
        if clip_index is not None:
            raise OptionError("--clip-index needs --bbox or --around")
        return None, None
    from osm_expand.clip import options_for_index, requested_box

    return requested_box(bbox=bbox, around=around, radius=radius), options_for_index(clip_index)


def check_options(request: ExpandRequest) -> CheckedOptions:
    """The options that need no input, checked before any work (``batch`` checks them before its first job).

    Raises
    ------
    OptionError
        ``--area`` out of range, bad ``--at``/``--at-lonlat``/``--bbox``/``--around``, too many years.
    HistoryError
        A ``--history`` that cannot be found or read.
    """
    from osm_expand.engine.history import MAX_YEARS, load_history
    from osm_expand.land import LandOptions, parse_rules

    if request.area is not None and not (0 < request.area <= MAX_AREA_M2):
        raise OptionError(f"--area must be positive (m²) and at most {MAX_AREA_M2:.0e}, got {request.area:.6g}")
    land = LandOptions() if request.unbuildable is None else LandOptions(unbuildable=parse_rules(request.unbuildable))
    at, at_lonlat = _points(request)
    box, clip = check_clip(request.bbox, request.around, request.radius, request.clip_index)
    history = load_history(request.history)
    years = history.years if request.years is None else request.years
    if years > MAX_YEARS:
        raise OptionError(f"--years {years}: at most {MAX_YEARS} years can be simulated")
    return CheckedOptions(land=land, history=history, years=years, at=at, at_lonlat=at_lonlat, box=box, clip=clip)


def site_point(request: ExpandRequest, checked: CheckedOptions, city) -> tuple[float, float] | None:
    """``--at`` / ``--at-lonlat`` in metres, checked against the map's bounds."""
    if checked.at_lonlat is not None:
        lon, lat = checked.at_lonlat
        text = f"{lon:g},{lat:g}"
        lon0, lat0, lon1, lat1 = city.context.bounds_lonlat
        inside = lambda x, y: lon0 <= x <= lon1 and lat0 <= y <= lat1  # noqa: E731
        if inside(lat, lon) and not inside(lon, lat):
            raise OptionError(f"--at-lonlat {text}: latitude and longitude look swapped; "
                              f"give longitude first: {lat:g},{lon:g}")
        if not inside(lon, lat) and not request.beyond_bounds:
            raise OptionError(f"--at-lonlat {text} is outside the map (lon {lon0:.5f}..{lon1:.5f}, "
                              f"lat {lat0:.5f}..{lat1:.5f}); use --beyond-bounds to grow outside it")
        x, y = city.projection.to_xy(lon, lat)
        return float(x), float(y)
    if checked.at is not None:
        x, y = checked.at
        x0, y0, x1, y1 = city.bounds_xy
        if not request.beyond_bounds and not (x0 <= x <= x1 and y0 <= y <= y1):
            raise OptionError(f"--at {x:g},{y:g} is outside the map (x {x0:.0f}..{x1:.0f}, y {y0:.0f}..{y1:.0f} m); "
                              "use --beyond-bounds to grow outside it")
        return x, y
    return None
