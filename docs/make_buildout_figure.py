"""The build-out figures of docs/buildout.md: a town after its history, buildings and lots by land use.

    python docs/make_buildout_figure.py [FILE] [--history NAME] [--out docs/buildout-krems.png]
                                        [--zoom M] [--dpi N]

Runs what ``osm-expand FILE --history NAME`` runs (seed 0, the history's
years), then draws the city with ``color_by="landuse"``: the whole town, and,
with ``--zoom M``, an M-metre square around the lot that has the most lot
area within 300 m of it (``-zoom.png`` next to the first).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))


def densest_lot(city, radius: float = 300.0) -> np.ndarray:
    """The centroid (2,) of the lot with the most lot area within ``radius`` metres."""
    from scipy.spatial import cKDTree

    xy = np.array([lot.polygon.centroid.coords[0] for lot in city.lots])
    area = np.array([lot.polygon.area for lot in city.lots])
    tree = cKDTree(xy)
    near = tree.query_ball_point(xy, radius)
    mass = np.array([area[n].sum() for n in near])
    return xy[int(np.argmax(mass))]


def main() -> None:
    from osm_expand.engine.history import load_history
    from osm_expand.export.preview import write_preview
    from osm_expand.ingest import load
    from osm_expand.maturation import MatureOptions, mature_result
    from osm_expand.pipeline import ExpandOptions, expand

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", type=Path, default=REPO / "fixtures" / "krems.osm.gz")
    ap.add_argument("--history", default="example")
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "buildout-krems.png")
    ap.add_argument("--zoom", type=float, default=900.0, help="side of the zoomed square (m); 0: none")
    ap.add_argument("--dpi", type=int, default=None, help="unused (the preview's own dpi)")
    args = ap.parse_args()
    result = mature_result(expand(load(args.file), ExpandOptions(seed=0)), load_history(args.history),
                           MatureOptions(), 0)
    city = result.city
    name = args.file.name.split(".")[0]
    write_preview(city, args.out, title=f"{name}, '{args.history}' history: buildings and lots by land use",
                  color_by="landuse")
    print(args.out)
    if args.zoom > 0 and city.lots:
        c = densest_lot(city)
        h = args.zoom / 2
        out = args.out.with_name(args.out.stem + "-zoom" + args.out.suffix)
        write_preview(city, out, title=f"{name}: the densest part of the build-out ({args.zoom:.0f} m)",
                      color_by="landuse", extent=(c[0] - h, c[1] - h, c[0] + h, c[1] + h))
        print(out)


if __name__ == "__main__":
    main()
