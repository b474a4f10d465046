"""A window's directed kinds cropped from the map's (``lattice._cropped``, ``Lattice._map_directed``): the
tables cut from the map's unit edges afresh (``lattice._window_directed``), window after growing window
and B after B (issue 22, session 43)."""
from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from osm_expand.engine.roads import lattice as L
from osm_expand.engine.roads.lattice import NO_EDGE, LatticeOptions, build_lattice
from tests.test_majorroads import random_blobs, random_river_lattice


def _random_live(rng: np.random.Generator, radius: int, map_ny: int, map_nx: int) -> tuple[np.ndarray, np.ndarray]:
    """Random live unit edges ``(D/2, V_map)`` whose edges end on the map, and the directions."""
    directions = L.lattice_directions(radius)
    half = len(directions) // 2
    live = rng.choice(np.array([0, 1, 2, 3, NO_EDGE], dtype=np.uint8), size=(half, map_ny * map_nx))
    iy, ix = np.divmod(np.arange(map_ny * map_nx), map_nx)
    for k, (dx, dy) in enumerate(directions[:half].tolist()):
        live[k, (ix + dx < 0) | (ix + dx >= map_nx) | (iy + dy >= map_ny)] = NO_EDGE
    return live, directions


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_window_cropped_from_the_maps_directed_kinds_is_the_one_cut_from_its_unit_edges(seed):
    """:func:`~osm_expand.engine.roads.lattice._cropped` of the map's directed kinds (the map's own
    :func:`~osm_expand.engine.roads.lattice._window_directed`) equals the window's cut from the unit
    edges, for windows anywhere (on the map's sides, one vertex wide, narrower than the radius)."""
    rng = np.random.default_rng(seed)
    radius = int(rng.integers(1, 6))
    map_ny, map_nx = int(rng.integers(1, 30)), int(rng.integers(1, 30))
    live, directions = _random_live(rng, radius, map_ny, map_nx)
    whole = L._window_directed(live, (map_ny, map_nx), (0, 0), (map_ny, map_nx), directions)
    for _ in range(5):
        r0, c0 = int(rng.integers(0, map_ny)), int(rng.integers(0, map_nx))
        ny, nx = int(rng.integers(1, map_ny - r0 + 1)), int(rng.integers(1, map_nx - c0 + 1))
        got = L._cropped(whole, (map_ny, map_nx), (r0, c0), (ny, nx), directions)
        expected = L._window_directed(live, (map_ny, map_nx), (r0, c0), (ny, nx), directions)
        assert got.shape == expected.shape and got.dtype == expected.dtype
        assert np.array_equal(got, expected)
        got[:] = 0  # a copy: G′ edits its table in place
    assert np.array_equal(whole, L._window_directed(live, (map_ny, map_nx), (0, 0), (map_ny, map_nx), directions))


def _grown(rng: np.random.Generator, box: tuple[int, int, int, int], shape: tuple[int, int]) -> tuple[int, ...]:
    """A window's ``(r0, c0, rows, cols)`` round ``box`` (the last one), grown by a few vertices a side."""
    r0, c0, r1, c1 = box
    ny, nx = shape
    r0, c0 = max(r0 - int(rng.integers(0, 8)), 0), max(c0 - int(rng.integers(0, 8)), 0)
    r1, c1 = min(r1 + int(rng.integers(0, 8)), ny), min(c1 + int(rng.integers(0, 8)), nx)
    return r0, c0, r1, c1


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_windows_growing_year_after_year_crop_the_tables_they_would_cut(seed):
    """As the route search asks for them: windows growing round a first one, then the whole map, B growing
    between the years. Each window's directed kinds equal those cut from the map's live unit edges of
    that B made afresh (:func:`~osm_expand.engine.roads.lattice._window_directed`) and those its own unit
    tables give (the rasters sampled in the window); the map's directed table is made once for all the
    years (carried from B to B, :func:`~osm_expand.engine.roads.lattice._directed_without_touched`) and
    replaces the unit edges."""
    from dataclasses import replace

    rng = np.random.default_rng(seed)
    lat = random_river_lattice(rng)
    made = []
    units = L._map_live_units
    with pytest.MonkeyPatch.context() as monkey:
        monkey.setattr(L, "_map_live_units", lambda lat: made.append(1) or units(lat))
        for _ in range(4):
            for _ in range(int(rng.integers(1, 3))):  # B grows by one or two discs a year
                x, y = rng.uniform(0, 800), rng.uniform(0, 600)
                lat = lat.with_built_up(shapely.Point(x, y).buffer(float(rng.uniform(20, 90))))
            ny, nx = lat.shape
            r, c = int(rng.integers(0, ny - 4)), int(rng.integers(0, nx - 4))
            box = (r, c, r + int(rng.integers(2, 12)), c + int(rng.integers(2, 12)))
            windows = []
            for _ in range(3):
                box = _grown(rng, box, (ny, nx))
                windows.append(lat.window(box[0], box[1], box[2] - box[0], box[3] - box[1]))
            windows.append(lat)
            live = units(lat)  # this B's unit edges made afresh
            for window in windows:
                kind, _ = window.directed_tables()
                assert np.array_equal(kind, L._window_directed(live, lat.full_shape, window.offset, window.shape,
                                                               lat.directions))
                sampled = replace(window, map_units=None, _cache={})
                assert np.array_equal(kind, sampled.directed_tables()[0])
                kind[:] = 0  # G′ edits its copy; the map's table stays
            assert "directed" in lat._shared and "live" not in lat._shared
    assert len(made) == 1


def test_a_map_above_the_cap_cuts_each_windows_table_from_its_unit_edges(monkeypatch):
    """A map whose directed kinds would take more than ``_MAP_DIRECTED_BYTES`` keeps none: its windows cut
    their tables from the unit edges (:func:`~osm_expand.engine.roads.lattice._window_directed`), the same."""
    rng = np.random.default_rng(7)
    extent = (0, 0, 600, 400)
    lat = build_lattice(extent, forbidden=random_blobs(rng, extent, 3, within=(50, 550), radius=(20, 60)),
                        options=LatticeOptions(radius=3))
    lat = lat.with_built_up(shapely.Point(300, 200).buffer(50.0))
    window = lat.window(3, 4, 12, 15)
    cropped = window.directed_tables()[0].copy()
    monkeypatch.setattr(L, "_MAP_DIRECTED_BYTES", 0)
    lat2 = build_lattice(extent, forbidden=random_blobs(np.random.default_rng(7), extent, 3, within=(50, 550),
                                                        radius=(20, 60)), options=LatticeOptions(radius=3))
    window2 = lat2.with_built_up(shapely.Point(300, 200).buffer(50.0)).window(3, 4, 12, 15)
    assert np.array_equal(window2.directed_tables()[0], cropped)
    assert "directed" not in window2._shared
