"""The boxes to clip: checked and made from the command line's ``--bbox`` or ``--around`` (degrees), and
found for many points at once in libosmium's integer coordinates (:class:`_Boxes`)."""
from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from osm_expand.errors import OptionError

__all__ = ["EARTH_RADIUS_M", "Box", "box_around", "check_box", "parse_bbox", "requested_box"]

#: (west, south, east, north) in degrees (WGS84).
Box = tuple[float, float, float, float]
#: Mean Earth radius (m), IUGG; the same sphere the box of :func:`box_around` is drawn on.
EARTH_RADIUS_M = 6_371_008.8
#: Coordinates of libosmium's locations are integers of 1e-7 degree.
_COORDINATE_PRECISION = 10_000_000


def check_box(box: Iterable[float], what: str = "box") -> Box:
    """A valid (W, S, E, N) box in degrees, or an :class:`InputError` saying what is wrong.

    Parameters
    ----------
    box : four numbers
        West, south, east, north in degrees (longitude first).
    what : str
        How the box is named in the message (``"--bbox"``, ``"town Krems"``).

    Returns
    -------
    tuple of four floats
    """
    try:
        values = tuple(float(v) for v in box)
    except (TypeError, ValueError):
        raise OptionError(f"{what}: expects four numbers W,S,E,N, got {box!r}") from None
    if len(values) != 4:
        raise OptionError(f"{what}: expects four numbers W,S,E,N, got {len(values)}")
    w, s, e, n = values
    text = f"{w:g},{s:g},{e:g},{n:g}"
    if not all(math.isfinite(v) for v in values):
        raise OptionError(f"{what} {text}: not finite numbers")
    if not (-180 <= w <= 180 and -180 <= e <= 180 and -90 <= s <= 90 and -90 <= n <= 90):
        raise OptionError(f"{what} {text}: outside the globe (longitudes -180..180, latitudes -90..90, W,S,E,N)")
    if w >= e or s >= n:
        swap = " (latitude and longitude swapped? the order is W,S,E,N)" if s < w and n < e and s < n else ""
        raise OptionError(f"{what} {text}: empty box, west must be less than east and south less than north{swap}")
    return values


def parse_bbox(text: str, what: str = "--bbox") -> Box:
    """``"W,S,E,N"`` → a checked box (see :func:`check_box`)."""
    parts = [p.strip() for p in str(text).split(",")]
    if len(parts) != 4:
        raise OptionError(f"{what} expects four numbers W,S,E,N separated by commas, got {text!r}")
    try:
        return check_box([float(p) for p in parts], what)
    except ValueError:
        raise OptionError(f"{what} expects four numbers W,S,E,N separated by commas, got {text!r}") from None


def box_around(lon: float, lat: float, radius_m: float) -> Box:
    """The box holding the circle of ``radius_m`` metres around a point.

    On a sphere of :data:`EARTH_RADIUS_M`: ``Δlat = r / R`` and
    ``Δlon = Δlat / cos(lat)`` (in radians), so the box spans ``2 r`` in
    both directions at the centre's latitude.

    Parameters
    ----------
    lon, lat : float
        The centre in degrees.
    radius_m : float
        Metres, > 0.

    Returns
    -------
    tuple of four floats
        (W, S, E, N) in degrees.
    """
    try:
        lon, lat, radius_m = float(lon), float(lat), float(radius_m)
    except (TypeError, ValueError):
        raise OptionError(f"--around expects numbers, got {lon!r},{lat!r} and radius {radius_m!r}") from None
    if not (math.isfinite(lon) and math.isfinite(lat) and -180 <= lon <= 180 and -90 < lat < 90):
        swapped = (" (latitude and longitude swapped? the order is LON,LAT)"
                   if -90 < lon < 90 and abs(lat) <= 180 else "")
        raise OptionError(f"--around {lon:g},{lat:g}: not a longitude,latitude{swapped}")
    if not (math.isfinite(radius_m) and radius_m > 0):
        raise OptionError(f"--radius must be a positive number of metres, got {radius_m:g}")
    dlat = math.degrees(radius_m / EARTH_RADIUS_M)
    if abs(lat) + dlat >= 90:
        raise OptionError(f"--around {lon:g},{lat:g} --radius {radius_m:g}: the box reaches a pole")
    dlon = dlat / math.cos(math.radians(lat))
    if not (-180 <= lon - dlon and lon + dlon <= 180):
        raise OptionError(f"--around {lon:g},{lat:g} --radius {radius_m:g}: the box crosses the antimeridian "
                          "(not supported)")
    return (lon - dlon, lat - dlat, lon + dlon, lat + dlat)


def requested_box(*, bbox: str | None = None, around: str | None = None, radius: float | None = None) -> Box | None:
    """The box of the command line's ``--bbox W,S,E,N`` or ``--around LON,LAT --radius M``.

    Parameters
    ----------
    bbox : str, optional
        ``"W,S,E,N"`` in degrees.
    around : str, optional
        ``"LON,LAT"`` in degrees; needs ``radius``.
    radius : float, optional
        Metres from ``around`` to the box's sides (:func:`box_around`).

    Returns
    -------
    tuple of four floats, or None
        (W, S, E, N) in degrees; None when neither option is given.

    Raises
    ------
    InputError
        Both options, ``--around`` without ``--radius`` (or the reverse), or a bad box.
    """
    if bbox is not None and (around is not None or radius is not None):
        raise OptionError("give --bbox or --around with --radius, not both")
    if bbox is not None:
        return parse_bbox(bbox)
    if around is None and radius is None:
        return None
    if around is None:
        raise OptionError("--radius needs --around LON,LAT")
    if radius is None:
        raise OptionError("--around needs --radius M (metres from the point to the box's sides)")
    parts = [p.strip() for p in str(around).split(",")]
    try:
        lon, lat = (float(p) for p in parts)
    except ValueError:
        raise OptionError(f"--around expects two numbers LON,LAT separated by a comma, got {around!r}") from None
    return box_around(lon, lat, radius)


class _Boxes:
    """The boxes in libosmium's integer coordinates, with a grid to find the boxes of many points at once."""

    def __init__(self, boxes: list[Box]):
        b = np.asarray(boxes, dtype=float).reshape(-1, 4)
        self.lo = np.round(b[:, :2] * _COORDINATE_PRECISION).astype(np.int64)  # (B, 2) W, S
        self.hi = np.round(b[:, 2:] * _COORDINATE_PRECISION).astype(np.int64)  # (B, 2) E, N
        self.union_lo, self.union_hi = self.lo.min(axis=0), self.hi.max(axis=0)  # (2,) all boxes
        self.cell = np.maximum((self.hi - self.lo).max(axis=0), 1)  # (2,) one box spans at most 2 cells a side
        first, last = self.lo // self.cell, self.hi // self.cell
        keys, owners = [], []
        for k in range(len(b)):
            cx, cy = np.meshgrid(np.arange(first[k, 0], last[k, 0] + 1), np.arange(first[k, 1], last[k, 1] + 1))
            keys.append(self._key(cx.ravel(), cy.ravel()))
            owners.append(np.full(cx.size, k))
        key, owner = np.concatenate(keys), np.concatenate(owners)
        order = np.argsort(key, kind="stable")
        self.key, self.owner = key[order], owner[order]

    @staticmethod
    def _key(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
        return cx.astype(np.int64) * (1 << 32) + cy.astype(np.int64)

    def members(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point index, box index) of every point inside every box (edges included).

        Parameters
        ----------
        x, y : (N,) int arrays
            Longitudes and latitudes in 1e-7 degree.
        """
        x, y = np.asarray(x, dtype=np.int64), np.asarray(y, dtype=np.int64)
        key = self._key(x // self.cell[0], y // self.cell[1])
        start = np.searchsorted(self.key, key, side="left")
        stop = np.searchsorted(self.key, key, side="right")
        count = stop - start
        point = np.repeat(np.arange(len(x)), count)
        if point.size == 0:
            return point, point
        offset = np.arange(point.size) - np.repeat(np.cumsum(count) - count, count)
        box = self.owner[np.repeat(start, count) + offset]
        px, py = x[point], y[point]
        inside = ((px >= self.lo[box, 0]) & (px <= self.hi[box, 0]) & (py >= self.lo[box, 1])
                  & (py <= self.hi[box, 1]))
        return point[inside], box[inside]
