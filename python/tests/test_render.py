"""render, Scene and write_png."""

import struct
import zlib

import numpy as np
import pytest

import sspc


def background_fraction(image):
    return np.mean(np.all(image == image[0, 0], axis=2))


def test_render_a_model_gives_an_rgb_image_of_the_surface(bunny_model):
    image = sspc.render(bunny_model, width=96, height=64)
    assert image.shape == (64, 96, 3) and image.dtype == np.uint8
    assert image.base is not None  # the renderer's own buffer
    # The bunny fills the middle of the frame, the corners are background.
    assert 0.1 < 1 - background_fraction(image) < 0.9
    assert np.any(image[32, 48] != image[0, 0])


def test_depth_is_finite_where_the_surface_is(bunny_model):
    rgb, depth = sspc.render(bunny_model, width=64, height=64, depth=True)
    assert depth.shape == (64, 64) and depth.dtype == np.float32
    hit = np.isfinite(depth)
    assert hit[32, 32] and not hit[0, 0]
    assert np.all(np.any(rgb[hit] != rgb[0, 0], axis=1))


def test_a_point_cloud_and_its_model_look_alike(bunny, bunny_model):
    scene = sspc.Scene(bunny)
    assert scene.memory_bytes > 0 and scene.build_seconds >= 0
    eye = (0.0, 0.1, 0.4)
    a = scene.render(width=64, height=64, eye=eye, target=(-0.02, 0.1, 0), fov=35)
    b = sspc.render(bunny_model, width=64, height=64, eye=eye, target=(-0.02, 0.1, 0), fov=35)
    mask_a, mask_b = np.any(a != a[0, 0], axis=2), np.any(b != b[0, 0], axis=2)
    assert np.mean(mask_a == mask_b) > 0.95


def test_a_cloud_without_normals_gets_estimated_ones(bumps):
    bare = sspc.PointCloud(bumps.positions)
    image = sspc.render(bare, width=32, height=32, eye=(0, -1, 1), target=(0, 0, 0))
    assert 0 < 1 - background_fraction(image) < 1
    assert bare.normals is None  # estimated on a copy
    np.testing.assert_array_equal(sspc.render(bumps.positions, width=32, height=32, eye=(0, -1, 1),
                                              target=(0, 0, 0)).shape, (32, 32, 3))


def test_a_scene_renders_from_many_cameras(bunny_model):
    scene = sspc.Scene(bunny_model, memory_budget_mib=64)
    (lo, hi) = scene.bounds()
    centre = tuple((np.array(lo) + np.array(hi)) / 2)
    front = scene.render(width=48, height=48, eye=(centre[0], centre[1], 0.5), target=centre)
    side = scene.render(width=48, height=48, eye=(0.5, centre[1], centre[2]), target=centre)
    assert not np.array_equal(front, side)


def test_render_arguments_are_checked(bunny_model):
    with pytest.raises(ValueError, match="shade"):
        sspc.render(bunny_model, width=8, height=8, shade="toon")
    with pytest.raises(ValueError, match="memory_budget_mib"):
        sspc.Scene(bunny_model, memory_budget_mib=0)
    with pytest.raises(ValueError, match="eye"):
        sspc.render(bunny_model, width=8, height=8, eye=(1, 2))
    with pytest.raises(ValueError):
        sspc.render(bunny_model, width=0, height=8)


def test_write_png_writes_the_pixels(tmp_path):
    image = np.zeros((5, 7, 3), np.uint8)
    image[2, 3] = (255, 128, 1)
    path = tmp_path / "image.png"
    sspc.write_png(image, path)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = struct.unpack(">II", data[16:24])
    assert (width, height) == (7, 5)
    # The pixels, from the IDAT chunks (8-bit RGB, one filter byte a row).
    idat, pos = b"", 8
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        if data[pos + 4 : pos + 8] == b"IDAT":
            idat += data[pos + 8 : pos + 8 + length]
        pos += 12 + length
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(5, 1 + 7 * 3)
    assert np.all(raw[:, 0] == 0)  # no filter: the rows are the pixels
    np.testing.assert_array_equal(raw[:, 1:].reshape(5, 7, 3), image)


def test_write_png_checks_the_array(tmp_path):
    with pytest.raises(ValueError, match=r"\(H, W, 3\) uint8"):
        sspc.write_png(np.zeros((4, 4, 3), np.float32), tmp_path / "a.png")
    with pytest.raises(ValueError):
        sspc.write_png(np.zeros((4, 4), np.uint8), tmp_path / "a.png")


def test_direct_render_matches_the_render_of_the_decode(bunny_model):
    # The compressed model's surface is that of its decoded points (issue: one seamless surface):
    # the two renders agree over the pixels they hit, and hit the same pixels.
    (lo, hi) = sspc.Scene(bunny_model).bounds()
    centre = tuple((np.array(lo) + np.array(hi)) / 2)
    camera = dict(width=64, height=64, eye=(centre[0], centre[1], centre[2] + 0.4), target=centre)
    direct = sspc.render(bunny_model, **camera)
    decoded = sspc.render(bunny_model.decode_all(), **camera)
    hit_direct, hit_decoded = direct.any(axis=2), decoded.any(axis=2)
    assert hit_direct.sum() > 500
    assert (hit_direct != hit_decoded).sum() <= 0.002 * (hit_direct | hit_decoded).sum()
    both = hit_direct & hit_decoded
    mse = np.mean((direct[both].astype(float) - decoded[both].astype(float)) ** 2)
    assert mse == 0 or 10 * np.log10(255 ** 2 / mse) >= 35


def test_level_of_detail_changes_little_and_is_checked(bunny_model):
    # lod > 0 intersects a coarser form where the points lie denser than the pixels: at 96² the
    # bunny's spacing projects to about a fifth of a pixel, so the image changes, but little (the
    # C++ tests hold a smooth sphere to 35 dB).
    full = sspc.render(bunny_model, width=96, height=96)
    coarse = sspc.render(bunny_model, width=96, height=96, lod=1.0)
    assert not np.array_equal(full, coarse)
    hit_full, hit_coarse = full.any(axis=2), coarse.any(axis=2)
    assert hit_full.sum() > 1500
    assert (hit_full != hit_coarse).sum() <= 0.03 * (hit_full | hit_coarse).sum()
    both = hit_full & hit_coarse
    mse = np.mean((full[both].astype(float) - coarse[both].astype(float)) ** 2)
    assert 10 * np.log10(255 ** 2 / mse) >= 22
    assert np.array_equal(sspc.render(bunny_model, width=96, height=96, lod=0.0), full)
    with pytest.raises(ValueError):
        sspc.render(bunny_model, width=8, height=8, lod=-1.0)
