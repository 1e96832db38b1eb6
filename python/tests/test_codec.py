"""encode and CompressedModel: statistics, random access against the whole decode and against the
command-line tool, and the errors of missing and corrupt files."""

import subprocess

import numpy as np
import pytest

import sspc
from conftest import rows


def test_encode_to_a_file_returns_the_cli_statistics(bumps, tmp_path):
    path = tmp_path / "bumps.sspc"
    # The paper's regime: small patches and τ of one spacing (the default levels instance a
    # patch only within half their grid step).
    stats = sspc.encode(bumps, path, level=5, patch_points=256, tau=1.0)
    for key in ("level", "points", "patches", "codewords", "bits_per_point", "file_bytes", "covered", "seconds"):
        assert key in stats
    assert stats["points"] == len(bumps)
    assert stats["file_bytes"] == path.stat().st_size
    assert stats["bits_per_point"] == pytest.approx(8 * stats["file_bytes"] / len(bumps))
    assert stats["covered"]
    # A surface of identical bumps shares code words between its patches.
    assert stats["codewords"] < stats["patches"]


def test_encode_to_bytes_gives_the_same_file(bumps, tmp_path):
    path = tmp_path / "bumps.sspc"
    sspc.encode(bumps, path, level=6, seed=2)
    data = sspc.encode(bumps, None, level=6, seed=2)
    assert isinstance(data, bytes)
    assert data == path.read_bytes()  # deterministic, and the same writer


def test_encode_options_are_checked(bumps):
    with pytest.raises(ValueError, match="level"):
        sspc.encode(bumps, None, level=10)
    with pytest.raises(ValueError, match="normals must be"):
        sspc.encode(bumps, None, normals="guess")
    with pytest.raises(ValueError):
        sspc.encode(sspc.synthetic.plane(10), None)  # fewer than 16 points
    with pytest.raises(TypeError):
        sspc.encode(bumps, None, 5)  # options are keyword-only


def test_levels_trade_rate_for_detail(bumps):
    fine = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, level=2))
    coarse = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, level=8))
    assert coarse.info()["bits_per_point"] < fine.info()["bits_per_point"]
    assert sspc.eval(bumps, coarse.decode_all())["psnr"] < sspc.eval(bumps, fine.decode_all())["psnr"]


def test_info_describes_the_model(bunny_model, bunny_model_path, bunny):
    info = bunny_model.info()
    assert info["format"] == "sspc" and info["version"] == 7
    assert info["source_points"] == len(bunny)
    assert info["patches"] == bunny_model.patch_count
    assert info["codewords"] == bunny_model.codeword_count
    assert info["file_bytes"] == bunny_model_path.stat().st_size
    lo, hi = bunny.bounds()
    assert np.allclose(info["bbox_min"], lo, atol=1e-3) and np.allclose(info["bbox_max"], hi, atol=1e-3)
    assert [s["name"] for s in info["sections"]][0] == "header"


def test_patches_concatenate_to_the_whole_decode(bunny_model):
    whole = bunny_model.decode_all()
    assert abs(len(whole) - bunny_model.info()["source_points"]) < 0.05 * len(whole)
    parts = [bunny_model.decode_patch(k).positions for k in range(bunny_model.patch_count)]
    np.testing.assert_array_equal(np.concatenate(parts), whole.positions)


def test_the_block_cache_keeps_within_its_budget(bumps):
    # Small patches: many patch blocks, more than the cache's 16 shards keep at a budget of 0.
    model = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, patch_points=12))
    assert model.cache_budget == 64 << 20
    first = [model.decode_patch(k).positions for k in range(model.patch_count)]
    full = model.cache_bytes
    assert full > 0
    model.cache_budget = 0  # evicts at once
    assert model.cache_budget == 0 and model.cache_bytes < full
    again = [model.decode_patch(k).positions for k in range(model.patch_count)]
    assert model.cache_bytes < full
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)


def test_chunks_concatenate_to_the_whole_decode(bumps):
    # Small patches: several patch blocks (64 patches each), the unit a chunk is made of.
    model = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, patch_points=12))
    assert model.patch_count > 3 * 64
    whole = model.decode_all()
    chunks = []
    model.decode_chunks(chunks.append, chunk_points=len(whole) // 4)
    assert 3 <= len(chunks) <= 8
    np.testing.assert_array_equal(np.concatenate([c.positions for c in chunks]), whole.positions)

    def stop(chunk):
        raise KeyError("enough")

    with pytest.raises(KeyError, match="enough"):
        model.decode_chunks(stop, chunk_points=1)


def test_patch_record_maps_the_code_word_onto_the_patch(bunny_model):
    record = bunny_model.patch(3)
    r, t = record["rotation"], record["translation"]
    assert r.shape == (3, 3) and t.shape == (3,)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-4)
    word = bunny_model.codeword(record["codeword"])
    placed = word["points"].positions @ r.T + t  # world_from_codeword
    decoded = bunny_model.decode_patch(3, overlap=True).positions
    assert len(decoded) == len(placed)
    np.testing.assert_allclose(decoded, placed, atol=1e-5)


def test_decode_box_is_the_subset_of_the_whole_inside_it(bunny_model):
    whole = bunny_model.decode_all()
    lo, hi = np.array([-0.05, 0.05, -0.05]), np.array([0.0, 0.12, 0.05])
    box = bunny_model.decode_box(lo, hi)
    p = whole.positions
    inside = p[np.all((p >= lo.astype(np.float32)) & (p <= hi.astype(np.float32)), axis=1)]
    assert 0 < len(box) < len(whole)
    np.testing.assert_array_equal(box.positions, inside)  # the same points, in the same order
    assert rows(box) <= rows(whole)
    empty = bunny_model.decode_box((10, 10, 10), (11, 11, 11))
    assert len(empty) == 0 and empty.positions.shape == (0, 3)


def test_decode_all_equals_the_command_line_decode(bunny_model, bunny_model_path, cli, tmp_path):
    out = tmp_path / "cli.ply"
    subprocess.run([cli, "--quiet", "decode", str(bunny_model_path), str(out)], check=True)
    from_cli = sspc.read(out)
    mine = bunny_model.decode_all()
    np.testing.assert_array_equal(mine.positions, from_cli.positions)
    assert (mine.normals is None) == (from_cli.normals is None)


def test_from_bytes_decodes_like_open(bunny_model, bunny_model_path):
    for data in (bunny_model_path.read_bytes(), bytearray(bunny_model_path.read_bytes())):
        model = sspc.CompressedModel.from_bytes(data)
        np.testing.assert_array_equal(model.decode_all().positions, bunny_model.decode_all().positions)


def test_from_bytes_reads_strided_and_reversed_views_in_logical_order(bunny_model, bunny_model_path):
    data = np.frombuffer(bunny_model_path.read_bytes(), np.uint8)
    reversed_view = data[::-1].copy()[::-1]  # negative stride: its first element is at the end
    strided_view = np.repeat(data, 2)[::2]  # stride 2
    assert reversed_view.strides[0] < 0 and strided_view.strides[0] == 2
    expected = bunny_model.decode_all().positions
    for view in (reversed_view, strided_view, memoryview(strided_view)):
        model = sspc.CompressedModel.from_bytes(view)
        np.testing.assert_array_equal(model.decode_all().positions, expected)
    # A large zero buffer viewed backwards is read within its bounds and refused by its content.
    with pytest.raises(RuntimeError, match="not an .sspc file"):
        sspc.CompressedModel.from_bytes(np.zeros(50_000_000, np.uint8)[::-1])


def test_store_normals_decodes_normals(bumps):
    model = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, store_normals=True))
    assert model.info()["normals"]
    decoded = model.decode_all()
    assert decoded.normals is not None and decoded.normals.shape == decoded.positions.shape


def test_missing_and_corrupt_files_raise_with_the_library_message(bunny_model_path, tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.sspc: no such file"):
        sspc.CompressedModel.open(tmp_path / "nothing.sspc")
    with pytest.raises(RuntimeError, match="not an .sspc file"):
        sspc.CompressedModel.from_bytes(b"this is not a model")
    data = bunny_model_path.read_bytes()
    truncated = tmp_path / "truncated.sspc"
    truncated.write_bytes(data[: len(data) // 3])
    with pytest.raises(RuntimeError, match="truncated.sspc.*truncated"):
        sspc.CompressedModel.open(truncated)
    flipped = bytearray(data)
    flipped[len(data) // 2] ^= 0xFF  # inside a block: found when the block is read
    model = sspc.CompressedModel.from_bytes(flipped)
    with pytest.raises(RuntimeError, match="CRC32 mismatch"):
        model.verify()
    with pytest.raises(RuntimeError, match="corrupt"):
        model.decode_all()


def test_indices_are_checked(bunny_model):
    with pytest.raises(IndexError, match="out of range"):
        bunny_model.decode_patch(bunny_model.patch_count)
    with pytest.raises(IndexError):
        bunny_model.patch(-1)
    with pytest.raises(IndexError):
        bunny_model.codeword(bunny_model.codeword_count)


def _attributed(bumps):
    """The bumps with colours, intensity, classification and returns that follow the place."""
    p = bumps.positions.astype(np.float64)
    colours = np.stack([p[:, 0] * 200 + 20, p[:, 1] * 200 + 30, np.full(len(p), 90.0)], axis=1)
    return sspc.PointCloud(
        bumps.positions, bumps.normals, np.clip(np.round(colours), 0, 255).astype(np.uint8),
        intensity=(p[:, 0] * 60000).astype(np.uint16),
        classification=np.where(p[:, 2] > 0.02, 5, 2).astype(np.uint8),
        return_number=np.ones(len(p), dtype=np.uint8),
        number_of_returns=np.where(p[:, 1] > 0.5, 2, 1).astype(np.uint8),
    )


def test_per_point_attributes_come_back_at_their_place(bumps):
    cloud = _attributed(bumps)
    assert cloud.intensity.dtype == np.uint16 and cloud.classification.dtype == np.uint8
    data = sspc.encode(cloud, None, colour_quality=100)
    model = sspc.CompressedModel.from_bytes(data)
    info = model.info()
    assert info["colours"] and info["intensity"] and info["classification"] and info["returns"]
    assert info["colour_step"] == 1 and info["attribute_bytes"] > 0
    decoded = model.decode_all()
    # Each decoded point carries the values of its nearest source point, losslessly here.
    src = cloud.positions.astype(np.float64)
    out = decoded.positions.astype(np.float64)
    nearest = np.array([np.argmin(((src - q) ** 2).sum(axis=1)) for q in out])
    np.testing.assert_array_equal(decoded.colours, cloud.colours[nearest])
    np.testing.assert_array_equal(decoded.intensity, cloud.intensity[nearest])
    np.testing.assert_array_equal(decoded.classification, cloud.classification[nearest])
    np.testing.assert_array_equal(decoded.number_of_returns, cloud.number_of_returns[nearest])


def test_attribute_options_choose_what_is_kept_and_its_rate(bumps, tmp_path):
    cloud = _attributed(bumps)
    fine = sspc.encode(cloud, tmp_path / "fine.sspc", colour_quality=100)
    coarse = sspc.encode(cloud, tmp_path / "coarse.sspc", colour_quality=20)
    assert coarse["colour_bytes"] < fine["colour_bytes"]
    assert fine["classification_bytes"] > 0 and fine["colour_step"] == 1
    only = sspc.CompressedModel.open(
        tmp_path / "only.sspc" if sspc.encode(cloud, tmp_path / "only.sspc", attributes=["classification"]) else None)
    assert only.info()["classification"] and not only.info()["colours"]
    assert only.decode_all().colours is None
    none = sspc.CompressedModel.from_bytes(sspc.encode(cloud, None, attributes="none"))
    assert none.info()["attribute_bytes"] == 0
    with pytest.raises(ValueError, match="unknown attribute 'color'"):
        sspc.encode(cloud, None, attributes="color")
    with pytest.raises(ValueError, match="0..255"):
        sspc.PointCloud(cloud.positions, classification=np.full(len(cloud), 256))


def test_coarse_levels_decode_resampled_unless_asked_for_the_stored_points(bumps):
    # Level 9's grid is 3.6 spacings: a stored point stands for about a dozen of the source's.
    model = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, level=9))
    m = model.info()["resample"]
    assert 2 <= m <= 4
    stored = model.decode_all(stored=True)
    resampled = model.decode_all()
    assert len(resampled) == m * m * len(stored)
    # Each stored point's m² points follow it, within its grid cell and a step off its tangent
    # plane: |offset| <= step * sqrt(1/2 + 1).
    info = model.info()
    step = 2 * info["patch_radius"] / 2 ** info["position_bits"]
    near = resampled.positions.reshape(len(stored), m * m, 3) - stored.positions[:, None, :]
    assert np.linalg.norm(near, axis=2).max() <= 1.23 * step
    # Resampling restores the source's density: closer to it under the paper's PSNR.
    assert sspc.eval(bumps, resampled)["psnr"] > sspc.eval(bumps, stored)["psnr"] + 1.0
    k = model.patch_count // 2
    assert len(model.decode_patch(k)) == m * m * len(model.decode_patch(k, stored=True))

    off = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, level=9, resample="off"))
    assert off.info()["resample"] == 0
    np.testing.assert_array_equal(off.decode_all().positions, stored.positions)
    two = sspc.CompressedModel.from_bytes(sspc.encode(bumps, None, level=9, resample=2))
    assert two.info()["resample"] == 2
    with pytest.raises(ValueError, match="resample"):
        sspc.encode(bumps, None, level=9, resample=5)
    with pytest.raises(ValueError, match="resample"):
        sspc.encode(bumps, None, level=9, resample="always")


def test_resampled_points_inherit_their_stored_point_attributes(bumps):
    model = sspc.CompressedModel.from_bytes(sspc.encode(_attributed(bumps), None, level=9))
    m2 = model.info()["resample"] ** 2
    assert m2 >= 4
    stored, resampled = model.decode_all(stored=True), model.decode_all()
    assert len(resampled) == m2 * len(stored)
    for name in ("colours", "intensity", "classification", "return_number", "number_of_returns"):
        np.testing.assert_array_equal(np.repeat(getattr(stored, name), m2, axis=0), getattr(resampled, name))


def test_several_files_encode_as_their_concatenation(bunny, tmp_path):
    positions = np.asarray(bunny.positions)
    parts = np.array_split(positions, 3)
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    for k, part in enumerate(parts):
        sspc.write(sspc.PointCloud(part), tiles / f"t{k}.ply")
    sspc.write(sspc.PointCloud(positions), tmp_path / "whole.ply")
    whole = sspc.encode(tmp_path / "whole.ply", None, level=7)
    assert sspc.encode([tiles / f"t{k}.ply" for k in range(3)], None, level=7) == whole
    assert sspc.encode([str(tiles)], None, level=7) == whole  # a folder, its files by name
    limited = sspc.encode(tmp_path / "whole.ply", None, level=7, tile_points=9000, memory_limit=1 << 30)
    assert sspc.encode((str(tiles / "t*.ply"),), None, level=7, tile_points=9000, memory_limit=1 << 30) == limited
    with pytest.raises(ValueError, match="no file matches"):
        sspc.encode([str(tiles / "*.las")], None)


def test_a_memory_limit_needs_a_file(bumps):
    # The limit reads the input in passes; a cloud in memory is held whole already: refused, not ignored.
    with pytest.raises(ValueError, match="memory_limit reads the input in passes"):
        sspc.encode(bumps, None, memory_limit=1 << 30)
