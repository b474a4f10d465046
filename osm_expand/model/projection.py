"""A reversible local metric projection centred on the data.

A transverse Mercator centred on the extract keeps scale error below 1e-5 over
a town, so distances and angles in metres are trustworthy, and the PROJ
string travels with every export so coordinates can be georeferenced again.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np


@lru_cache(maxsize=16)
def _proj(proj_string: str):
    """The projection, made once per string.

    A ``Proj`` projects geographic coordinates on its own ellipsoid (WGS84
    here) both ways, giving bit for bit what a ``Transformer`` from EPSG:4326
    gives, in 0.6 ms instead of the 28 ms two transformers take to set up
    (their EPSG lookup in PROJ's database).
    """
    from pyproj import Proj  # pyproj only when a projection is used: it is slow to import

    return Proj(proj_string)


@dataclass(frozen=True)
class LocalProjection:
    lon0: float
    lat0: float

    @property
    def proj_string(self) -> str:
        return (f"+proj=tmerc +lat_0={self.lat0:.7f} +lon_0={self.lon0:.7f} +k=1 "
                "+x_0=0 +y_0=0 +ellps=WGS84 +units=m +no_defs")

    def to_xy(self, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, y = _proj(self.proj_string)(np.asarray(lon, dtype=float), np.asarray(lat, dtype=float))
        return np.asarray(x), np.asarray(y)

    def to_lonlat(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lon, lat = _proj(self.proj_string)(np.asarray(x, dtype=float), np.asarray(y, dtype=float), inverse=True)
        return np.asarray(lon), np.asarray(lat)

    @classmethod
    def centred_on(cls, bounds_lonlat: tuple[float, float, float, float]) -> LocalProjection:
        lon_min, lat_min, lon_max, lat_max = bounds_lonlat
        return cls(round((lon_min + lon_max) / 2, 7), round((lat_min + lat_max) / 2, 7))
