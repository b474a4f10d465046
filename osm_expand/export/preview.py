"""A map of the city (PNG or SVG): the town as mapped in grey, what the tool made in colour.

Water in blue, the town's buildings and streets in greys, the new streets
coloured by when they grew (the district one colour, each era of the
engine's history its own, with a legend naming them; major streets drawn
thicker than minor ones), joining streets in black, the site outline dashed,
a scale bar. Coloured by hierarchy instead, each short street took another
colour and the growth read as confetti; by stage, a viewer sees a district
and the quarters each era added. Generated buildings are coloured by
``color_by``: ``origin`` (one colour, the default), ``landuse`` (a colour
per land-use type, with a legend; generated lots are shaded in the same
colours) or ``year`` (the year each was built, with a colour bar). The same
city gives the same bytes: the SVG's element ids are salted with a constant,
and no dates are written.
"""
from __future__ import annotations

import enum
import os
from collections.abc import Sequence
from typing import cast

import numpy as np
import shapely

from osm_expand.errors import OptionError
from osm_expand.export.atomic import atomic_write
from osm_expand.model import City, Origin
from osm_expand.model.enums import parse_enum
from osm_expand.model.network import Street
from osm_expand.model.segments import is_major
from osm_expand.model.topology import junction_mask

#: Generated buildings of one colour when coloured by origin.
NEW_BUILDING = "#e8a33d"
#: Colours of the growth stages, by position: the district first, then each era of the history in its
#: order (matplotlib's Dark2, a qualitative map whose eight colours stay apart from the greys, the water's
#: blue and the joins' black; fixed per position so the same run draws the same bytes; a ninth stage
#: takes the first colour again).
STAGE_COLOURS = ("#d95f02", "#1b9e77", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666")
#: Line widths (points) of new streets: major (the model's major highway classes and their links), minor.
#: Thicker majors let a viewer see a quarter's spine; 1.8/1.0 read well at the preview's 110 dpi.
NEW_STREET_WIDTH = {True: 1.8, False: 1.0}
#: Colours of the bundled land-use types (002 Table 5's convention: housing warm, business red,
#: industry blue-violet, parks green); other types get the remaining tab10 colours in name order.
LANDUSE_COLOURS = {"residential_low": "#f2c14e", "residential_high": "#e07b39", "commercial": "#d1495b",
                   "industrial": "#6c5b9c", "park": "#5fa052"}
#: Radius (m) of the disc in which each junction's neighbouring junctions are counted to find the town on
#: the map: a neighbourhood's radius (a district of 0.2-0.5 km² is a disc of 250-400 m). The denser half of
#: the junctions by that count is the town, as the growth yardstick keeps the denser half of its discs
#: (issue 20); rural roads have a junction every kilometre or so and fall in the sparser half.
TOWN_RADIUS = 300.0
#: Fewest junctions for the town to be read from them; below it the frame is the whole map.
TOWN_MIN_JUNCTIONS = 16
#: Margin round the frame, a share of its longer side.
FRAME_MARGIN = 0.05


class Frame(enum.StrEnum):
    """What the picture frames."""

    TOWN = "town"   # the town (its denser half of junctions) and everything new: what grew is legible
    ALL = "all"     # every street of the map, the countryside's roads included

    @classmethod
    def parse(cls, value: str) -> Frame:
        return parse_enum(cls, value, "frame")


class ColorBy(enum.StrEnum):
    """What colours the generated buildings."""

    ORIGIN = "origin"
    LANDUSE = "landuse"
    YEAR = "year"

    @classmethod
    def parse(cls, value: str) -> ColorBy:
        return parse_enum(cls, value, "color_by")


def _landuse_colours(names: list[str]) -> dict[str, str]:
    """A colour per land-use type name: the bundled ones fixed, others from tab10 in name order."""
    import matplotlib
    from matplotlib.colors import ListedColormap

    tab10 = cast(ListedColormap, matplotlib.colormaps["tab10"])
    spare = [c for c in cast(Sequence[tuple[float, float, float]], tab10.colors)]  # tab10 lists RGB triples
    out, k = {}, 0
    for name in sorted(set(names)):
        if name in LANDUSE_COLOURS:
            out[name] = LANDUSE_COLOURS[name]
        else:
            out[name] = matplotlib.colors.to_hex(spare[k % len(spare)])
            k += 1
    return out


def picture_frame(city: City, site_region: shapely.Geometry | None = None,
                  frame: str = "town") -> tuple[float, float, float, float]:
    """The window ``(x0, y0, x1, y1)`` a picture of ``city`` draws, margin included.

    Why: an extract is often mostly countryside (Krems' is 9.6 × 6.4 km round a town of 4 × 1.3 km), and a
    district of half a square kilometre drawn on the whole of it is a scribble. ``town`` frames the town
    (the discs of :data:`TOWN_RADIUS` round the junctions of its mapped streets in the denser half by
    junctions within that radius), every new street and building and the site; ``all`` every street of
    the map and the site.
    """
    net = city.network
    pts = [net.xy[net.used_nodes()]]
    if Frame.parse(frame) is Frame.TOWN:
        town = _town_junctions(city)
        pts = [town - TOWN_RADIUS, town + TOWN_RADIUS] if len(town) else pts  # each junction's disc
        pts += [net.street_xy(s) for s in net.streets if s.origin != Origin.SOURCE]
        pts += [np.asarray(b.ring) for b in city.buildings if b.origin != Origin.SOURCE]
    if site_region is not None:
        pts.append(np.asarray(site_region.exterior.coords))
    xy = np.vstack(pts)
    (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
    pad = FRAME_MARGIN * max(x1 - x0, y1 - y0)
    return float(x0 - pad), float(y0 - pad), float(x1 + pad), float(y1 + pad)


def _town_junctions(city: City) -> np.ndarray:
    """The mapped streets' junctions in the denser half by junctions within :data:`TOWN_RADIUS` (none when
    there are too few junctions to tell)."""
    from scipy.spatial import cKDTree

    net = city.network
    source = [s for s in net.streets if s.origin == Origin.SOURCE]
    xy = net.xy[junction_mask(source, len(net.xy))]
    if len(xy) < TOWN_MIN_JUNCTIONS:
        return xy[:0]
    near = cKDTree(xy).query_ball_point(xy, TOWN_RADIUS, return_length=True)
    return xy[near >= np.median(near)]


def write_preview(city: City, path: str | os.PathLike, site_region: shapely.Geometry | None = None,
                  title: str = "", *, color_by: str = "origin",
                  extent: tuple[float, float, float, float] | None = None, frame: str = "town") -> None:
    """Draw the city to ``path`` (``.png`` or ``.svg``), atomically.

    Parameters
    ----------
    city : City
    path : str or PathLike
    site_region : shapely Polygon, optional
        Drawn dashed (where the district was grown).
    title : str
    color_by : {"origin", "landuse", "year"}
        What colours the generated buildings (module docstring).
    extent : (x0, y0, x1, y1), optional
        The window to draw (metres, the city's projection); default: :func:`picture_frame`'s.
    frame : {"town", "all"}
        What :func:`picture_frame` frames when no ``extent`` is given: the town and what grew, or the
        whole map.

    Raises
    ------
    InputError
        An unknown ``color_by`` or ``frame``, or an empty ``extent``.
    """
    colour = ColorBy.parse(color_by)
    if extent is None:
        extent = picture_frame(city, site_region, frame)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.lines import Line2D

    net = city.network
    with plt.rc_context({"svg.hashsalt": "osm-expand", "path.simplify": True}):
        x0, y0, x1, y1 = (float(v) for v in extent)
        if not (x1 > x0 and y1 > y0):
            raise OptionError(f"extent must be (x0, y0, x1, y1) with x1 > x0 and y1 > y0, got {extent!r}")
        aspect = (y1 - y0) / max(x1 - x0, 1.0)
        fig, ax = plt.subplots(figsize=(10, float(np.clip(10 * aspect, 4, 14)) + 0.6))
        water = [np.asarray(p.exterior.coords) for g in (*city.water, *city.sea)
                 for p in getattr(g, "geoms", [g]) if p.geom_type == "Polygon"]
        ax.add_collection(PolyCollection(water, facecolors="#b9d7ea", edgecolors="none"))
        ax.add_collection(PolyCollection([b.ring for b in city.buildings if b.origin == Origin.SOURCE],
                                         facecolors="0.78", edgecolors="none"))
        _new_buildings(fig, ax, city, colour)
        old = [net.street_xy(s) for s in net.streets if s.origin == Origin.SOURCE]
        ax.add_collection(LineCollection(old, colors="0.45", linewidths=0.7))
        handles = []
        for k, (label, streets) in enumerate(growth_stages(net.streets)):
            colour_k = STAGE_COLOURS[k % len(STAGE_COLOURS)]
            ax.add_collection(LineCollection([net.street_xy(s) for s in streets], colors=colour_k,
                                             linewidths=[NEW_STREET_WIDTH[is_major(s)] for s in streets]))
            handles.append(Line2D([], [], color=colour_k, lw=NEW_STREET_WIDTH[False], label=label))
        joins = [net.street_xy(s) for s in net.streets if s.origin == Origin.JOIN]
        if joins:
            ax.add_collection(LineCollection(joins, colors="black", linewidths=1.6))
            handles.append(Line2D([], [], color="black", lw=1.6, label="joining streets"))
        if handles:
            buildings_legend = ax.get_legend()
            ax.legend(handles=handles, loc="upper left", fontsize=7, title="new streets (major thicker)",
                      title_fontsize=7)
            if buildings_legend is not None:
                ax.add_artist(buildings_legend)
        if site_region is not None:
            ax.plot(*site_region.exterior.xy, ls="--", color="black", lw=0.8)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        _scale_bar(ax)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title)
        ax.set_xlabel("Map data © OpenStreetMap contributors (ODbL): the town in grey; "
                      "new streets by osm-expand coloured by when they grew, joining streets in black", fontsize=8)
        suffix = str(path).lower().rsplit(".", 1)[-1]
        with atomic_write(path, "wb") as fh:
            fig.savefig(fh, format="svg" if suffix == "svg" else "png", dpi=110, bbox_inches="tight",
                        metadata={"Software": None} if suffix == "png" else {"Date": None})
        plt.close(fig)


def growth_stages(streets: Sequence[Street]) -> list[tuple[str, list[Street]]]:
    """The new streets by when they grew, each with its legend label, in the order they grew.

    The district (origin ``grown``) first, then the engine's streets by era. The history's order is
    read from the streets themselves (an era's first year), so the preview needs no history: eras run
    one after another, and two eras with the same first year (none in the bundled histories) fall
    back to name order so the drawing stays the same. Joining streets are not a stage (drawn black).
    """
    district = [s for s in streets if s.origin == Origin.GROWN]
    eras: dict[str, list[Street]] = {}
    for s in streets:
        if s.origin == Origin.ENGINE:
            eras.setdefault(s.era or "engine", []).append(s)
    out = [("district", district)] if district else []

    def first_year(name: str) -> tuple[float, str]:
        years = [s.year for s in eras[name] if s.year is not None]
        return (min(years) if years else float("inf"), name)

    for name in sorted(eras, key=first_year):
        years = [s.year for s in eras[name] if s.year is not None]
        span = "" if not years else f" ({min(years)})" if min(years) == max(years) else f" ({min(years)}–{max(years)})"
        out.append((f"{name}{span}", eras[name]))
    return out


def _new_buildings(fig, ax, city: City, colour: ColorBy) -> None:
    """The generated buildings (and, by land use, the generated lots) in the chosen colours."""
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    new = [b for b in city.buildings if b.origin != Origin.SOURCE]
    if colour is ColorBy.LANDUSE:
        colours = _landuse_colours([b.land_use or "unknown" for b in new] + [lot.land_use for lot in city.lots])
        if city.lots:
            rings = [np.asarray(lot.polygon.exterior.coords) for lot in city.lots]
            ax.add_collection(PolyCollection(rings, facecolors=[colours[lot.land_use] for lot in city.lots],
                                             edgecolors="white", linewidths=0.2, alpha=0.35))
        if new:
            ax.add_collection(PolyCollection([b.ring for b in new], edgecolors="none",
                                             facecolors=[colours[b.land_use or "unknown"] for b in new]))
        if colours:
            ax.legend(handles=[Patch(color=c, label=n.replace("_", " ")) for n, c in colours.items()],
                      loc="upper right", fontsize=7, title="land use", title_fontsize=7)
        return
    if not new:
        return
    if colour is ColorBy.YEAR and any(b.year is not None for b in new):
        years = np.array([b.year if b.year is not None else np.nan for b in new], dtype=float)
        pc = PolyCollection([b.ring for b in new], cmap="viridis", edgecolors="none")
        pc.set_array(np.where(np.isfinite(years), years, np.nanmin(years)))
        ax.add_collection(pc)
        fig.colorbar(pc, ax=ax, shrink=0.5, label="new buildings: year built")
        return
    ax.add_collection(PolyCollection([b.ring for b in new], facecolors=NEW_BUILDING, edgecolors="none"))


def _scale_bar(ax) -> None:
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    length = 10 ** np.floor(np.log10((x1 - x0) / 4))
    ax.plot([x0 + 0.05 * (x1 - x0), x0 + 0.05 * (x1 - x0) + length], [y0 + 0.04 * (y1 - y0)] * 2, color="black", lw=3)
    ax.text(x0 + 0.05 * (x1 - x0), y0 + 0.06 * (y1 - y0), f"{length:,.0f} m")
