"""eval: the keys and values of `sspc eval --json`."""

import math

import numpy as np
import pytest

import sspc


def test_identical_clouds_have_infinite_psnr(bunny):
    report = sspc.eval(bunny, bunny)
    assert report["identical"] and report["rms"] == 0 and report["hausdorff"] == 0
    assert math.isinf(report["psnr"]) and math.isinf(report["d1_psnr"])
    assert report["ref_normals"] == "file"
    assert report["normal_angle_mean_deg"] == pytest.approx(0, abs=1e-6)


def test_a_shifted_cloud_has_the_paper_psnr(bumps):
    shift = 1e-3
    moved = sspc.PointCloud(bumps.positions + np.float32([0, 0, shift]))
    report = sspc.eval(bumps, moved)
    assert report["ref_points"] == report["test_points"] == len(bumps)
    assert report["rms"] == pytest.approx(shift, rel=0.05)
    assert report["psnr"] == pytest.approx(20 * math.log10(report["ref_diagonal"] / report["rms"]))
    assert not report["identical"]
    assert set(report["ref_to_test"]) >= {"rms", "hausdorff", "d1_mse", "d2_mse"}
    assert "normal_angle_mean_deg" not in report  # the test cloud has no normals


def test_decoded_model_psnr_and_bits_per_point(bunny, bunny_model, bunny_model_path):
    report = sspc.eval(bunny, bunny_model.decode_all(), compressed=bunny_model_path)
    assert 45 < report["psnr"] < 80
    assert report["compressed_bytes"] == bunny_model_path.stat().st_size
    assert report["bits_per_point"] == pytest.approx(bunny_model.info()["bits_per_point"])
    assert sspc.eval(bunny, bunny, compressed=b"x" * 100)["compressed_bytes"] == 100


def test_reference_without_normals(bumps):
    bare = sspc.PointCloud(bumps.positions)
    report = sspc.eval(bare, bumps)
    assert report["ref_normals"] == "estimated" and "d2_psnr" in report
    assert "normal_angle_mean_deg" not in report  # estimated normals are not compared
    # Neither argument changed: the normals were added to and taken from copies.
    assert bare.normals is None and bumps.normals is not None
    no_d2 = sspc.eval(bare.positions, bumps, estimate_normals=False)
    assert no_d2["ref_normals"] == "none" and "d2_psnr" not in no_d2


def test_colour_psnr(bumps):
    rng = np.random.default_rng(5)
    colours = rng.integers(0, 250, size=(len(bumps), 3), dtype=np.uint8)
    ref = sspc.PointCloud(bumps.positions, colours=colours)
    assert math.isinf(sspc.eval(ref, ref)["colour_psnr"])
    # Every channel 5 levels up: MSE 25 in both directions, PSNR 10 log10(255^2 / 25).
    brighter = sspc.PointCloud(bumps.positions, colours=colours + np.uint8(5))
    report = sspc.eval(ref, brighter)
    assert report["colour_mse"] == report["ref_to_test"]["colour_mse"] == 25
    assert report["colour_psnr"] == pytest.approx(10 * math.log10(255**2 / 25))
    assert "colour_psnr" not in sspc.eval(bumps, brighter)  # only one cloud has colours


def test_eval_errors(bumps):
    with pytest.raises(ValueError):
        sspc.eval(bumps, bumps, peak=-1)
    with pytest.raises(ValueError, match=r"decoded must have shape \(N, 3\)"):
        sspc.eval(bumps, np.zeros((4, 2)))
