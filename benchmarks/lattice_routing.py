"""Build time of the pathfinding lattice G and of G′, and route time across them.

    python benchmarks/lattice_routing.py [--sizes 2500 5000 10000] [--repeat N] [--krems]

Each map is a square of the given side (metres) with a 150 m wide river
across it and a grid town (100 m blocks) in its middle, a fifth of the side
wide, with one major street through it. Printed per map, in seconds (best of
``--repeat``; CPU time of this process, then wall time):

- ``lattice``: :func:`build_lattice` (once per map: its rasters and bridges; the
  land, water and harbour edges are generated with G′),
- ``B``: :func:`built_up_area` and :meth:`Lattice.with_built_up` (each year),
- ``G′``: :func:`pathfinding_graph` (each year that proposes a road),
- ``CSR``: the cached adjacency matrix of G′ (first route of the year),
- ``route``: one turn-penalised city road corner to corner across the river,
  with the matrix already cached (each proposal), and ``plan`` for building it.

``--krems`` also times the same steps on fixtures/krems.osm.gz (its streets
and the Danube). The machine may be shared: CPU time is the steadier figure.
"""
from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import shapely

from osm_expand.engine.roads.built_up import built_up_area
from osm_expand.engine.roads.lattice import LatticeOptions, Raster, build_lattice
from osm_expand.engine.roads.path_graph import pathfinding_graph
from osm_expand.engine.roads.road_types import RoadType, plan_major_road, propose_route
from osm_expand.model.segments import SegmentTable

REPO = Path(__file__).resolve().parent.parent


def timed(work: Callable[[], object], repeat: int) -> tuple[object, float, float]:
    """Result, best CPU seconds and best wall seconds over ``repeat`` runs."""
    cpu, wall, result = [], [], None
    for _ in range(repeat):
        c, w = time.process_time(), time.perf_counter()
        result = work()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    return result, min(cpu), min(wall)


def synthetic_map(side: float) -> tuple[tuple[float, float, float, float], Raster, SegmentTable, list]:
    """A river across the map and a grid town in the middle (lines noded at every crossing)."""
    extent = (0.0, 0.0, side, side)
    cell = 10.0
    n = int(side / cell)
    ys = (np.arange(n) + 0.5) * cell
    xs = (np.arange(n) + 0.5) * cell
    yy, xx = np.meshgrid(ys, xs, indexing="ij")
    water = Raster(np.abs(yy - 0.3 * side - 0.1 * (xx - side / 2)) < 75.0, (0.0, 0.0), cell)
    blocks = max(int(side / 5 / 100), 2)
    x0 = y0 = side / 2 - blocks * 50.0
    ticks = np.arange(blocks + 1) * 100.0
    lines, major = [], []
    for k, t in enumerate(ticks):
        lines.append(np.stack([x0 + ticks, np.full(blocks + 1, y0 + t)], axis=1))
        lines.append(np.stack([np.full(blocks + 1, x0 + t), y0 + ticks], axis=1))
        major += [k == blocks // 2, False]
    segs = SegmentTable.from_lines(lines, major=major, width=[8.0] * len(lines))
    faces = list(shapely.get_parts(shapely.polygonize(list(segs.lines()))))
    return extent, water, segs, faces


def krems_map() -> tuple[tuple[float, float, float, float], Raster, SegmentTable, list]:
    """Krems: its streets (tertiary and above major), faces as blocks, the Danube."""
    from osm_expand.ingest import load
    town = load(REPO / "fixtures" / "krems.osm.gz")
    net, wet = town.network, town.water_geometry()
    major = [s.highway.removesuffix("_link") in {"motorway", "trunk", "primary", "secondary", "tertiary"}
             for s in net.streets]
    segs = SegmentTable.from_lines([net.street_xy(s) for s in net.streets], major=major,
                               width=[12.0 if m else 6.0 for m in major], bridge=[s.bridge for s in net.streets])
    (x0, y0), (x1, y1) = net.xy.min(axis=0) - 100, net.xy.max(axis=0) + 100
    extent = (float(x0), float(y0), float(x1), float(y1))
    water = Raster.from_geometry(wet, extent, cell=10.0)
    return extent, water, segs, list(shapely.get_parts(shapely.polygonize(list(segs.lines()))))


def run(name: str, extent, water: Raster, segs: SegmentTable, faces: list, repeat: int) -> None:
    lattice, lat_cpu, lat_wall = timed(lambda: build_lattice(extent, water=water, options=LatticeOptions()), repeat)
    (built, cut), b_cpu, b_wall = timed(lambda: _with_b(lattice, faces, segs), repeat)
    graph, g_cpu, g_wall = timed(lambda: pathfinding_graph(cut, segs, built), repeat)
    _, m_cpu, m_wall = timed(lambda: graph._csr(*graph.masks()), repeat)
    graph.matrix()
    x0, y0, x1, y1 = extent
    source = graph.nearest_vertex([x0 + 0.05 * (x1 - x0), y0 + 0.05 * (y1 - y0)])
    target = graph.nearest_vertex([x1 - 0.05 * (x1 - x0), y1 - 0.05 * (y1 - y0)])
    route, r_cpu, r_wall = timed(lambda: propose_route(graph, source, target, RoadType.CITY), repeat)
    plan, p_cpu, p_wall = timed(lambda: plan_major_road(graph, route, RoadType.CITY, 12.0), repeat)
    ny, nx = lattice.shape
    edges = int((lattice.unit_kind != 255).sum()) + len(lattice.bridge_src)
    print(f"{name:>10} {ny * nx:>8} {edges:>9} {len(segs.uv):>6} "
          f"{lat_cpu:6.2f}/{lat_wall:<6.2f} {b_cpu:6.2f}/{b_wall:<6.2f} {g_cpu:6.2f}/{g_wall:<6.2f} "
          f"{m_cpu:6.2f}/{m_wall:<6.2f} {r_cpu:6.2f}/{r_wall:<6.2f} {p_cpu:6.2f}/{p_wall:<6.2f} "
          f"{route.length:8.0f} {plan.bridges:3d}")


def _with_b(lattice, faces, segs):
    built = built_up_area(faces, segs)
    return built, lattice.with_built_up(built.area)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[2500.0, 5000.0, 10000.0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--krems", action="store_true")
    args = parser.parse_args()
    print("seconds as CPU/wall; route = one city road corner to corner, CSR cached")
    print(f"{'map':>10} {'vertices':>8} {'edges':>9} {'segs':>6} {'lattice':>13} {'B':>13} {'G′':>13} "
          f"{'CSR':>13} {'route':>13} {'plan':>13} {'length':>8} {'br':>3}")
    for side in args.sizes:
        run(f"{side / 1000:g} km", *synthetic_map(side), args.repeat)
    if args.krems:
        run("krems", *krems_map(), args.repeat)


if __name__ == "__main__":
    main()
