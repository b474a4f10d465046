"""Reading user information maps: .npy and PGM grids with a JSON georeference, and their errors."""
from __future__ import annotations

import json

import numpy as np
import pytest

from osm_expand.errors import InputError
from osm_expand.model.projection import LocalProjection
from osm_expand.rasters import read_raster
from synth.infomaps import Raster


def write(tmp_path, name: str, data: bytes | np.ndarray, geo: dict | None) -> object:
    path = tmp_path / name
    if isinstance(data, np.ndarray):
        np.save(path, data)
    else:
        path.write_bytes(data)
    if geo is not None:
        (tmp_path / (name + ".json")).write_text(json.dumps(geo))
    return path


def test_an_npy_map_in_image_order_is_flipped_to_row_zero_south(tmp_path):
    grid = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])  # first row is the northern one
    path = write(tmp_path, "height.npy", grid, {"origin": [100.0, 500.0], "cell_size": 10.0, "row0": "north"})
    raster = Raster(*read_raster(path))
    assert raster.origin == (100.0, 480.0) and raster.cell == 10.0
    np.testing.assert_array_equal(raster.values, grid[::-1])
    assert raster.sample(np.array([[105.0, 495.0]]), nearest=True)[0] == 1.0  # north-west cell


def test_row_zero_south_keeps_the_order_and_scale_and_offset_apply(tmp_path):
    grid = np.array([[0, 1], [2, 3]], dtype=np.int16)
    path = write(tmp_path, "h.npy", grid, {"origin": [0, 0], "cell_size": 5, "row0": "south", "scale": 2.0,
                                           "offset": 100.0})
    raster = Raster(*read_raster(path))
    np.testing.assert_array_equal(raster.values, 100.0 + 2.0 * grid)
    assert raster.origin == (0.0, 0.0)


def test_plain_and_binary_pgm_read_as_shares_of_their_maximum(tmp_path):
    plain = b"P2\n# a density map\n3 2\n4\n0 1 2\n3 4 4\n"
    raster = Raster(*read_raster(write(tmp_path, "d.pgm", plain, {"origin": [0, 0], "cell_size": 1.0})))
    np.testing.assert_allclose(raster.values, [[0.75, 1.0, 1.0], [0.0, 0.25, 0.5]])
    binary = b"P5 2 2 255\n" + bytes([0, 255, 51, 102])
    raster = Raster(*read_raster(write(tmp_path, "b.pgm", binary, {"origin": [0, 0], "cell_size": 1.0})))
    np.testing.assert_allclose(raster.values, [[0.2, 0.4], [0.0, 1.0]])
    wide = b"P5 1 2 1000\n" + np.array([1000, 250], dtype=">u2").tobytes()
    raster = Raster(*read_raster(write(tmp_path, "w.pgm", wide, {"origin": [0, 0], "cell_size": 1.0})))
    np.testing.assert_allclose(raster.values, [[0.25], [1.0]])


def test_a_lonlat_origin_is_projected_with_the_towns_projection(tmp_path):
    proj = LocalProjection(15.6, 48.4)
    path = write(tmp_path, "m.npy", np.zeros((2, 2)), {"origin_lonlat": [15.6, 48.4], "cell_size": 10.0,
                                                       "row0": "south"})
    raster = Raster(*read_raster(path, projection=proj))
    assert raster.origin == pytest.approx((0.0, 0.0), abs=1e-6)
    with pytest.raises(InputError, match="origin_lonlat needs the town's projection"):
        read_raster(path)


def test_a_sidecar_named_after_the_stem_also_works(tmp_path):
    path = write(tmp_path, "m.npy", np.ones((1, 1)), None)
    (tmp_path / "m.json").write_text(json.dumps({"origin": [1, 2], "cell_size": 3}))
    assert read_raster(path).origin == (1.0, -1.0)  # row 0 north by default: origin is the north-west corner


@pytest.mark.parametrize("name, data, geo, message", [
    ("a.npy", np.zeros((2, 2)), None, "no georeference; write a.npy.json"),
    ("a.pgm", b"P6 1 1 255\n\x00\x00\x00", {"origin": [0, 0], "cell_size": 1}, "not a PGM file"),
    ("a.pgm", b"P5 4 4 255\n\x00", {"origin": [0, 0], "cell_size": 1}, "truncated"),
    ("a.pgm", b"P2 2 1 10\n3 11\n", {"origin": [0, 0], "cell_size": 1}, "exceeds the maximum value 10"),
    ("a.pgm", b"P2 x 1 10\n3\n", {"origin": [0, 0], "cell_size": 1}, "bad PGM header"),
    ("a.npy", np.zeros(3), {"origin": [0, 0], "cell_size": 1}, "2-D grid"),
    ("a.npy", np.array([[np.nan]]), {"origin": [0, 0], "cell_size": 1}, "NaN"),
    ("a.npy", np.zeros((2, 2)), {"origin": [0, 0], "cell_size": 0}, "cell_size must be a positive number"),
    ("a.npy", np.zeros((2, 2)), {"origin": [0, 0], "cell_size": 1, "row0": "top"}, "row0 must be one of north"),
    ("a.npy", np.zeros((2, 2)), {"origin": [0], "cell_size": 1}, "origin must be two finite numbers"),
    ("a.npy", np.zeros((2, 2)), {"cell_size": 1}, "exactly one of origin"),
    ("a.npy", np.zeros((2, 2)), {"origin": [0, 0], "cell_size": 1, "cellsize": 1}, "unknown key 'cellsize'"),
    ("a.tif", b"II*\x00", {"origin": [0, 0], "cell_size": 1}, "unknown map format .tif"),
])
def test_bad_maps_give_one_line_errors_naming_the_file(tmp_path, name, data, geo, message):
    path = write(tmp_path, name, data, geo)
    with pytest.raises(InputError, match=message) as err:
        read_raster(path)
    assert "\n" not in str(err.value) and name.split(".")[0] in str(err.value)


def test_a_missing_file_and_broken_json_are_input_errors(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_raster(tmp_path / "nothing.npy")
    path = write(tmp_path, "j.npy", np.zeros((1, 1)), None)
    (tmp_path / "j.npy.json").write_text("{origin: 1")
    with pytest.raises(InputError, match="not valid JSON"):
        read_raster(path)
