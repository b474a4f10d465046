"""The growing network's memory: nodes, segments and their index, and the attraction points."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from synth.colonisation.options import TERTIARY
from synth.segment_index import SegmentIndex

# --------------------------------------------------------------------------- the growing network


class _Network:
    """Nodes, edges and the segment index of the network being grown (old streets included)."""

    def __init__(self, cell: float):
        self.xy = np.zeros((1024, 2))
        self.n = 0
        #: failed attempts in a row, retired for the phase, never grows (an old-street node outside the region)
        self.fails = np.zeros(1024, dtype=np.int64)
        self.retired = np.zeros(1024, dtype=bool)
        self.static = np.zeros(1024, dtype=bool)
        self.fixed: list[bool] = []
        self.through: list[bool] = []  # a node inside a street (seed vertex, split point): no parent direction
        self.parent: list[int] = []
        self.phase: list[int] = []
        self.seed_ref: list[tuple[int, int, bool] | None] = []
        self.creator: list[int] = []  # the edge whose growth created the node, else -1
        self.adj: list[dict[int, int]] = []
        self.eu: list[int] = []
        self.ev: list[int] = []
        self.elevel: list[int] = []
        self.ephase: list[int] = []
        self.eseed: list[tuple[int, int]] = []
        self.ealive: list[bool] = []
        self.eslot: list[int] = []
        self.eorigin: list[int] = []  # the grown edge a split half came from (itself otherwise)
        self.index = SegmentIndex(cell)

    def add_node(self, p: np.ndarray, *, fixed: bool = False, through: bool = False, parent: int = -1,
                 phase: int = 0, seed_ref: tuple[int, int, bool] | None = None, creator: int = -1) -> int:
        if self.n == len(self.xy):
            self.xy = np.vstack([self.xy, np.zeros_like(self.xy)])
            for name in ("fails", "retired", "static"):
                old = getattr(self, name)
                setattr(self, name, np.concatenate([old, np.zeros_like(old)]))
        k = self.n
        self.xy[k] = p
        self.n += 1
        self.fixed.append(fixed)
        self.through.append(through)
        self.parent.append(parent)
        self.phase.append(phase)
        self.seed_ref.append(seed_ref)
        self.creator.append(creator)
        self.adj.append({})
        return k

    def add_edge(self, u: int, v: int, *, level: int, phase: int, seed: tuple[int, int] = (-1, -1),
                 origin: int = -1) -> int:
        e = len(self.eu)
        self.eorigin.append(e if origin < 0 else origin)
        self.eu.append(u)
        self.ev.append(v)
        self.elevel.append(level)
        self.ephase.append(phase)
        self.eseed.append(seed)
        self.ealive.append(True)
        self.eslot.append(self.index.add(self.xy[u].copy(), self.xy[v].copy(), u, v))
        self.adj[u][v] = e
        self.adj[v][u] = e
        return e

    def remove_edge(self, e: int) -> None:
        self.ealive[e] = False
        self.index.remove(self.eslot[e])
        u, v = self.eu[e], self.ev[e]
        del self.adj[u][v], self.adj[v][u]

    def node_level(self, m: int) -> int:
        """A node's hierarchy: the most important level of the roads it joins (001 §4.1.3)."""
        return min((self.elevel[e] for e in self.adj[m].values()), default=TERTIARY + 1)

    def directions(self, m: int, at: np.ndarray | None = None) -> np.ndarray:
        """Unit vectors from node ``m`` (or from ``at``) to each neighbour, shape (k, 2)."""
        if not self.adj[m]:
            return np.zeros((0, 2))
        nb = np.fromiter(self.adj[m].keys(), dtype=np.int64)
        d = self.xy[nb] - (self.xy[m] if at is None else at)
        return d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-12)[:, None]

    def segments_near(self, p: np.ndarray, radius: float) -> np.ndarray:
        """Slots of the index's live segments whose grid cells come within ``radius`` of ``p``."""
        idx = self.index
        lo = np.floor((p - radius) / idx.cell).astype(int)
        hi = np.floor((p + radius) / idx.cell).astype(int)
        found: list[int] = []
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                found.extend(idx.grid.get((i, j), ()))
        if not found:
            return np.zeros(0, dtype=np.int64)
        slots = np.unique(np.asarray(found, dtype=np.int64))
        return slots[idx.active[slots]]


# --------------------------------------------------------------------------- the kernel


@dataclass
class _APs:
    """One phase's attractors: scattered points, and (phase 2) phase-1 nodes."""

    xy: np.ndarray  # (M, 2)
    node: np.ndarray  # (M,) node id for a node attractor, else -1
    alive: np.ndarray
    active: np.ndarray  # within RoI of some node at some time: the only ones worth a query
    tree: cKDTree
