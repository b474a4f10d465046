"""Land use and heights against a real town (seed 002 §4, §6; 004 §4.3.4).

    python benchmarks/landuse_calibration.py [FILE ...] [--years 20] [--seed 0] [--cell 10] [--half 1000]

For each town (default Krems and Andorra):

1. reads its ``landuse=*`` / ``leisure=*`` / forest polygons (osmium areas;
   the ingest does not keep them yet) and its buildings with their
   ``height`` / ``building:levels`` tags;
2. calibrates the land-use goals from those polygons
   (:func:`calibrate_landuse`, clipped to the town — the buildings buffered
   by 60 m — whose footprints split dense housing and give the coverage);
3. stands in one lot per existing building (centroid; area = footprint /
   0.35 ground coverage; envelope = the footprint), a centre at the densest
   place (most buildings within 250 m), traffic from the class of the
   streets within 40 m, water from the ingest, green from forest and parks;
4. simulates land use from scratch — :func:`assign_types`, then ``--years``
   yearly :func:`update_land_use` — and compares it with the real land use on
   a ``--cell`` m raster over the old town (``--half`` m around the centre,
   200×200 cells by default): Weber's
   ``Similarity(GT, IS)`` and ``Similarity(IS, GT)`` (002 Eq. 12–13) for n =
   4, 8, 12, real untagged cells as nodata, next to the same for the
   simulated types shuffled among the lots (same shares, no spatial sense):
   the valuation defaults earn their keep when the first beats the second.
   Weber's measure compares textures (best match anywhere), not places, so
   the cell-wise agreement on tagged cells is printed too, against the same
   shuffled baseline;
5. runs the economy for the lots and reports the generated height median
   against the town's tagged median (or the default when untagged).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import osmium
import shapely
from scipy.spatial import cKDTree

from osm_expand.engine.buildout import economy as ec
from osm_expand.engine.buildout import landuse as lu
from osm_expand.engine.buildout import landuse_osm as lo
from osm_expand.engine.buildout import landuse_types as lt
from osm_expand.engine.buildout import lot_values as lv
from osm_expand.engine.buildout import similarity as ls
from osm_expand.ingest import load

REPO = Path(__file__).resolve().parent.parent
#: Traffic proxy per highway class (relative daily volumes of a small town).
CLASS_TRAFFIC = {"motorway": 8.0, "trunk": 6.0, "primary": 4.0, "secondary": 2.5, "tertiary": 1.5,
                 "unclassified": 0.7, "residential": 0.5, "living_street": 0.2, "service": 0.2}
GREEN = {("landuse", "forest"), ("natural", "wood"), ("leisure", "park"), ("landuse", "grass"),
         ("landuse", "meadow"), ("landuse", "recreation_ground")}


def read_polygons(path: Path, to_xy) -> tuple[list[tuple[object, str]], list[object]]:
    """(polygon, landuse/leisure value) pairs and green polygons, projected."""
    wkb = osmium.geom.WKBFactory()
    landuse, green = [], []
    fp = (osmium.FileProcessor(str(path)).with_locations()
          .with_areas(osmium.filter.KeyFilter("landuse", "leisure", "natural"))
          .with_filter(osmium.filter.EntityFilter(osmium.osm.AREA)))
    for area in fp:
        tags = area.tags
        try:
            geom = shapely.from_wkb(wkb.create_multipolygon(area))
        except RuntimeError:
            continue
        geom = shapely.transform(geom, lambda c: np.column_stack(to_xy(c[:, 0], c[:, 1])))
        if not geom.is_valid:
            geom = shapely.make_valid(geom)
        value = tags.get("landuse") or tags.get("leisure")
        if value:
            landuse.append((geom, value))
        if any(tags.get(k) == v for k, v in GREEN):
            green.append(geom)
    return landuse, green


def town(path: Path, years: int, seed: int, cell: float, half: float) -> dict:
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    net = load(path)
    ctx = net.context
    polygons, green = read_polygons(path, ctx.projection.to_xy)
    footprints = [shapely.Polygon(b.ring) for b in ctx.buildings]
    footprints = [f if f.is_valid else shapely.make_valid(f) for f in footprints]
    foot_area = np.maximum(shapely.area(np.asarray(footprints, dtype=object)), 10.0)
    xy = shapely.get_coordinates(shapely.centroid(np.asarray(footprints, dtype=object)))
    n = len(xy)
    tree = cKDTree(xy)
    density = np.array([len(x) for x in tree.query_ball_point(xy, 250.0)])
    centre = xy[np.argmax(density)][None, :]
    lines = [shapely.LineString(net.street_xy(s)) for s in net.streets]
    weights = np.array([CLASS_TRAFFIC.get(s.highway.removesuffix("_link"), 0.3) for s in net.streets])
    pi, li = shapely.STRtree(lines).query(shapely.points(xy), predicate="dwithin", distance=40.0)
    traffic = np.zeros(n)
    np.maximum.at(traffic, pi, weights[li])
    outline = shapely.union_all(shapely.buffer(np.asarray(footprints, dtype=object), 60.0))
    cal = lo.calibrate_landuse(polygons, outline, buildings=footprints)
    types = cal.with_goals(lt.DEFAULT_TYPES)
    attrs = lv.lot_attributes(xy, centres=centre, water=list(ctx.water) + list(ctx.sea), green=green,
                              traffic=traffic)
    area = foot_area / 0.35
    layout = lv.lot_layout(xy, area, attrs)
    lut = lu.assign_types(layout, np.full(n, lt.UNASSIGNED), types=types, rng=rng)
    result = None
    for _ in range(years):
        result = lu.update_land_use(layout, lut, types=types, rng=rng)
        lut = result.lut
    x0, y0 = np.maximum(xy.min(axis=0), centre[0] - half)
    x1, y1 = np.minimum(xy.max(axis=0), centre[0] + half)
    bounds = (x0, y0, x1, y1)
    real = ls.rasterise_polygons(polygons, bounds=bounds, cell=cell, buildings=footprints)
    sim = ls.rasterise_lots(xy, lut, bounds=bounds, cell=cell, max_distance=40.0)
    shuffled = ls.rasterise_lots(xy, rng.permutation(lut), bounds=bounds, cell=cell, max_distance=40.0)
    tagged = real != lt.UNASSIGNED
    both = tagged & (sim != lt.UNASSIGNED)  # cells with a real tag and a lot nearby
    agree = float((sim[both] == real[both]).mean()) if both.any() else float("nan")
    agree_shuffled = float((shuffled[both] == real[both]).mean()) if both.any() else float("nan")
    sims = {}
    for k in (4, 8, 12):
        sims[k] = (ls.similarity(real, sim, k, nodata=lt.UNASSIGNED), ls.similarity(real, shuffled, k,
                                                                                  nodata=lt.UNASSIGNED),
                   ls.similarity(np.where(tagged, sim, lt.UNASSIGNED), real, k, nodata=lt.UNASSIGNED))
    # heights
    h = np.array([np.nan if b.height is None else b.height for b in ctx.buildings])
    lv = np.array([np.nan if b.levels is None else b.levels for b in ctx.buildings])
    hcal = ec.calibrate_heights(h, lv)
    econ = ec.lot_economy(area, foot_area, result.luv if result else np.ones(n), lut, attrs[:, 0],
                          avgprice=100.0, calibration=hcal, rng=rng)
    built = econ.height > 0
    return {"town": path.name, "lots": n, "polygons": len(polygons), "coverage": cal.coverage,
            "weight": cal.weight, "shares": cal.shares, "goals": cal.goals,
            "final": lv.area_shares(area, lut, len(types)), "tagged_cells": float(tagged.mean()),
            "raster": real.shape, "both": float(both.mean()), "agree": agree, "agree_shuffled": agree_shuffled,
            "similarity": sims, "heights": hcal, "generated_median": float(np.median(econ.height[built])),
            "generated_quartiles": np.quantile(econ.height[built], [0.25, 0.75]),
            "seconds": time.perf_counter() - t0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path,
                        default=[REPO / "fixtures/krems.osm.gz", REPO / "fixtures/andorra.osm.pbf"])
    parser.add_argument("--years", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cell", type=float, default=10.0)
    parser.add_argument("--half", type=float, default=1000.0)
    args = parser.parse_args()
    names = [t.name for t in lt.DEFAULT_TYPES]
    np.set_printoptions(precision=3, suppress=True)
    for path in args.files:
        r = town(path, args.years, args.seed, args.cell, args.half)
        print(f"== {r['town']}: {r['lots']} buildings as lots, {r['polygons']} land-use polygons, "
              f"{r['seconds']:.1f} s")
        print(f"   types            {names}")
        print(f"   town's shares    {r['shares']}  (coverage {r['coverage']:.2f}, weight {r['weight']:.2f})")
        print(f"   goals            {r['goals']}")
        print(f"   simulated shares {r['final']}  (after {args.years} years)")
        print(f"   old town {r['raster'][1]}×{r['raster'][0]} cells, {r['tagged_cells']:.1%} with real land use; "
              f"{r['both']:.1%} with a lot too, where the simulation has the real type on {r['agree']:.1%} "
              f"(shuffled lots {r['agree_shuffled']:.1%})")
        for k, (s, base, rev) in r["similarity"].items():
            print(f"   n={k:>2}: Similarity(GT, IS) {s:.3f}  shuffled lots {base:.3f}  "
                  f"Similarity(IS, GT) {rev:.3f}")
        h = r["heights"]
        source = (f"{h.n_tagged} tagged, storey {h.storey_height:.2f} m from {h.n_storey_pairs} pairs"
                  if h.from_tags else "no height tags: defaults")
        print(f"   heights: target median {h.median:.1f} m ({source}); generated median "
              f"{r['generated_median']:.1f} m, quartiles {r['generated_quartiles']} "
              f"(ratio {r['generated_median'] / h.median:.2f})")


if __name__ == "__main__":
    main()
