"""PointCloud construction and validation, PLY round trips, normal estimation."""

import numpy as np
import pytest

import sspc


def test_build_from_float64_converts_to_float32():
    positions = np.arange(30, dtype=np.float64).reshape(10, 3) / 7
    cloud = sspc.PointCloud(positions)
    assert len(cloud) == 10
    assert cloud.positions.dtype == np.float32 and cloud.positions.shape == (10, 3)
    np.testing.assert_array_equal(cloud.positions, positions.astype(np.float32))
    assert cloud.normals is None and cloud.colours is None


def test_build_with_every_attribute_keeps_them():
    positions = np.random.default_rng(1).random((5, 3), dtype=np.float32)
    normals = np.tile(np.float32([0, 0, 1]), (5, 1))
    colours = np.arange(15, dtype=np.int32).reshape(5, 3) * 10
    cloud = sspc.PointCloud(positions, normals=normals, colours=colours)
    np.testing.assert_array_equal(cloud.normals, normals)
    assert cloud.colours.dtype == np.uint8
    np.testing.assert_array_equal(cloud.colours, colours)


@pytest.mark.parametrize("shape", [(10,), (10, 2), (10, 4), (2, 3, 3)])
def test_wrong_shape_is_a_value_error(shape):
    with pytest.raises(ValueError, match=r"positions must have shape \(N, 3\)"):
        sspc.PointCloud(np.zeros(shape))


def test_wrong_dtype_is_a_type_error():
    with pytest.raises(TypeError, match="positions must be an array of real numbers"):
        sspc.PointCloud(np.zeros((4, 3), dtype=np.complex64))
    with pytest.raises(TypeError, match="colours must be an array of integers"):
        sspc.PointCloud(np.zeros((4, 3)), colours=np.zeros((4, 3), dtype=np.float32))


def test_lengths_colours_and_coordinates_are_checked():
    with pytest.raises(ValueError, match="normals"):
        sspc.PointCloud(np.zeros((4, 3)), normals=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="0..255"):
        sspc.PointCloud(np.zeros((2, 3)), colours=[[0, 0, 0], [0, 256, 0]])
    with pytest.raises(ValueError, match="point 1 has a non-finite coordinate"):
        sspc.PointCloud([[0, 0, 0], [np.nan, 0, 0]])
    with pytest.raises(ValueError, match="positions: row 1 holds 1e[+]300, beyond float32's range"):
        sspc.PointCloud([[0, 0, 0], [1e300, 0, 0]])


def test_views_share_the_cloud_memory_and_are_read_only(bunny):
    a, b = bunny.positions, bunny.positions
    assert np.shares_memory(a, b)  # a view, not a copy
    assert not a.flags.writeable
    with pytest.raises(ValueError):
        a[0, 0] = 1
    # The view keeps the cloud alive.
    view = sspc.PointCloud(np.ones((3, 3))).positions
    np.testing.assert_array_equal(view, np.ones((3, 3), np.float32))


def test_read_shipped_bunny(bunny):
    assert len(bunny) == 34834
    assert bunny.normals is not None
    norms = np.linalg.norm(bunny.normals, axis=1)
    assert np.all(np.abs(norms - 1) < 1e-3)


@pytest.mark.parametrize("ascii", [False, True])
def test_write_read_round_trip(tmp_path, ascii):
    rng = np.random.default_rng(7)
    positions = rng.normal(size=(200, 3)).astype(np.float32)
    normals = positions / np.linalg.norm(positions, axis=1, keepdims=True)
    colours = rng.integers(0, 256, size=(200, 3))
    cloud = sspc.PointCloud(positions, normals, colours)
    path = tmp_path / "cloud.ply"
    sspc.write(cloud, path, ascii=ascii)
    assert path.read_bytes().startswith(b"ply\nformat " + (b"ascii" if ascii else b"binary_little_endian"))
    back = sspc.read(str(path))
    np.testing.assert_array_equal(back.positions, cloud.positions)
    np.testing.assert_array_equal(back.normals, cloud.normals)
    np.testing.assert_array_equal(back.colours, cloud.colours)


def test_read_errors_carry_the_library_message(tmp_path):
    missing = tmp_path / "missing.ply"
    with pytest.raises(FileNotFoundError, match="missing.ply: no such file"):
        sspc.read(missing)
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n")
    with pytest.raises(RuntimeError, match="bad.ply"):
        sspc.read(bad)


def test_write_to_a_missing_folder_is_an_os_error(tmp_path, bumps):
    with pytest.raises(OSError):
        sspc.write(bumps, tmp_path / "no" / "such" / "folder.ply")


def test_estimate_normals_matches_the_analytic_ones(bumps):
    normals = sspc.estimate_normals(bumps, k=16, viewpoint=(0, 0, 10))
    assert normals.shape == (len(bumps), 3) and normals.dtype == np.float32
    assert normals.flags.owndata is False and normals.base is not None  # the library's buffer
    cosines = np.sum(normals * bumps.normals, axis=1)
    assert np.median(cosines) > 0.99  # oriented towards the viewpoint above the plane, like the truth
    # From a bare array too, with the same result.
    np.testing.assert_array_equal(sspc.estimate_normals(bumps.positions, viewpoint=(0, 0, 10)), normals)


def test_estimate_normals_rejects_bad_arguments(bumps):
    with pytest.raises(ValueError):
        sspc.estimate_normals(bumps, k=1)
    with pytest.raises(ValueError, match="viewpoint"):
        sspc.estimate_normals(bumps, viewpoint=(0, 0))
    with pytest.raises(ValueError, match="threads"):
        sspc.estimate_normals(bumps, threads=-1)
