"""Flow fields for street growth: Wejchert–Haumann flow primitives summed on a grid.

Seed 001 §4.3.2 steers new street segments with a 2-D vector field built from
the potential-flow primitives of Wejchert and Haumann (1991, "Animation
aerodynamics"). In polar coordinates around a primitive at ``(x0, y0)``:

* **uniform** flow of speed ``U`` along heading ``α``: potential
  ``φ = U (x cos α + y sin α)``, velocity ``v = U (cos α, sin α)`` everywhere
  (the primitive has no position; 001 only says "flow in straight lines,
  parallel to the direction specified by the primitive");
* **source**: ``φ = a/(2π) ln r``, ``v_r = a / (2π r)``, ``v_θ = 0`` (eq. 4);
* **sink**: the same with ``a < 0``, so the flow points at the primitive;
* **vortex**: ``φ = b/(2π) θ``, ``v_r = 0``, ``v_θ = b / (2π r)`` (eq. 5),
  counter-clockwise for ``b > 0`` (001's ``θ_vortex = θ + π/2``), clockwise
  for ``b < 0``.

Each primitive's velocity is evaluated at the grid's cell centres and summed
(001 eq. 6; here ``r`` is in metres, not grid cells, so a field does not
change when its grid is refined). The singularity at ``r = 0`` is replaced by
a Rankine core: inside ``core`` metres the speed grows linearly from zero,
``|v| = |a| r / (2π core²)``, which meets ``|a| / (2π r)`` at ``r = core``.
Strengths are in m²/s-like units for source, sink and vortex (speed × distance)
and m/s for uniform flow: only their ratios matter, since growth uses the
field's direction. The field is sampled between cell centres by bilinear
interpolation of both components.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from enum import StrEnum

import numpy as np

from osm_expand.errors import InputError

__all__ = ["FlowField", "FlowPrimitive", "PrimitiveKind", "flow_field", "primitive_velocity"]


class PrimitiveKind(StrEnum):
    """The flow primitives of 001 §4.3.2."""

    UNIFORM = "uniform"
    SOURCE = "source"
    SINK = "sink"
    VORTEX = "vortex"


@dataclass(frozen=True)
class FlowPrimitive:
    """One flow primitive.

    Parameters
    ----------
    kind : str
        ``"uniform"``, ``"source"``, ``"sink"`` or ``"vortex"``.
    x, y : float
        Position in metres (local projection); ignored for uniform flow.
    strength : float
        Uniform: speed ``U``; source/sink: ``|a|`` (a sink always uses
        ``a = -|strength|``, a source ``a = +|strength|``); vortex: ``b``,
        counter-clockwise when positive, clockwise when negative.
    direction_deg : float
        Uniform flow only: heading in degrees counter-clockwise from east.
    """

    kind: str
    x: float = 0.0
    y: float = 0.0
    strength: float = 1.0
    direction_deg: float = 0.0

    def __post_init__(self) -> None:
        valid = [k.value for k in PrimitiveKind]
        if self.kind not in valid:
            raise InputError(f"flow primitive kind {self.kind!r} is not one of {', '.join(valid)}")
        if not np.isfinite([self.x, self.y, self.strength, self.direction_deg]).all():
            raise InputError(f"flow primitive {self.kind}: position, strength and direction must be finite")

    def to_dict(self) -> dict[str, float | str]:
        """The primitive as plain JSON values."""
        return asdict(self)


def primitive_velocity(primitive: FlowPrimitive, xy: np.ndarray, *, core: float) -> np.ndarray:
    """The primitive's velocity at points (001 eqs. 4-6).

    Parameters
    ----------
    primitive : FlowPrimitive
        The primitive.
    xy : ndarray, shape (N, 2)
        Points in metres.
    core : float
        Radius of the Rankine core in metres (> 0): the speed of a source,
        sink or vortex falls linearly to zero inside it, so ``r = 0`` gives
        a zero vector, never a division by zero.

    Returns
    -------
    ndarray, shape (N, 2)
        Velocity vectors.
    """
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    kind = PrimitiveKind(primitive.kind)
    if kind is PrimitiveKind.UNIFORM:
        a = np.radians(primitive.direction_deg)
        return np.tile([primitive.strength * np.cos(a), primitive.strength * np.sin(a)], (len(xy), 1))
    rel = xy - [primitive.x, primitive.y]
    r = np.hypot(rel[:, 0], rel[:, 1])
    # speed / r, so that speed · (unit radial) = (speed / r) · rel; Rankine core inside ``core``
    with np.errstate(divide="ignore", invalid="ignore"):
        per_r = np.where(r >= core, 1.0 / (2 * np.pi * np.maximum(r, core) ** 2), 1.0 / (2 * np.pi * core ** 2))
    if kind is PrimitiveKind.VORTEX:
        tangent = np.column_stack([-rel[:, 1], rel[:, 0]])  # counter-clockwise
        return primitive.strength * per_r[:, None] * tangent
    a = abs(primitive.strength) if kind is PrimitiveKind.SOURCE else -abs(primitive.strength)
    return a * per_r[:, None] * rel


@dataclass(frozen=True)
class FlowField:
    """Summed primitive velocities on a regular grid.

    ``vectors[i, j]`` is the velocity at the centre of cell ``(i, j)``:
    ``x = origin[0] + (j + 0.5) cell``, ``y = origin[1] + (i + 0.5) cell``
    (row 0 is the southern row).
    """

    origin: tuple[float, float]
    cell: float
    vectors: np.ndarray  # (ny, nx, 2)
    primitives: tuple[FlowPrimitive, ...]

    def centres(self) -> np.ndarray:
        """Cell centres, shape (ny · nx, 2), row by row from the south-west."""
        ny, nx = self.vectors.shape[:2]
        gx, gy = np.meshgrid(self.origin[0] + (np.arange(nx) + 0.5) * self.cell,
                             self.origin[1] + (np.arange(ny) + 0.5) * self.cell)
        return np.column_stack([gx.ravel(), gy.ravel()])

    def sample(self, xy: np.ndarray) -> np.ndarray:
        """Velocity at points by bilinear interpolation (clamped at the grid's edge).

        Parameters
        ----------
        xy : ndarray, shape (N, 2)
            Points in metres.

        Returns
        -------
        ndarray, shape (N, 2)
        """
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        ny, nx = self.vectors.shape[:2]
        fx = np.clip((xy[:, 0] - self.origin[0]) / self.cell - 0.5, 0.0, nx - 1.0)
        fy = np.clip((xy[:, 1] - self.origin[1]) / self.cell - 0.5, 0.0, ny - 1.0)
        j0 = np.minimum(np.floor(fx).astype(np.int64), max(nx - 2, 0))
        i0 = np.minimum(np.floor(fy).astype(np.int64), max(ny - 2, 0))
        j1, i1 = np.minimum(j0 + 1, nx - 1), np.minimum(i0 + 1, ny - 1)
        tx, ty = (fx - j0)[:, None], (fy - i0)[:, None]
        v = self.vectors
        return ((1 - ty) * ((1 - tx) * v[i0, j0] + tx * v[i0, j1])
                + ty * ((1 - tx) * v[i1, j0] + tx * v[i1, j1]))

    def direction(self, xy: np.ndarray, *, floor: float = 1e-12) -> np.ndarray:
        """Unit flow directions at points; a zero vector where the speed is below ``floor``.

        Parameters
        ----------
        xy : ndarray, shape (N, 2)
            Points in metres.
        floor : float
            Speeds at or below this have no direction (a stagnation point).

        Returns
        -------
        ndarray, shape (N, 2)
        """
        v = self.sample(xy)
        speed = np.hypot(v[:, 0], v[:, 1])
        out = np.zeros_like(v)
        ok = speed > floor
        out[ok] = v[ok] / speed[ok, None]
        return out


def flow_field(primitives: Sequence[FlowPrimitive], *, bounds: tuple[float, float, float, float],
               cell: float, core: float | None = None) -> FlowField:
    """Sum the primitives on a grid covering ``bounds`` (001 eq. 6).

    Parameters
    ----------
    primitives : sequence of FlowPrimitive
        The primitives; an empty sequence gives a zero field.
    bounds : (xmin, ymin, xmax, ymax)
        Area to cover, metres.
    cell : float
        Grid spacing in metres (> 0).
    core : float, optional
        Rankine core radius in metres; default one cell.

    Returns
    -------
    FlowField
    """
    if not cell > 0:
        raise InputError(f"flow field cell size must be positive, got {cell}")
    x0, y0, x1, y1 = (float(v) for v in bounds)
    nx = max(int(np.ceil((x1 - x0) / cell)), 1)
    ny = max(int(np.ceil((y1 - y0) / cell)), 1)
    empty = FlowField(origin=(x0, y0), cell=float(cell), vectors=np.zeros((ny, nx, 2)), primitives=tuple(primitives))
    pts = empty.centres()
    total = np.zeros_like(pts)
    for p in primitives:
        total += primitive_velocity(p, pts, core=cell if core is None else core)
    return FlowField(origin=(x0, y0), cell=float(cell), vectors=total.reshape(ny, nx, 2),
                     primitives=tuple(primitives))
