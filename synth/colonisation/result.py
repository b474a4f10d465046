"""What space colonisation returns: the grown streets, the joins to the old town, and the run's record."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from synth.colonisation.options import ColonisationOptions
from synth.flowfield import FlowField

# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class GrownStreet:
    """A new street: its node ids in :attr:`ColonisationResult.xy`, shape, level and highway class."""

    nodes: tuple[int, ...]
    xy: np.ndarray  # (k, 2) metres
    level: int
    highway: str


@dataclass(frozen=True)
class Join:
    """A node where new streets meet an old street.

    ``seed`` names the old street (its index in ``seeds``). When ``vertex`` is
    True the node is that street's vertex number ``segment`` (no split
    needed); otherwise it is a new point on the segment between its vertices
    ``segment`` and ``segment + 1``, where the integrator splits the real way.
    """

    node: int
    xy: tuple[float, float]
    seed: int
    segment: int
    vertex: bool


@dataclass(frozen=True)
class ColonisationResult:
    """What :func:`colonise` grew.

    ``xy`` holds every node of the grown graph (old-town nodes first, flagged
    in ``fixed``); ``edges`` the grown edges only, with their level and phase.
    """

    xy: np.ndarray  # (N, 2)
    fixed: np.ndarray  # (N,) bool: old-town nodes (never moved)
    edges: np.ndarray  # (E, 2) grown edges
    edge_level: np.ndarray  # (E,)
    edge_phase: np.ndarray  # (E,) 1 or 2
    streets: tuple[GrownStreet, ...]
    joins: tuple[Join, ...]
    attraction_xy: np.ndarray  # (M, 2) every regular AP introduced
    attraction_phase: np.ndarray  # (M,)
    attraction_alive: np.ndarray  # (M,) bool, at the end of its phase
    flow: FlowField | None
    options: ColonisationOptions
    report: dict[str, Any] = field(default_factory=dict)

    def polylines(self) -> list[tuple[int, np.ndarray]]:
        """(level, polyline) per street, like :meth:`synth.grow.GrowResult.polylines`."""
        return [(s.level, s.xy) for s in self.streets]

    def debug_features(self, *, flow_step: int = 1) -> list[dict[str, Any]]:
        """GeoJSON-ready features in metres: APs, flow grid and primitives, parameters (001 §5.1.2).

        Parameters
        ----------
        flow_step : int
            Draw every ``flow_step``-th flow grid cell in both directions.

        Returns
        -------
        list of dict
            ``{"type": "Feature", "geometry": ..., "properties": {"layer": ...}}``;
            layers ``attraction_point`` (phase, alive), ``flow_vector`` (a line
            from a cell centre along the unit flow, half a cell long; vx, vy,
            speed), ``flow_primitive`` (kind, strength, direction_deg) and
            ``parameters`` (no geometry; the options and the report).
        """
        feats: list[dict[str, Any]] = []
        for (x, y), ph, alive in zip(self.attraction_xy.tolist(), self.attraction_phase.tolist(),
                                     self.attraction_alive.tolist()):
            feats.append(_feature({"type": "Point", "coordinates": [x, y]},
                                  layer="attraction_point", phase=int(ph), alive=bool(alive)))
        if self.flow is not None:
            ny, nx = self.flow.vectors.shape[:2]
            centres = self.flow.centres().reshape(ny, nx, 2)[::flow_step, ::flow_step].reshape(-1, 2)
            vec = self.flow.vectors[::flow_step, ::flow_step].reshape(-1, 2)
            speed = np.hypot(vec[:, 0], vec[:, 1])
            unit = np.where(speed[:, None] > 0, vec / np.maximum(speed, 1e-300)[:, None], 0.0)
            tips = centres + unit * 0.5 * self.flow.cell * flow_step
            for c, t, v, s in zip(centres.tolist(), tips.tolist(), vec.tolist(), speed.tolist()):
                feats.append(_feature({"type": "LineString", "coordinates": [c, t]}, layer="flow_vector",
                                      vx=v[0], vy=v[1], speed=s))
            for p in self.flow.primitives:
                feats.append(_feature({"type": "Point", "coordinates": [p.x, p.y]}, layer="flow_primitive",
                                      **p.to_dict()))
        feats.append({"type": "Feature", "geometry": None,
                      "properties": {"layer": "parameters", "options": self.options.to_dict(),
                                     "report": self.report}})
        return feats


def _feature(geometry: dict[str, Any], **properties: Any) -> dict[str, Any]:
    return {"type": "Feature", "geometry": geometry, "properties": properties}
