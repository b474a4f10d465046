"""The similarity of two land-use rasters (002 §6): lots and mapped polygons rasterised, compared in windows.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from osm_expand.engine.buildout.landuse_osm import types_from_polygons
from osm_expand.engine.buildout.landuse_types import (
    DEFAULT_OPTIONS,
    DEFAULT_TYPES,
    UNASSIGNED,
    LandUseOptions,
    LandUseType,
)
from osm_expand.errors import InputError


def rasterise_lots(xy: NDArray[np.float64], lut: NDArray[np.int64], *,
                   bounds: tuple[float, float, float, float], cell: float,
                   max_distance: float) -> NDArray[np.int64]:
    """A land-use image: each cell takes the type of the nearest lot centroid within ``max_distance``.

    Parameters
    ----------
    xy : ndarray, shape (L, 2)
    lut : ndarray of int, shape (L,)
    bounds : (xmin, ymin, xmax, ymax)
        Metres.
    cell : float
        Pixel size (m).
    max_distance : float
        Cells farther than this (m) from every lot are ``UNASSIGNED``.

    Returns
    -------
    ndarray of int, shape (rows, cols)
        Row 0 at ``ymin``.
    """
    xs, ys = _grid(bounds, cell)
    gx, gy = np.meshgrid(xs, ys)
    out = np.full(gx.shape, UNASSIGNED, dtype=np.int64)
    if len(xy) == 0:
        return out
    d, i = cKDTree(np.asarray(xy, float)).query(np.column_stack([gx.ravel(), gy.ravel()]),
                                               distance_upper_bound=max_distance)
    hit = np.isfinite(d)
    flat = out.reshape(-1)
    flat[hit] = np.asarray(lut)[i[hit]]
    return out


def _grid(bounds: tuple[float, float, float, float], cell: float) -> tuple[NDArray, NDArray]:
    xmin, ymin, xmax, ymax = bounds
    if not cell > 0 or not (xmax > xmin and ymax > ymin):
        raise InputError(f"land use raster: bad bounds {bounds} or cell {cell}")
    return (np.arange(xmin + cell / 2, xmax, cell), np.arange(ymin + cell / 2, ymax, cell))


def rasterise_polygons(polygons: Sequence[tuple[Any, str]], *, bounds: tuple[float, float, float, float],
                       cell: float, types: Sequence[LandUseType] = DEFAULT_TYPES,
                       buildings: Sequence[Any] | None = None,
                       options: LandUseOptions = DEFAULT_OPTIONS) -> NDArray[np.int64]:
    """The town's real land use as an image (cell centres in mapped polygons; see :func:`types_from_polygons`).

    Returns
    -------
    ndarray of int, shape (rows, cols)
        Type index per cell, ``UNASSIGNED`` where nothing is mapped; row 0 at ``ymin``.
    """
    xs, ys = _grid(bounds, cell)
    gx, gy = np.meshgrid(xs, ys)
    flat = types_from_polygons(np.column_stack([gx.ravel(), gy.ravel()]), polygons,
                               types=types, buildings=buildings, options=options)
    return flat.reshape(gx.shape)


def similarity(image: NDArray[np.int64], reference: NDArray[np.int64], n: int, *,
               samples: int = 1000, rng: np.random.Generator | None = None,
               nodata: int | None = None) -> float:
    """Weber's texture similarity ``Similarity(X, Y)`` of two land-use images (002 §6, Eq. 12–13).

    For each sampled pixel ``p`` of ``image`` (X) take its ``n×n``
    neighbourhood ``x_p``, find the neighbourhood ``z_p`` of ``reference`` (Y)
    with the most identical values, and average ``sim = (identical values) /
    n²`` over the samples. The best match is exact: with one-hot codes per
    value the count of identical values is a dot product, so all of Y's
    neighbourhoods are scored at once by a matrix product (in blocks), each
    distinct neighbourhood of Y once. Cost ``samples × (Y's distinct windows)
    × n² × (distinct values)``: about a second for ``n = 8`` on 200×200 of
    distinct windows with 1,000 samples; ``samples`` trades accuracy
    (standard error ≤ 0.5/√samples) for time.

    Parameters
    ----------
    image, reference : ndarray of int, shape (H, W) and (H', W')
        Land-use images (any integer codes; equal codes are the same use).
    n : int
        Neighbourhood size (pixels), at most the smaller image side.
    samples : int
        Pixels of X sampled (all when X has fewer windows).
    rng : numpy.random.Generator, optional
        Picks the samples (default: a fixed seed, so the measure is repeatable).
    nodata : int, optional
        X pixels with this value (the real town's untagged land) are never
        sampled as centres and do not count in a neighbourhood: Eq. 13 then
        divides by the number of X's other pixels instead of ``n²``.

    Returns
    -------
    float
        In [0, 1]; 1 when every sampled neighbourhood of X occurs in Y.
    """
    x = np.asarray(image)
    y = np.asarray(reference)
    if x.ndim != 2 or y.ndim != 2:
        raise InputError("similarity: images must be 2-D")
    if not 1 <= n <= min(*x.shape, *y.shape):
        raise InputError(f"similarity: n must lie in 1..{min(*x.shape, *y.shape)}, got {n}")
    rng = np.random.default_rng(0) if rng is None else rng
    codes, inverse = np.unique(np.concatenate([x.ravel(), y.ravel()]), return_inverse=True)
    k = len(codes)
    xc = inverse[:x.size].reshape(x.shape)
    yc = inverse[x.size:].reshape(y.shape)
    xw = np.lib.stride_tricks.sliding_window_view(xc, (n, n)).reshape(-1, n * n)
    # each distinct neighbourhood of Y once: a repeated one scores the same, so the best match is the same
    # (a land-use image is patches of one use: Krems' 13,158 windows hold 4,000-5,400 distinct ones)
    yw, _ = _distinct_rows(np.lib.stride_tricks.sliding_window_view(yc, (n, n)).reshape(-1, n * n), k)
    candidates = np.arange(len(xw))
    if nodata is not None:
        centre = np.lib.stride_tricks.sliding_window_view(x, (n, n))[:, :, n // 2, n // 2].ravel()
        candidates = candidates[centre != nodata]
        if len(candidates) == 0:
            raise InputError("similarity: every pixel of the image is nodata")
    if len(candidates) > samples:
        candidates = np.sort(rng.choice(candidates, size=samples, replace=False))
    sampled, of = _distinct_rows(xw[candidates], k)  # likewise each distinct sampled window once
    xs = _one_hot(sampled, k)
    valid = np.full(len(candidates), float(n * n))
    if nodata is not None and nodata in codes:
        code = int(np.searchsorted(codes, nodata))
        xs[:, code::k] = 0.0  # a nodata pixel of X matches nothing and does not count
        valid = (xw[candidates] != code).sum(axis=1).astype(np.float64)
    # only the (pixel, code) columns that some sampled window of X holds can add to a count: the others are
    # dropped from both sides (Krems' report: 214 of 384 held; the counts are whole numbers, exact in
    # float32 in any order, so the scores are the same)
    held = np.flatnonzero(xs.any(axis=0))
    xs = np.ascontiguousarray(xs[:, held])
    best = np.zeros(len(sampled))
    block = max(1, int(2e7 // (n * n * k)))  # ~80 MB of float32 per block of Y's windows
    for start in range(0, len(yw), block):
        yb = _one_hot(yw[start:start + block], k, held)
        np.maximum(best, (xs @ yb.T).max(axis=1), out=best)
    return float((best[of] / valid).mean())


def _distinct_rows(rows: NDArray[np.intp], k: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The distinct rows of ``rows`` (codes below ``k``), each once, and which of them each row is
    (``distinct[inverse]`` is ``rows``).

    Each row is compared as one block of bytes (its codes in the smallest integer type that holds them):
    ``np.unique(axis=0)`` compares 64 fields one by one, 25 times slower."""
    small = np.ascontiguousarray(rows.astype(np.min_scalar_type(max(k - 1, 0))))
    _, first, inverse = np.unique(small.view(np.dtype((np.void, small.itemsize * small.shape[1]))).ravel(),
                                  return_index=True, return_inverse=True)
    return rows[first], inverse.ravel()


def _one_hot(windows: NDArray[np.int64], k: int, columns: NDArray[np.intp] | None = None) -> NDArray[np.float32]:
    """Each window's pixels one-hot, column ``pixel · k + code``: (W, pixels · k), or only ``columns``
    (ascending) of it."""
    out = np.zeros((len(windows), windows.shape[1] * k), dtype=np.float32)
    cols = np.arange(windows.shape[1]) * k
    out[np.arange(len(windows))[:, None], cols[None, :] + windows] = 1.0
    return out if columns is None else out[:, columns]
