"""The build-out on real towns: seconds, lots and buildings, footprints and heights against the town's, shares.

    python benchmarks/buildout.py [FILE ...] [--all] [--history NAME|all] [--years N] [--seed N]
                                  [--engine] [--xml DIR] [--referee PATH] [--json]

With ``--engine`` each run is what ``osm-expand FILE --history NAME`` runs
(the pipeline's district, then the engine's years: growth, traffic, major
roads and the build-out), and the build-out's own calls are timed, wall and
CPU seconds (the CPU time does not count what other processes take from a
shared machine): this is the issue's budget, lots and buildings of the
default Krems run ≤ 5 s.

Without it, for each town (default Krems; ``--all``: Krems, Monaco, Andorra,
north-bayreuth, Campo Grande) and history (default ``example``; ``all``: the
three bundled ones) it expands the town (the pipeline's district, not
timed), then runs the build-out alone: ``start_buildout`` once, then
``buildout_year`` for each of the history's years (50 by default) with the
history's yearly values. The years are stood in for: the district's streets start planned
and are built in random order over the first ten years (002 §2.2: lots come
at once, buildings when their street is built), traffic is a fixed daily
volume by highway class, and in year 10 an engine street is cut across the
largest block with buildings (demolition and healing), after which the
blocks are recomputed.

Prints per town and history: the seconds of ``start_buildout`` and of all
years (issue budget: ≤ 5 s for Krems with the default history), lots and
buildings made, demolished and substituted, the generated footprint-area
and height medians against the town's, each type's share against its goal,
lot-area quartiles against the configured bounds and the similarity check.
With ``--xml DIR`` the ``<urbanenvironment>`` is written there, validated
against the XSD, and judged by the referee (``--referee``, default
``/work/shared/tools/referee.py`` when it exists).
"""
from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import shapely

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # this checkout's packages, not an installed copy
FIXTURES = REPO / "fixtures"
TOWNS = ["krems.osm.gz", "monaco.osm.gz", "andorra.osm.pbf", "north-bayreuth.osm.gz", "campo-grande.osm.gz"]
REFEREE = Path("/work/shared/tools/referee.py")
#: Daily traffic by highway rank (motorway … tertiary); other streets 300.
TRAFFIC = {0: 20000.0, 1: 15000.0, 2: 8000.0, 3: 4000.0, 4: 2000.0}
#: Years over which the district's planned streets are built, and the year of the cut.
BUILD_YEARS, CUT_YEAR = 10, 10


def traffic_of(city) -> dict[int, float]:
    from osm_expand.model.highways import rank

    return {s.id: TRAFFIC.get(int(rank(s.highway)), 300.0) for s in city.network.streets}


def expanded(path: Path):
    from osm_expand.ingest import load
    from osm_expand.model import Status
    from osm_expand.pipeline import ExpandOptions, expand

    city = expand(load(path), ExpandOptions(seed=0, fidelity=False)).city
    net = city.network
    return city.replace(network=net.replace(streets=tuple(
        replace(s, status=Status.PLANNED) if s.is_new else s for s in net.streets)))


def build_some(city, order: list[int], share: float):
    """The city with the first ``share`` of ``order`` (street ids) built."""
    from osm_expand.model import Status

    built = set(order[:math.ceil(share * len(order))])
    return city.replace(network=city.network.replace(streets=tuple(
        replace(s, status=Status.BUILT) if s.id in built else s for s in city.network.streets)))


def cut_across(city, year: int):
    """An engine street across the largest block with generated buildings, joined to its streets at both ends."""
    from osm_expand.model import Origin, Status

    with_buildings = {b.lot for b in city.buildings if b.origin == Origin.ENGINE}
    lots = [lot for lot in city.lots if lot.id in with_buildings]
    if not lots:
        return city
    by_id = {b.id: b for b in city.blocks}
    net = city.network
    lines = shapely.STRtree([shapely.LineString(net.street_xy(s)) for s in net.streets])
    for block in sorted({by_id[lot.block] for lot in lots}, key=lambda b: (-b.polygon.area, b.id)):
        pts = _chord(block.polygon)
        if pts is None:
            continue
        inner = shapely.LineString(pts).interpolate(0.5, normalized=True).buffer(
            0.5 * np.hypot(*(pts[1] - pts[0])) - 0.5)  # the chord without its ends
        if not len(lines.query(shapely.LineString(pts).intersection(inner), predicate="intersects")):
            break  # a chord that crosses no street inside the block (a dead end would be crossed without a junction)
    else:
        return city
    pts = [pts[0], pts[1]]
    index = {s.id: k for k, s in enumerate(net.streets)}
    ends = []
    for p in (pts[0], pts[-1]):
        k = min((index[i] for i in set(block.street_ids) if i in index),
                key=lambda k: shapely.LineString(net.street_xy(net.streets[k])).distance(shapely.Point(p)))
        net, node = _insert(net, k, p)
        ends.append(net.xy[node])
    net = net.with_new_streets([np.array(ends)], [{"origin": Origin.ENGINE, "year": year, "highway": "residential",
                                                   "status": Status.BUILT}])
    return city.replace(network=net)


def _chord(poly) -> np.ndarray | None:
    """The chord across a block's long side through its centroid: (2, 2) ends on its outline, or None."""
    c = np.asarray(poly.centroid.coords[0])
    env = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)
    long_side = max([env[1] - env[0], env[2] - env[1]], key=lambda v: np.hypot(*v))
    axis = np.array([-long_side[1], long_side[0]]) / np.hypot(*long_side)  # across the long side
    far = 10 * math.sqrt(poly.area)
    hit = shapely.LineString([c - far * axis, c + far * axis]).intersection(poly.exterior)
    pts = sorted((np.asarray(p.coords[0]) for p in shapely.get_parts(hit)), key=lambda p: float((p - c) @ axis))
    return np.array(pts) if len(pts) == 2 else None  # a concave block's chord that leaves it is no chord


def _insert(net, k: int, point: np.ndarray):
    s = net.streets[k]
    xy = net.street_xy(s)
    at = shapely.LineString(xy).project(shapely.Point(point))
    cum = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    i = int(np.clip(np.searchsorted(cum, at) - 1, 0, len(xy) - 2))
    streets = list(net.streets)
    streets[k] = replace(s, nodes=s.nodes[:i + 1] + (len(net.xy),) + s.nodes[i + 1:])
    return net.replace(xy=np.vstack([net.xy, point]), node_ids=np.append(net.node_ids, 0),
                       streets=tuple(streets)), len(net.xy)


def run(path: Path, history_name: str, years: int | None, seed: int, xml: Path | None, referee: Path | None) -> dict:
    from osm_expand.blocks import blocks
    from osm_expand.engine.buildout.year import BuildoutYear, buildout_report, buildout_year, start_buildout
    from osm_expand.engine.history import load_history

    city = expanded(path)
    history = load_history(history_name)
    years = history.years if years is None else years
    rng = np.random.default_rng(seed)
    order = [int(i) for i in rng.permutation([s.id for s in city.network.streets if s.is_new])]
    city = city.replace(blocks=tuple(blocks(city.network, year=city.year)))
    clock = history.clock(city.year)
    t0 = time.perf_counter()
    memory = start_buildout(city, history, rng)
    t_start = time.perf_counter() - t0
    total, t_years, slowest = BuildoutYear(), 0.0, 0.0
    for step in range(years):
        year = clock.calendar_year(step)
        city = build_some(city, order, min(1.0, (step + 1) / BUILD_YEARS))
        if step == CUT_YEAR:
            city = cut_across(city, year)
            city = city.replace(blocks=tuple(blocks(city.network, year=year)))
        now = history.values_at(clock.history_year(step))
        t1 = time.perf_counter()
        city, memory, report = buildout_year(city, memory, history, now, rng, year=year, traffic=traffic_of(city))
        dt = time.perf_counter() - t1
        t_years += dt
        slowest = max(slowest, dt)
        total = total + report
    t1 = time.perf_counter()
    summary = buildout_report(city, memory, history)
    t_report = time.perf_counter() - t1
    out = {"town": path.name, "history": history_name, "years": years,
           "seconds": {"start": round(t_start, 2), "years": round(t_years, 2), "slowest_year": round(slowest, 3),
                       "report": round(t_report, 2), "total": round(t_start + t_years, 2)},
           "totals": total.to_dict(), "report": summary}
    if xml is not None:
        out["xml"] = write_and_judge(city, xml / f"{path.name.split('.')[0]}-{history_name}.xml", referee)
    return out


def engine_run(path: Path, history_name: str, years: int | None, seed: int, xml: Path | None,
               referee: Path | None) -> dict:
    """The CLI's run (district, then the engine's years) with the build-out's calls timed, wall and CPU."""
    import osm_expand.engine.loop as loop
    from osm_expand.engine.buildout.year import buildout_report, buildout_year, start_buildout
    from osm_expand.engine.history import load_history
    from osm_expand.ingest import load
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.pipeline import ExpandOptions, expand

    clock = {"wall": 0.0, "cpu": 0.0, "years": 0, "slowest": 0.0}

    def timed(fn, count=False):
        def call(*args, **kwargs):
            w, c = time.perf_counter(), time.process_time()
            out = fn(*args, **kwargs)
            dw = time.perf_counter() - w
            clock["wall"] += dw
            clock["cpu"] += time.process_time() - c
            if count:
                clock["years"] += 1
                clock["slowest"] = max(clock["slowest"], dw)
            return out
        return call

    box = {}

    def report(city, memory, history):
        box["city"] = city
        return buildout_report(city, memory, history)

    # the loop's own names for the build-out's calls, timed (a benchmark's patch: the loop calls them directly)
    loop.start_buildout, loop.buildout_year, loop.buildout_report = (timed(start_buildout), timed(buildout_year, True),
                                                                     report)
    w, c = time.perf_counter(), time.process_time()
    result = mature_result(expand(load(path), ExpandOptions(seed=seed)), load_history(history_name),
                           MatureOptions(years=years), seed)
    engine = result.report["engine"]
    out = {"town": path.name, "history": history_name, "years": engine["years"],
           "seconds": {"buildout_wall": round(clock["wall"], 2), "buildout_cpu": round(clock["cpu"], 2),
                       "slowest_year": round(clock["slowest"], 3), "run_wall": round(time.perf_counter() - w, 2),
                       "run_cpu": round(time.process_time() - c, 2),
                       "engine": {k: round(v, 2) for k, v in engine["seconds"].items()}},
           "report": engine["buildout"]}
    if xml is not None:
        out["xml"] = write_and_judge(box["city"], xml / f"{path.name.split('.')[0]}-{history_name}.xml", referee)
    return out


def write_and_judge(city, out: Path, referee: Path | None) -> dict:
    from osm_expand.export.urban import validate, write_urbanenvironment

    out.parent.mkdir(parents=True, exist_ok=True)
    write_urbanenvironment(city, out)
    result = {"path": str(out), "schema_errors": len(validate(out))}
    if referee is not None and referee.exists():
        done = subprocess.run([sys.executable, str(referee), "urban", str(out)], capture_output=True, text=True)
        verdict = json.loads(done.stdout)
        result["referee_violations"] = verdict["violations"]
        result["referee_counts"] = verdict["counts"]
    return result


def show(r: dict) -> None:
    rep, sec = r["report"], r["seconds"]
    b = rep["buildings"]
    if "totals" in r:
        tot = r["totals"]
        print(f"{r['town']} / {r['history']} ({r['years']} years): start {sec['start']} s, years {sec['years']} s "
              f"(slowest {sec['slowest_year']} s), total {sec['total']} s; report {sec['report']} s")
        print(f"  lots {rep['lots']['count']} (made {tot['lots_made']}, demolished {tot['lots_demolished']}), "
              f"generated buildings {b['generated']} (built {tot['buildings_built']}, demolished "
              f"{tot['buildings_demolished']}, substituted {tot['buildings_substituted']}), town's {b['town']}")
    else:
        print(f"{r['town']} / {r['history']} ({r['years']} years, engine): build-out {sec['buildout_wall']} s wall, "
              f"{sec['buildout_cpu']} s CPU (slowest year {sec['slowest_year']} s); whole run {sec['run_wall']} s "
              f"wall, {sec['run_cpu']} s CPU; engine stages {sec['engine']}")
        print(f"  lots {rep['lots']['count']}, generated buildings {b['generated']}, town's {b['town']}")
    fm, hm = b["footprint_median_m2"], b["height_median_m"]
    if fm["generated"]:
        print(f"  footprint median {fm['generated']} m² vs town {fm['town']} m² "
              f"({100 * (fm['generated'] / fm['town'] - 1):+.1f} %); height median {hm['generated']} m vs "
              f"{'town ' + str(hm['town']) if hm['town'] else 'target ' + str(hm['target'])} m "
              f"(storey {b['storey_height_m']} m, {b['tagged_buildings']} tagged)")
    lu = rep["land_use"]
    shares = ", ".join(f"{k} {v['share']:.3f}/{v['goal']:.3f}" for k, v in lu["types"].items())
    print(f"  shares/goals: {shares}; max deviation {lu['max_share_deviation']}")
    for k, v in rep["lots"]["types"].items():
        if v["count"]:
            print(f"  lots {k:17s} n={v['count']:4d} quartiles {v['area_quartiles_m2']} m² bounds {v['bounds_m2']}")
    if rep["similarity"]:
        s = rep["similarity"]
        print(f"  similarity (002 Eq. 12–13, n={s['n']}, {s['cell_m']} m): simulated {s['simulated']} vs "
              f"shuffled {s['shuffled']}; cell-wise agreement {s['cellwise_agreement']}")
    if "xml" in r:
        print(f"  xml: {r['xml']}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", type=Path)
    ap.add_argument("--all", action="store_true", help="Krems, Monaco, Andorra, north-bayreuth, Campo Grande")
    ap.add_argument("--history", default="example", help="a bundled history, a TOML file, or 'all'")
    ap.add_argument("--years", type=int, default=None, help="default: the history's")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--xml", type=Path, default=None, help="write, validate and referee the XML in this folder")
    ap.add_argument("--referee", type=Path, default=REFEREE)
    ap.add_argument("--json", action="store_true", help="one JSON object per run on stdout")
    ap.add_argument("--engine", action="store_true", help="the CLI's run (the engine's years), build-out timed")
    args = ap.parse_args()
    files = args.files or [FIXTURES / t for t in (TOWNS if args.all else TOWNS[:1])]
    histories = ["example", "european", "north-american"] if args.history == "all" else [args.history]
    for path in files:
        for name in histories:
            r = (engine_run if args.engine else run)(path, name, args.years, args.seed, args.xml, args.referee)
            print(json.dumps(r)) if args.json else show(r)
            sys.stdout.flush()


if __name__ == "__main__":
    main()
