"""Information maps for space colonisation (seed 001 §4.3.1): density, border, height.

All three are :class:`Raster` grids in the local projection's metres:

* **density** (population density): values in [0, 1], **larger is denser**
  (001: "lighter areas imply higher population density"; a PGM's white is
  its maximum value). An attraction point is kept with probability equal to
  the value under it.
* **border**: values > 0.5 are **forbidden** (001 fig. 106c: white is water
  and sand, black is land). No attraction point is kept there and no street
  segment may cross such a cell.
* **height**: metres above any datum. A node–attraction-point pair, and a new
  segment, is refused when its slope between consecutive sample points
  exceeds the maximum steepness (001 §4.3.1, fig. 88).

When the user gives no maps, they are derived from the town:
:func:`town_density` (:func:`density_from_points` with :class:`InfoMapOptions`)
smooths existing building centroids and street vertices by a Gaussian kernel
density estimate, and :func:`border_from_geometries` rasterises water, the
old town and non-buildable land (the colonisation kernel also takes these
directly as one ``forbidden`` geometry, which is exact).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from scipy import ndimage

from osm_expand.errors import InputError

__all__ = ["InfoMapOptions", "Raster", "border_from_geometries", "density_from_points", "forbidden_cells",
           "slopes_within", "town_density"]


@dataclass(frozen=True)
class InfoMapOptions:
    """How maps are derived from the town when the user gives none; lengths in segment lengths (SL)."""

    #: Cell size, SL: half an SL resolves the street grid the kernel grows (001 §5.6 used 143-215 m
    #: cells for SL = 1 cell; a town needs finer).
    cell: float = 0.5
    #: Kernel density bandwidth (Gaussian σ), SL: a few blocks, so density fades over a district's width.
    bandwidth: float = 4.0
    #: Lowest density anywhere (001 has none: its maps are drawn by hand): far from the town a third of
    #: the APs are kept, so a district can still grow there, more sparsely.
    floor: float = 0.3
    #: The map covers the region's bounds grown by this, SL, so the smoothing sees the town next to it.
    margin: float = 3.0


@dataclass(frozen=True)
class Raster:
    """A regular grid of values over the plane.

    Cell ``(i, j)`` covers ``x ∈ origin[0] + [j, j + 1) · cell`` and
    ``y ∈ origin[1] + [i, i + 1) · cell``: row 0 is the **southern** row
    and ``origin`` the south-west corner of the grid, in metres.
    """

    origin: tuple[float, float]
    cell: float
    values: np.ndarray  # (ny, nx) float64

    def __post_init__(self) -> None:
        if np.ndim(self.values) != 2 or 0 in np.shape(self.values):
            raise InputError(f"a raster needs a non-empty 2-D array, got shape {np.shape(self.values)}")
        if not (np.isfinite(self.cell) and self.cell > 0):
            raise InputError(f"raster cell size must be a positive number, got {self.cell}")

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) in metres."""
        ny, nx = self.values.shape
        return (self.origin[0], self.origin[1], self.origin[0] + nx * self.cell, self.origin[1] + ny * self.cell)

    def sample(self, xy: np.ndarray, *, nearest: bool = False) -> np.ndarray:
        """Values at points, bilinear between cell centres (or the containing cell's value).

        Points outside the grid take the value of the nearest edge cell.

        Parameters
        ----------
        xy : ndarray, shape (..., 2)
            Points in metres.
        nearest : bool
            Return the value of the cell containing each point instead.

        Returns
        -------
        ndarray, shape (...)
        """
        xy = np.asarray(xy, dtype=float)
        shape = xy.shape[:-1]
        pts = xy.reshape(-1, 2)
        ny, nx = self.values.shape
        v = self.values
        if nearest:
            j = np.clip(np.floor((pts[:, 0] - self.origin[0]) / self.cell).astype(np.int64), 0, nx - 1)
            i = np.clip(np.floor((pts[:, 1] - self.origin[1]) / self.cell).astype(np.int64), 0, ny - 1)
            return v[i, j].reshape(shape)
        fx = np.clip((pts[:, 0] - self.origin[0]) / self.cell - 0.5, 0.0, nx - 1.0)
        fy = np.clip((pts[:, 1] - self.origin[1]) / self.cell - 0.5, 0.0, ny - 1.0)
        j0 = np.minimum(np.floor(fx).astype(np.int64), max(nx - 2, 0))
        i0 = np.minimum(np.floor(fy).astype(np.int64), max(ny - 2, 0))
        j1, i1 = np.minimum(j0 + 1, nx - 1), np.minimum(i0 + 1, ny - 1)
        tx, ty = fx - j0, fy - i0
        out = (1 - ty) * ((1 - tx) * v[i0, j0] + tx * v[i0, j1]) + ty * ((1 - tx) * v[i1, j0] + tx * v[i1, j1])
        return out.reshape(shape)

    def sample_along(self, a: np.ndarray, b: np.ndarray, samples: int) -> np.ndarray:
        """Values at ``samples`` evenly spaced interior points of each segment a→b, plus both ends.

        Parameters
        ----------
        a, b : ndarray, shape (P, 2)
            Segment ends in metres.
        samples : int
            Interior points per segment (>= 0).

        Returns
        -------
        ndarray, shape (P, samples + 2)
            Column 0 at ``a``, the last column at ``b``.
        """
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        b = np.asarray(b, dtype=float).reshape(-1, 2)
        t = np.linspace(0.0, 1.0, samples + 2)
        pts = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
        return self.sample(pts)


def slopes_within(height: Raster, a: np.ndarray, b: np.ndarray, *, max_steepness_deg: float,
                  samples: int) -> np.ndarray:
    """Whether each segment a→b stays under the maximum steepness everywhere (001 §4.3.1, fig. 88).

    The height is sampled at both ends and ``samples`` points between; the
    slope of every piece between consecutive samples must satisfy
    ``atan(|Δh| / Δs) <= max_steepness_deg``. With ``samples = 0`` only the
    ends are compared (001 fig. 88a, which misses a valley between them).

    Parameters
    ----------
    height : Raster
        Heights in metres.
    a, b : ndarray, shape (P, 2)
        Segment ends in metres.
    max_steepness_deg : float
        Largest allowed slope angle, degrees.
    samples : int
        Interior sample points per segment.

    Returns
    -------
    ndarray of bool, shape (P,)
    """
    a = np.asarray(a, dtype=float).reshape(-1, 2)
    b = np.asarray(b, dtype=float).reshape(-1, 2)
    if len(a) == 0:
        return np.zeros(0, dtype=bool)
    h = height.sample_along(a, b, samples)
    step = np.hypot(*(b - a).T) / (samples + 1)
    rise = np.abs(np.diff(h, axis=1)).max(axis=1)
    return rise <= np.tan(np.radians(max_steepness_deg)) * step + 1e-9


def _grid(bounds: tuple[float, float, float, float], cell: float) -> tuple[tuple[float, float], int, int]:
    if not cell > 0:
        raise InputError(f"raster cell size must be positive, got {cell}")
    x0, y0, x1, y1 = (float(v) for v in bounds)
    return (x0, y0), max(int(np.ceil((x1 - x0) / cell)), 1), max(int(np.ceil((y1 - y0) / cell)), 1)


def density_from_points(points: np.ndarray, *, bounds: tuple[float, float, float, float], cell: float,
                        bandwidth: float, floor: float = 0.0, weights: np.ndarray | None = None) -> Raster:
    """A density map from points by Gaussian kernel density estimation, scaled to [floor, 1].

    The points are binned on the grid and smoothed with a Gaussian of
    standard deviation ``bandwidth`` (``scipy.ndimage.gaussian_filter``, so
    the cost is linear in the number of points and cells). The densest
    cell gets 1; every cell gets at least ``floor``, so growth is not
    impossible far from the town.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Building centroids, street vertices, … in metres. Points outside
        ``bounds`` still count, at the nearest edge cell (they are clipped).
    bounds : (xmin, ymin, xmax, ymax)
        Area of the map, metres.
    cell : float
        Cell size, metres.
    bandwidth : float
        Kernel standard deviation, metres.
    floor : float
        Lowest value of the map, in [0, 1].
    weights : ndarray, shape (N,), optional
        Weight per point (default 1).

    Returns
    -------
    Raster
        Values in [floor, 1]; all ``floor`` (or 1 when floor is 0) without points.
    """
    if not 0.0 <= floor <= 1.0:
        raise InputError(f"density floor must be in [0, 1], got {floor}")
    origin, nx, ny = _grid(bounds, cell)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    counts = np.zeros((ny, nx))
    if len(pts):
        j = np.clip(np.floor((pts[:, 0] - origin[0]) / cell).astype(np.int64), 0, nx - 1)
        i = np.clip(np.floor((pts[:, 1] - origin[1]) / cell).astype(np.int64), 0, ny - 1)
        np.add.at(counts, (i, j), 1.0 if weights is None else np.asarray(weights, dtype=float))
    smooth = ndimage.gaussian_filter(counts, sigma=max(bandwidth / cell, 1e-6), mode="constant")
    top = smooth.max()
    scaled = smooth / top if top > 0 else np.full_like(smooth, 1.0 if floor == 0 else 0.0)
    return Raster(origin=origin, cell=float(cell), values=floor + (1.0 - floor) * scaled)


def border_from_geometries(geometries: Sequence[shapely.Geometry] | shapely.Geometry | None, *,
                           bounds: tuple[float, float, float, float], cell: float) -> Raster:
    """A border map: 1 in cells whose centre lies in a forbidden geometry, else 0.

    Parameters
    ----------
    geometries : geometry or sequence of geometries, optional
        Water, the old town, non-buildable land, … (metres).
    bounds : (xmin, ymin, xmax, ymax)
        Area of the map, metres.
    cell : float
        Cell size, metres.

    Returns
    -------
    Raster
        1.0 forbidden, 0.0 allowed.
    """
    origin, nx, ny = _grid(bounds, cell)
    values = np.zeros((ny, nx))
    if geometries is None:
        return Raster(origin=origin, cell=float(cell), values=values)
    geom = geometries if isinstance(geometries, shapely.Geometry) else shapely.union_all(list(geometries))
    if geom is None or geom.is_empty:
        return Raster(origin=origin, cell=float(cell), values=values)
    gx, gy = np.meshgrid(origin[0] + (np.arange(nx) + 0.5) * cell, origin[1] + (np.arange(ny) + 0.5) * cell)
    shapely.prepare(geom)
    values[shapely.intersects_xy(geom, gx.ravel(), gy.ravel()).reshape(ny, nx)] = 1.0
    return Raster(origin=origin, cell=float(cell), values=values)


def forbidden_cells(border: Raster) -> shapely.Geometry:
    """The forbidden cells of a border map (value > 0.5) as one polygonal geometry.

    Runs of forbidden cells in a row become one box each before the union,
    so the union sees one box per run, not per cell.

    Parameters
    ----------
    border : Raster
        Border map.

    Returns
    -------
    shapely.Geometry
        A (multi)polygon, empty when nothing is forbidden.
    """
    mask = border.values > 0.5
    if not mask.any():
        return shapely.Polygon()
    padded = np.pad(mask.astype(np.int8), ((0, 0), (1, 1)))
    step = np.diff(padded, axis=1)
    rows_s, cols_s = np.nonzero(step == 1)
    rows_e, cols_e = np.nonzero(step == -1)  # same row-major order as the starts
    x0, y0 = border.origin
    c = border.cell
    boxes = shapely.box(x0 + cols_s * c, y0 + rows_s * c, x0 + cols_e * c, y0 + (rows_s + 1) * c)
    return shapely.union_all(boxes)


def town_density(points: np.ndarray, *, bounds: tuple[float, float, float, float], segment_length: float,
                 options: InfoMapOptions | None = None) -> Raster:
    """The density map of 001 §4.3.1 derived from the town: a kernel density of its buildings and streets.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        Building centroids and street vertices of the town, metres.
    bounds : (xmin, ymin, xmax, ymax)
        The region to grow in, metres; the map covers it plus ``options.margin`` SL.
    segment_length : float
        SL in metres (the town's junction spacing).
    options : InfoMapOptions, optional
        Cell, bandwidth, floor and margin (default :class:`InfoMapOptions`).

    Returns
    -------
    Raster
        Values in [floor, 1], 1 at the densest part of the town.
    """
    options = options or InfoMapOptions()
    pad = options.margin * segment_length
    x0, y0, x1, y1 = bounds
    return density_from_points(points, bounds=(x0 - pad, y0 - pad, x1 + pad, y1 + pad),
                               cell=options.cell * segment_length, bandwidth=options.bandwidth * segment_length,
                               floor=options.floor)
