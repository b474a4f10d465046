"""Seconds per simulated year of the land-use update and the economy (seed 002 §4, §5.2–5.4).

    python benchmarks/landuse_speed.py [--sizes 1000,5000,20000] [--years 3] [--seed 0]

Synthetic lots on a jittered 30 m grid (400–1200 m² each, so ~330 lots fall
within the 256 m influence radius), one centre, a river, a forest, traffic
concentrated on two main axes. Per size it times, best of ``--years`` years
after one warm-up year that settles the shares:

- ``layout``: :func:`lot_attributes` + :func:`lot_layout` (k-nearest lots,
  the sparse influence kernel); rebuilt when the lots change;
- ``update``: one :func:`update_land_use` with ``sample_share = 1`` (002:
  50 % of the lots per six months);
- ``economy``: :func:`lot_economy` (prices, margins, floors, heights,
  occupants) and :func:`substitute`.

Prints one row per size and the shares' largest distance from the goals.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import shapely

from osm_expand.engine.buildout import economy as ec
from osm_expand.engine.buildout import landuse as lu
from osm_expand.engine.buildout import landuse_types as lt
from osm_expand.engine.buildout import lot_values as lv


def synthetic_lots(n: int, rng: np.random.Generator) -> dict:
    side = int(np.ceil(np.sqrt(n)))
    xy = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:n] * 30.0
    xy = xy + rng.normal(0, 4, xy.shape)
    extent = side * 30.0
    centre = xy.mean(axis=0)
    traffic = (np.exp(-np.abs(xy[:, 0] - centre[0]) / 40) + np.exp(-np.abs(xy[:, 1] - centre[1]) / 40)) * 1000
    return {
        "xy": xy, "area": rng.uniform(400, 1200, n), "centre": centre[None, :],
        "traffic": traffic + rng.gamma(1.0, 30.0, n),
        "water": [shapely.LineString([(0, 0.4 * extent), (extent, 0.5 * extent)]).buffer(15)],
        "green": [shapely.box(0.8 * extent, 0.8 * extent, extent, extent)],
    }


def run(n: int, years: int, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    lots = synthetic_lots(n, rng)
    t0 = time.perf_counter()
    attrs = lv.lot_attributes(lots["xy"], centres=lots["centre"], water=lots["water"], green=lots["green"],
                              traffic=lots["traffic"])
    layout = lv.lot_layout(lots["xy"], lots["area"], attrs)
    t_layout = time.perf_counter() - t0
    lut = lu.assign_types(layout, np.full(n, lt.UNASSIGNED), types=lt.DEFAULT_TYPES, rng=rng)
    calibration = ec.calibrate_heights(np.full(1, np.nan), np.full(1, np.nan))
    envelope = lots["area"] * 0.35
    scale = None
    year_built = np.full(n, 1950.0)
    floor_space = envelope * 2
    best = {"update": np.inf, "economy": np.inf}
    accepted = 0
    for year in range(years + 1):
        t0 = time.perf_counter()
        result = lu.update_land_use(layout, lut, types=lt.DEFAULT_TYPES, rng=rng)
        t1 = time.perf_counter()
        econ = ec.lot_economy(lots["area"], envelope, result.luv, result.lut, attrs[:, 0], avgprice=100.0,
                              calibration=calibration, scale=scale, rng=rng)
        sub = ec.substitute(year_built, econ.floors * envelope, floor_space, year=2000 + year, rng=rng)
        t2 = time.perf_counter()
        scale, lut, year_built = econ.scale, result.lut, sub.year_built
        floor_space = np.where(sub.replaced, econ.floors * envelope, floor_space)
        if year:  # the first year settles the shares from the greedy start
            best["update"] = min(best["update"], t1 - t0)
            best["economy"] = min(best["economy"], t2 - t1)
            accepted = result.accepted
    goals = lt.goal_shares(lt.DEFAULT_TYPES)
    return {"lots": n, "layout": t_layout, **best, "pairs": layout.weights.nnz,
            "accepted": accepted, "off_goal": float(np.abs(result.shares - goals).max()),
            "median_height": float(np.median(econ.height[econ.height > 0]))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1000,5000,20000")
    parser.add_argument("--years", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(f"{'lots':>7} {'layout s':>9} {'update s/yr':>12} {'economy s/yr':>13} {'kernel pairs':>13} "
          f"{'accepted':>9} {'max |share-goal|':>17} {'median h (m)':>13}")
    for n in (int(s) for s in args.sizes.split(",")):
        r = run(n, args.years, args.seed)
        print(f"{r['lots']:>7} {r['layout']:>9.2f} {r['update']:>12.2f} {r['economy']:>13.3f} "
              f"{r['pairs']:>13,} {r['accepted']:>9} {r['off_goal']:>17.3f} {r['median_height']:>13.1f}")


if __name__ == "__main__":
    main()
