"""Reading user information maps (density, border, height) for space colonisation.

A map is a 2-D grid in a ``.npy`` file (any numeric dtype) or a PGM image
(``P2`` plain or ``P5`` binary, 8 or 16 bit), plus a **georeference**: a JSON
sidecar named like the map with ``.json`` appended (``height.pgm.json``) or
replacing the suffix (``height.json``)::

    {
      "origin": [x, y],               # metres in the town's local projection, or
      "origin_lonlat": [lon, lat],    # degrees (WGS 84), projected with the town's projection
      "cell_size": 25.0,              # metres per cell, > 0
      "row0": "north",                # "north" (image order, the default) or "south"
      "scale": 1.0,                   # optional: value = offset + scale * stored value
      "offset": 0.0                   # optional
    }

``origin`` is the outer corner of the first column and of row 0: the
north-west corner of the grid when ``row0`` is ``"north"`` (as an image is
stored: its first row is its top), the south-west corner when ``"south"``.
Cells are squares aligned with the local projection's x (east) and y (north)
axes. Without ``scale``, PGM values are divided by the image's maximum value
(so a density or border map reads 0 for black and 1 for white) and ``.npy``
values are used as they are; a height map from a PGM therefore needs
``scale`` in metres per grey level.

Polarity (see :mod:`synth.infomaps`): density, larger is denser (white);
border, values above 0.5 are forbidden (white); height, metres.

:func:`read_raster` returns a :class:`GeoGrid` (south-west origin, cell size,
values with row 0 south), the fields of :class:`synth.infomaps.Raster` in
order, so the orchestrator builds the map with ``Raster(*grid)``; this module
does not import ``synth`` (``synth`` depends on ``osm_expand``, not the
reverse).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import NamedTuple

import numpy as np

from osm_expand.errors import InputError
from osm_expand.model.projection import LocalProjection

__all__ = ["GeoGrid", "read_georeference", "read_grid", "read_raster"]

#: The two orders a grid's rows may come in.
ROW0 = ("north", "south")


class GeoGrid(NamedTuple):
    """A grid placed in the local projection: ``Raster(*grid)`` makes a :class:`synth.infomaps.Raster`."""

    origin: tuple[float, float]  # south-west corner, metres
    cell: float  # metres
    values: np.ndarray  # (rows, columns) float64, row 0 south


def read_raster(path: str | Path, *, projection: LocalProjection | None = None) -> GeoGrid:
    """A georeferenced information map from ``.npy`` or PGM plus its JSON sidecar.

    Parameters
    ----------
    path : str or Path
        The ``.npy``, ``.pgm`` (or ``.pnm``) file.
    projection : LocalProjection, optional
        The town's projection; needed when the sidecar gives ``origin_lonlat``.

    Returns
    -------
    GeoGrid
        Values scaled as the sidecar says, row 0 south, origin the south-west corner in metres.

    Raises
    ------
    InputError
        One line naming the file and what is wrong with it.
    """
    path = Path(path)
    raw, default_scale = read_grid(path)
    geo = read_georeference(path)
    scale = float(geo.get("scale", default_scale))
    offset = float(geo.get("offset", 0.0))
    values = offset + scale * raw.astype(np.float64)
    if "origin" in geo:
        x0, y0 = _pair(geo["origin"], "origin", path)
    else:
        lon, lat = _pair(geo["origin_lonlat"], "origin_lonlat", path)
        if projection is None:
            raise InputError(f"{_sidecar_name(path)}: origin_lonlat needs the town's projection; give origin in metres")
        xs, ys = projection.to_xy(np.array([lon]), np.array([lat]))
        x0, y0 = float(xs[0]), float(ys[0])
    cell = float(geo["cell_size"])
    if geo.get("row0", "north") == "north":
        values = values[::-1]
        y0 -= values.shape[0] * cell
    return GeoGrid(origin=(x0, y0), cell=cell, values=np.ascontiguousarray(values))


def read_grid(path: Path) -> tuple[np.ndarray, float]:
    """The stored 2-D grid of a ``.npy`` or PGM file, and the default scale (1/maxval for PGM, 1 for npy).

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    (ndarray of shape (rows, columns), float)
    """
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            grid = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError) as exc:
            raise InputError(f"{path}: not a readable .npy array ({exc})") from None
        scale = 1.0
    elif suffix in (".pgm", ".pnm"):
        grid, maxval = _read_pgm(path)
        scale = 1.0 / maxval
    else:
        raise InputError(f"{path}: unknown map format {suffix or '(none)'}; use .npy or .pgm")
    if grid.ndim != 2 or 0 in grid.shape:
        raise InputError(f"{path}: a map must be a non-empty 2-D grid, got shape {grid.shape}")
    if not np.issubdtype(grid.dtype, np.number) or np.issubdtype(grid.dtype, np.complexfloating):
        raise InputError(f"{path}: a map must hold real numbers, got dtype {grid.dtype}")
    if not np.isfinite(grid).all():
        raise InputError(f"{path}: the map holds NaN or infinite values")
    return grid, scale


def _read_pgm(path: Path) -> tuple[np.ndarray, int]:
    """A PGM image (P2 or P5) as an integer grid, and its maximum value."""
    data = path.read_bytes()
    magic = data[:2]
    if magic not in (b"P2", b"P5"):
        raise InputError(f"{path}: not a PGM file (magic number {magic!r}, expected P2 or P5)")
    fields: list[int] = []
    pos = 2
    while len(fields) < 3:  # width, height, maxval; '#' starts a comment up to the end of the line
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        if pos < len(data) and data[pos:pos + 1] == b"#":
            pos = data.find(b"\n", pos)
            pos = len(data) if pos < 0 else pos
            continue
        start = pos
        while pos < len(data) and not data[pos:pos + 1].isspace():
            pos += 1
        token = data[start:pos]
        if not token.isdigit():
            raise InputError(f"{path}: bad PGM header (expected width, height and maximum value)")
        fields.append(int(token))
    width, height, maxval = fields
    if width < 1 or height < 1 or not 1 <= maxval <= 65535:
        raise InputError(f"{path}: bad PGM header (width {width}, height {height}, maximum value {maxval})")
    count = width * height
    if magic == b"P5":
        body = data[pos + 1:]  # exactly one whitespace byte after maxval
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype("u1")
        if len(body) < count * dtype.itemsize:
            raise InputError(f"{path}: PGM data is truncated ({len(body)} bytes for {width}x{height} pixels)")
        grid = np.frombuffer(body, dtype=dtype, count=count).astype(np.int64)
    else:
        tokens = data[pos:].split()
        if len(tokens) < count or not all(t.isdigit() for t in tokens[:count]):
            raise InputError(f"{path}: PGM data is truncated or not numeric ({len(tokens)} values for "
                             f"{width}x{height} pixels)")
        grid = np.array([int(t) for t in tokens[:count]], dtype=np.int64)
    if grid.max(initial=0) > maxval:
        raise InputError(f"{path}: PGM value {int(grid.max())} exceeds the maximum value {maxval}")
    return grid.reshape(height, width), maxval


def _sidecar_name(path: Path) -> Path:
    return path.with_name(path.name + ".json")


def read_georeference(path: Path) -> dict:
    """The map's JSON sidecar (``MAP.ext.json`` or ``MAP.json``), checked.

    Parameters
    ----------
    path : Path
        The map file (not the sidecar).

    Returns
    -------
    dict
        With ``origin`` or ``origin_lonlat``, ``cell_size`` and optionally ``row0``, ``scale``, ``offset``.
    """
    candidates = [_sidecar_name(path), path.with_suffix(".json")]
    side = next((c for c in candidates if c.is_file()), None)
    if side is None:
        raise InputError(f"{path}: no georeference; write {candidates[0].name} with origin (or origin_lonlat), "
                         "cell_size and row0")
    try:
        geo = json.loads(side.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{side}: not valid JSON ({exc})") from None
    if not isinstance(geo, dict):
        raise InputError(f"{side}: expected a JSON object with origin, cell_size and row0")
    known = {"origin", "origin_lonlat", "cell_size", "row0", "scale", "offset"}
    unknown = sorted(set(geo) - known)
    if unknown:
        raise InputError(f"{side}: unknown key {unknown[0]!r}; valid keys are {', '.join(sorted(known))}")
    if ("origin" in geo) == ("origin_lonlat" in geo):
        raise InputError(f"{side}: give exactly one of origin (metres) and origin_lonlat (degrees)")
    cell = geo.get("cell_size")
    if not isinstance(cell, (int, float)) or isinstance(cell, bool) or not np.isfinite(cell) or cell <= 0:
        raise InputError(f"{side}: cell_size must be a positive number of metres, got {cell!r}")
    if geo.get("row0", "north") not in ROW0:
        raise InputError(f"{side}: row0 must be one of {', '.join(ROW0)}, got {geo.get('row0')!r}")
    for key in ("scale", "offset"):
        v = geo.get(key, 0.0)
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not np.isfinite(v):
            raise InputError(f"{side}: {key} must be a finite number, got {v!r}")
    _pair(geo.get("origin", geo.get("origin_lonlat")), "origin" if "origin" in geo else "origin_lonlat", side)
    return geo


def _pair(value: object, key: str, where: Path) -> tuple[float, float]:
    if (not isinstance(value, (list, tuple)) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value)):
        raise InputError(f"{where}: {key} must be two finite numbers, got {value!r}")
    return float(value[0]), float(value[1])
