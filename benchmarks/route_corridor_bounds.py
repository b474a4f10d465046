"""Issue 22: how small can the road search's corridor provably get? Measure only, nothing in the code uses it.

    python benchmarks/route_corridor_bounds.py capture fixtures/campo-grande.osm.gz 3 /tmp/cg   # /tmp/cg-0.pkl …
    python benchmarks/route_corridor_bounds.py measure /tmp/cg-0.pkl                      # runs find_route for C
    python benchmarks/route_corridor_bounds.py measure /tmp/syn-0.pkl --cost 28130.284484811113
    python benchmarks/route_corridor_bounds.py floor /tmp/cg-0.pkl --cost 8866.6061 --corridor /tmp/cg0.npy  # twice
    python benchmarks/route_corridor_bounds.py directions /tmp/cg-0.pkl [--backward] [--splits]

``capture`` runs the engine (:func:`benchmarks.engine_speed.measure`, 30 years) on a town and pickles
the inputs of its first N ``find_route`` calls (graph, source, target, keywords), then stops.
``measure`` builds the captured search's turn-free G′ over the whole map (the restricted matrix:
symmetric on the captured searches, so one Dijkstra per end or landmark) and counts the vertices
whose lower bound on a route through them stays at or below the found cost C — the corridor an
exact search would have to touch — for each candidate bound:

- the ellipse ``c·|s−v| + c·|v−t|`` and A*'s ``d_s + c·|v−t|`` (c: the cheapest cost a metre);
- ``d_s + d_t``, the turn-free two-end bound the search uses now;
- ``d_s + d_t`` plus the turns forced between the directions ``v − s`` and ``t − v``: the route's
  heading bins hold one within half a bin of each (:func:`routing._turn_floor`'s sector argument),
  so its turns cost at least ``need[m]`` for the m bins between them;
- a coarse lattice: the quotient graph over f × f tiles (:func:`routing._tile_of`), each pair of
  tiles joined by its cheapest G′ edge — a route's tile walk costs no more than the route;
- landmarks (ALT, farthest-first): ``d_s + h_t`` and ``h_s + h_t`` (known before any search).

``floor`` gives what no admissible bound can beat: the vertices whose best *turn-penalised*
route from s to t through them costs at most C (forward Dijkstras from both ends on the
heading-expanded graph over the ``d_s + d_t`` corridor, which holds every route ≤ C; routes
reverse at the same cost, so the best through v is ``min_ij f_s[arr(v,i)] + P(j−i) + f_t[arr(v,j+K/2)]``).
Its first run saves the corridor and stops, so that the whole-map matrix and the expanded graph
never share a process; run it again for the floor.

``directions`` replays the captured ``find_route`` forwards (``RoutingOptions.backward`` off, the
default) or with ``--backward`` (:func:`routing._backward_route`) and prints its cost, CPU, peak
memory and, per search function, the states of the heading-expanded graphs it made and settled;
``--route V.npy`` saves the route's vertices (to compare the two). With ``--splits`` each forward
route search's last graph is also searched from both ends: the states a search that meets in the
middle would settle, forward ``g_f ≤ a·C, g_f + d_t ≤ C`` plus backward ``g_b ≤ (1 − a)·C,
g_b + d_s ≤ C``, for a few shares a (a = 1: forward A*, a = 0: backward A*).

For each bound ``measure`` prints the corridor's vertices, the CPU of computing the bound, and the estimated
memory of a heading-expanded search over just that corridor (its CSR entries at 12 bytes, its
states' indptr, distance and predecessor at 20 bytes). With ``--route VERTICES.npy`` (the found
route's map vertices) it also checks that every bound keeps the route (admissibility).
"""

from __future__ import annotations

import argparse
import os
import pickle
import resource
import sys
import time
from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import osm_expand.engine.roads.routing as ro  # noqa: E402


def _peak_mb() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024


def capture(town: str, n: int, out: str) -> None:
    """Pickle the inputs of the engine's first ``n`` road searches on ``town``."""
    import osm_expand.engine.roads.road_types as rt
    from benchmarks.engine_speed import measure

    real = rt.find_route
    count = [0]

    def wrapper(graph, source, target, **kw):  # type: ignore[no-untyped-def]
        with open(f"{out}-{count[0]}.pkl", "wb") as f:
            pickle.dump((graph, source, target, kw), f, protocol=5)
        print("captured", count[0], f"{_peak_mb()} MB", file=sys.stderr, flush=True)
        count[0] += 1
        if count[0] >= n:
            raise SystemExit(0)
        return real(graph, source, target, **kw)

    rt.find_route = wrapper
    measure(Path(town), "example", 30, 0)


def _quotient(m: csr_matrix, tile: np.ndarray, n_tiles: int) -> csr_matrix:
    """The tiles' graph: each ordered pair of distinct tiles its cheapest finite edge (row blocks)."""
    def cheapest(key: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        order = np.lexsort((d, key))
        key, d = key[order], d[order]
        first = np.ones(len(key), dtype=bool)
        first[1:] = key[1:] != key[:-1]
        return key[first], d[first]

    keys, vals = [], []
    step = max(1, m.shape[0] // 16)
    for a in range(0, m.shape[0], step):
        sub = m[a:a + step].tocoo()
        fin = np.isfinite(sub.data)
        r, c, d = tile[sub.row[fin] + a], tile[sub.col[fin]], sub.data[fin]
        x = r != c
        key, d = cheapest(r[x].astype(np.int64) * n_tiles + c[x], d[x])
        keys.append(key)
        vals.append(d)
    key, d = cheapest(np.concatenate(keys), np.concatenate(vals))
    return csr_matrix((d, (key // n_tiles, key % n_tiles)), shape=(n_tiles, n_tiles))


def measure(path: str, cost: float | None, route_file: str | None, landmarks: int) -> None:
    with open(path, "rb") as f:
        graph, s, t, kw = pickle.load(f)
    if not hasattr(graph.lattice, "_shared"):  # lattices pickled before the cache existed
        object.__setattr__(graph.lattice, "_shared", {})
    opts = kw.get("options") or ro.RoutingOptions()
    if cost is None:
        c0 = time.process_time()
        found = ro.find_route(graph, s, t, **kw)
        if found is None:
            print("no route found", file=sys.stderr)
            raise SystemExit(2)
        cost = float(found.cost)
        print(f"find_route: cost {cost:.1f}, {time.process_time() - c0:.1f} s CPU, peak {_peak_mb()} MB", flush=True)
    c0 = time.process_time()
    window = graph.window(tuple(graph.lattice.bounds))
    g = window.graph
    ws, wt = window.from_map(np.array([s, t])).tolist()
    route = window.from_map(np.load(route_file)) if route_file else None
    with g.restricted(kw["kinds"], kw.get("street_ok")) as m:
        n = g.n_vertices
        print(f"{path}: C {cost:.1f}; whole-map G' {n:,} vertices, {m.nnz:,} entries, "
              f"{time.process_time() - c0:.1f} s CPU, peak {_peak_mb()} MB", flush=True)
        c0 = time.process_time()
        ds, dt = dijkstra(m, indices=ws), dijkstra(m, indices=wt)
        print(f"turn-free d_s, d_t: {time.process_time() - c0:.1f} s CPU; d(s,t) {ds[wt]:.1f}", flush=True)
        k = opts.heading_bins
        penalties = ro._bin_penalties(opts)
        n_turn = int(np.count_nonzero(penalties < penalties.max() - 1e-9)) + 1
        out_degree = np.diff(m.indptr)

        def report(name: str, lb: np.ndarray, how: str) -> None:
            sel = lb <= cost * (1 + 1e-9)
            on = int(np.count_nonzero(sel))
            entries = on * (k * n_turn + k) + int(out_degree[sel].sum())
            gb = (entries * 12 + on * (2 * k + 1) * 20) / 1e9
            if route is not None:
                how += f"; route's max lb − C {float((lb[route] - cost).max()):+.3f}"
            print(f"  {name:46s} {on:>10,} ({100 * on / n:4.1f} %)  search ~{gb:5.2f} GB  [{how}]", flush=True)

        unit = ro.cheapest_unit_cost(graph.costs, kw["kinds"])
        to_s, to_t = g.xy - g.xy[ws], g.xy[wt] - g.xy
        report("ellipse c|s-v| + c|v-t|", unit * (np.hypot(*to_s.T) + np.hypot(*to_t.T)), "free")
        report("d_s + c|v-t| (A*)", ds + unit * np.hypot(*to_t.T), "1 Dijkstra")
        report("d_s + d_t (now)", ds + dt, "2 Dijkstras")
        need = ro._turn_floor(penalties) if k % 2 == 0 else np.zeros(k // 2 + 1)
        delta = 2 * np.pi / k
        off = np.abs(np.angle(np.exp(1j * (np.arctan2(to_t[:, 1], to_t[:, 0]) - np.arctan2(to_s[:, 1], to_s[:, 0])))))
        bins = np.clip(np.ceil((off - delta - 1e-9) / delta), 0, k // 2).astype(np.int64)
        turn = np.where((np.hypot(*to_s.T) == 0) | (np.hypot(*to_t.T) == 0), 0.0, need[bins])
        print(f"  turn floor need[m]: {np.round(need, 1).tolist()}")
        report("d_s + d_t + turns dir(v-s) -> dir(t-v)", ds + dt + turn, "2 Dijkstras + O(n)")
        for f in (2, 4, 8):
            c0 = time.process_time()
            tile, shape = ro._tile_of(g, f)
            q = _quotient(m, tile, shape[0] * shape[1])
            built = time.process_time() - c0
            c0 = time.process_time()
            lb = (dijkstra(q, indices=tile[ws]) + dijkstra(q.T.tocsr(), indices=tile[wt]))[tile]
            how = (f"{q.shape[0]:,} tiles, {q.nnz:,} edges, built {built:.1f} s, "
                   f"2 Dijkstras {time.process_time() - c0:.2f} s")
            report(f"coarse {f}x{f}: D_s + D_t", lb, how)
            report(f"coarse {f}x{f} + turns", lb + turn, "same")
        c0 = time.process_time()
        dist: list[np.ndarray] = []
        nearest = np.full(n, np.inf)
        far = int(np.argmax(np.where(np.isfinite(ds), ds, -1.0)))
        for i in range(landmarks):
            d_l = dijkstra(m, indices=far).astype(np.float32)
            dist.append(d_l)
            nearest = np.minimum(nearest, d_l)
            far = int(np.argmax(np.where(np.isfinite(nearest), nearest, -1.0)))
            if i + 1 in (4, 8, 16, landmarks):
                spent = time.process_time() - c0
                d = np.array(dist)
                with np.errstate(invalid="ignore"):
                    h_t = np.nan_to_num(np.nanmax(np.abs(d - d[:, wt][:, None]), axis=0), nan=0.0, posinf=0.0)
                    h_s = np.nan_to_num(np.nanmax(np.abs(d - d[:, ws][:, None]), axis=0), nan=0.0, posinf=0.0)
                how = f"{i + 1} Dijkstras once per map {spent:.1f} s, {d.nbytes / 1e6:.0f} MB"
                report(f"ALT {i + 1}: d_s + h_t", ds + h_t, how)
                report(f"ALT {i + 1}: h_s + h_t (before any search)", h_s + h_t, "same")
                report(f"ALT {i + 1}: h_s + h_t + turns", h_s + h_t + turn, "same")
    print(f"peak {_peak_mb()} MB")


def floor(path: str, cost: float, corridor: str) -> None:
    with open(path, "rb") as f:
        graph, s, t, kw = pickle.load(f)
    if not hasattr(graph.lattice, "_shared"):
        object.__setattr__(graph.lattice, "_shared", {})
    opts = kw.get("options") or ro.RoutingOptions()
    window = graph.window(tuple(graph.lattice.bounds))
    g = window.graph
    ws, wt = window.from_map(np.array([s, t])).tolist()
    tol = cost * (1 + 1e-9) + 1e-3
    if not os.path.exists(corridor):
        with g.restricted(kw["kinds"], kw.get("street_ok")) as m:
            ds, dt = dijkstra(m, indices=ws), dijkstra(m, indices=wt)
        np.save(corridor, np.flatnonzero(ds + dt <= tol))
        print(f"saved the d_s + d_t corridor to {corridor} (peak {_peak_mb()} MB); run again for the floor")
        return
    region = np.load(corridor)
    k = opts.heading_bins
    per = 2 * k + 1
    penalties = ro._bin_penalties(opts)
    lat, extra = g.masks(kw["kinds"], kw.get("street_ok"))
    c0 = time.process_time()
    expanded, local = ro._expanded_graph(g, lat, extra, region, penalties, k)
    n = len(region)
    print(f"{path}: corridor {n:,}, expanded {expanded.shape[0]:,} states {expanded.nnz:,} entries, "
          f"{time.process_time() - c0:.1f} s CPU, peak {_peak_mb()} MB", flush=True)
    c0 = time.process_time()
    arrive = []
    for end in (ws, wt):
        d = dijkstra(expanded, indices=int(local[end]) * per + 2 * k, limit=tol)
        arrive.append(d.reshape(n, per)[:, :k].astype(np.float32))
    f_s, f_t = arrive
    print(f"  2 Dijkstras {time.process_time() - c0:.1f} s CPU; s→t {f_s[local[wt]].min():.3f} (C {cost:.3f})")
    del expanded
    towards_t = np.roll(f_t, -(k // 2), axis=1)  # [:, j]: leaving v on bin j, the rest of the way to t
    best = np.full(n, np.inf, dtype=np.float32)
    for q in range(k):  # a turn of q bins at v
        best = np.minimum(best, (f_s + np.float32(penalties[q]) + np.roll(towards_t, -q, axis=1)).min(axis=1))
    best[local[[ws, wt]]] = 0.0
    for share in (1.0, 1.01, 1.05):
        print(f"  best route through v ≤ {share:.2f} C: {int(np.count_nonzero(best <= share * tol)):,}")
    print(f"peak {_peak_mb()} MB")


def directions(path: str, backward: bool, splits: bool, route_file: str | None) -> None:
    """Replay a captured search forwards or backwards: cost, CPU, and the states made and settled."""
    from dataclasses import replace

    with open(path, "rb") as f:
        graph, s, t, kw = pickle.load(f)
    if not hasattr(graph.lattice, "_shared"):
        object.__setattr__(graph.lattice, "_shared", {})
    kw = dict(kw)
    kw["options"] = replace(kw.get("options") or ro.RoutingOptions(), backward=backward)
    k = kw["options"].heading_bins
    per = 2 * k + 1
    made: dict[str, list[int]] = {}  # caller: [graphs, states made, states settled]
    real = ro.dijkstra

    def counted(m, *args, **kwargs):  # type: ignore[no-untyped-def]
        out = real(m, *args, **kwargs)
        frame = sys._getframe(1)
        caller = frame.f_code.co_name
        if caller in ("_tiled_search", "_backward_route"):
            d = out[0] if isinstance(out, tuple) else out
            row = made.setdefault(caller, [0, 0, 0])
            row[0] += 1
            row[1] += m.shape[0]
            row[2] += int(np.count_nonzero(np.isfinite(d)))
            f = frame.f_locals
            if splits and caller == "_tiled_search" and f.get("target") is not None and \
                    kwargs.get("return_predecessors") and f["local"][f["target"]] >= 0:
                _splits(m, f, per, k, real)
        return out

    ro.dijkstra = counted
    c0 = time.process_time()
    try:
        route = ro.find_route(graph, s, t, **kw)
    finally:
        ro.dijkstra = real
    cpu = time.process_time() - c0
    print(f"{path} {'backward' if backward else 'forward'}: cost {None if route is None else repr(route.cost)}, "
          f"{cpu:.1f} s CPU, peak {_peak_mb()} MB")
    for caller, (n, states, settled) in made.items():
        print(f"  {caller:16s} {n:3d} expanded graphs, {states:>12,} states made, {settled:>12,} settled")
    if route_file and route is not None:
        np.save(route_file, route.vertices)


def _splits(m: csr_matrix, f: dict, per: int, k: int, real) -> None:  # type: ignore[no-untyped-def,type-arg]
    """The states a search from both ends would settle on a forward route search's graph (see ``directions``)."""
    verts, lower, h = f["verts"], f["lower"], f["h"]
    ends = int(f["local"][f["target"]]) * per + np.arange(k)
    fwd = real(m, indices=f["start"], limit=f["cost"] * (1 + 1e-9) + 1e-6)
    cost = float(fwd[ends].min())
    d_s, d_t = np.repeat(lower[verts] - h[verts], per), np.repeat(h[verts], per)
    bwd = real(m.T.tocsr(), indices=ends, min_only=True, limit=cost)
    shares = []
    for a in (1.0, 0.8, 0.5, 0.3, 0.1, 0.0):
        n_f = np.count_nonzero((fwd <= a * cost) & (fwd + d_t <= cost))
        n_b = np.count_nonzero((bwd <= (1 - a) * cost) & (bwd + d_s <= cost))
        shares.append(f"{a:.1f}: {n_f:,} + {n_b:,}")
    print(f"    graph {m.shape[0]:,} states, C {cost:.1f}, settled g <= C {int(np.isfinite(fwd).sum()):,}; "
          "both ends a: fwd + bwd  " + ", ".join(shares), flush=True)
    # bidirectional A* with the average potential p = (d_t − d_s)/2 (consistent both ways): each side
    # settles its reduced distance up to its share of C' = C + p(t) − p(s), which reaches g up to 2C − d
    fwd = real(m, indices=f["start"], limit=2 * cost)
    bwd = real(m.T.tocsr(), indices=ends, min_only=True, limit=2 * cost)
    p = (d_t - d_s) / 2
    p_s, p_t = float(p[f["start"]]), float(p[ends[0]])
    red_f, red_b, full = fwd + p - p_s, bwd + p_t - p, cost + p_t - p_s
    shares = [f"{a:.1f}: {np.count_nonzero(red_f <= a * full):,} + {np.count_nonzero(red_b <= (1 - a) * full):,}"
              for a in (1.0, 0.8, 0.5, 0.3, 0.1, 0.0)]
    print("      average potentials a: fwd + bwd  " + ", ".join(shares), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="mode", required=True)
    cap = sub.add_parser("capture")
    cap.add_argument("town")
    cap.add_argument("n", type=int)
    cap.add_argument("out")
    mea = sub.add_parser("measure")
    mea.add_argument("pickle")
    mea.add_argument("--cost", type=float, help="the found route's cost (else find_route runs first)")
    mea.add_argument("--route", help="the found route's map vertices (.npy), to check every bound keeps it")
    mea.add_argument("--landmarks", type=int, default=16)
    flo = sub.add_parser("floor")
    flo.add_argument("pickle")
    flo.add_argument("--cost", type=float, required=True)
    flo.add_argument("--corridor", required=True, help=".npy of the d_s + d_t corridor (made on the first run)")
    dire = sub.add_parser("directions")
    dire.add_argument("pickle")
    dire.add_argument("--backward", action="store_true", help="search from the target (RoutingOptions.backward)")
    dire.add_argument("--splits", action="store_true", help="count what a search from both ends would settle")
    dire.add_argument("--route", help="save the route's vertices (.npy)")
    args = parser.parse_args()
    os.environ.setdefault("PYTHONHASHSEED", "0")
    if args.mode == "capture":
        capture(args.town, args.n, args.out)
    elif args.mode == "directions":
        directions(args.pickle, args.backward, args.splits, args.route)
    elif args.mode == "floor":
        floor(args.pickle, args.cost, args.corridor)
    else:
        measure(args.pickle, args.cost, args.route, args.landmarks)


if __name__ == "__main__":
    main()
