"""A LAS file written by numpy from the ASPRS LAS 1.2 layout (specification R15, §2.4 header,
§2.9 point format 3), not by sspc, and read back by numpy: `sspc convert` gives back every record
byte for byte, and `sspc encode` / `sspc decode` keep intensity, classification, returns and RGB
at each decoded point's place."""

import subprocess

import numpy as np
import pytest

HEADER = np.dtype([
    ("signature", "S4"), ("file_source_id", "<u2"), ("global_encoding", "<u2"), ("guid", "S16"),
    ("version_major", "u1"), ("version_minor", "u1"), ("system", "S32"), ("software", "S32"),
    ("day", "<u2"), ("year", "<u2"), ("header_size", "<u2"), ("point_offset", "<u4"),
    ("vlr_count", "<u4"), ("point_format", "u1"), ("record_length", "<u2"), ("point_count", "<u4"),
    ("points_by_return", "<u4", 5), ("scale", "<f8", 3), ("offset", "<f8", 3),
    ("max_x", "<f8"), ("min_x", "<f8"), ("max_y", "<f8"), ("min_y", "<f8"), ("max_z", "<f8"), ("min_z", "<f8"),
])
POINT3 = np.dtype([
    ("x", "<i4"), ("y", "<i4"), ("z", "<i4"), ("intensity", "<u2"), ("returns", "u1"),
    ("classification", "u1"), ("scan_angle", "i1"), ("user_data", "u1"), ("point_source_id", "<u2"),
    ("gps_time", "<f8"), ("red", "<u2"), ("green", "<u2"), ("blue", "<u2"),
])
assert HEADER.itemsize == 227 and POINT3.itemsize == 34


def write_las(path, ints, scale, offset, fields):
    points = np.zeros(len(ints), POINT3)
    points["x"], points["y"], points["z"] = ints[:, 0], ints[:, 1], ints[:, 2]
    for name, values in fields.items():
        points[name] = values
    world = ints * scale + offset
    h = np.zeros(1, HEADER)
    h["signature"], h["version_major"], h["version_minor"] = b"LASF", 1, 2
    h["software"], h["header_size"], h["point_offset"] = b"numpy", 227, 227
    h["point_format"], h["record_length"], h["point_count"] = 3, 34, len(points)
    h["points_by_return"][0][:] = np.bincount(points["returns"] & 7, minlength=6)[1:6]
    h["scale"], h["offset"] = scale, offset
    h["max_x"], h["min_x"] = world[:, 0].max(), world[:, 0].min()
    h["max_y"], h["min_y"] = world[:, 1].max(), world[:, 1].min()
    h["max_z"], h["min_z"] = world[:, 2].max(), world[:, 2].min()
    path.write_bytes(h.tobytes() + points.tobytes())


def read_las(path):
    data = path.read_bytes()
    h = np.frombuffer(data[:227], HEADER)[0]
    assert h["signature"] == b"LASF"
    start, n, length = int(h["point_offset"]), int(h["point_count"]), int(h["record_length"])
    assert h["point_format"] == 3 and length == 34
    return h, np.frombuffer(data[start:start + n * length], POINT3)


@pytest.fixture(scope="module")
def survey(tmp_path_factory, bunny):
    """The bunny as a 15 m statue at UTM-like coordinates on a millimetre grid, with LiDAR fields
    that follow the place (so a point's nearest neighbour tells what it should carry)."""
    path = tmp_path_factory.mktemp("las") / "survey.las"
    p = np.asarray(bunny.positions, dtype=np.float64)[::4] * 100.0  # 8,709 points: brute force below
    scale, offset = np.array([0.001] * 3), np.array([500000.0, 4500000.0, 100.0])
    ints = np.round(p / scale).astype(np.int64)
    rel = (p - p.min(axis=0)) / np.ptp(p, axis=0)
    returns_count = np.where(rel[:, 2] > 0.7, 2, 1)
    fields = {
        "intensity": (rel[:, 0] * 40000 + 1000).astype(np.uint16),
        "returns": (1 | (returns_count << 3)).astype(np.uint8),
        "classification": np.where(rel[:, 1] > 0.5, 6, 2).astype(np.uint8),
        "gps_time": 1000.0 + np.arange(len(p)) * 1e-3,
        "red": (np.round(rel[:, 0] * 255) * 256).astype(np.uint16),
        "green": (np.round(rel[:, 1] * 255) * 256).astype(np.uint16),
        "blue": np.full(len(p), 90 * 256, np.uint16),
    }
    write_las(path, ints, scale, offset, fields)
    return path


def test_convert_gives_back_every_record(survey, cli, tmp_path):
    out = tmp_path / "back.las"
    subprocess.run([cli, "--quiet", "convert", str(survey), str(out)], check=True)
    h_in, p_in = read_las(survey)
    h_out, p_out = read_las(out)
    np.testing.assert_array_equal(h_out["scale"], h_in["scale"])
    np.testing.assert_array_equal(h_out["offset"], h_in["offset"])
    assert p_out.tobytes() == p_in.tobytes()


def test_encode_decode_keeps_the_fields_at_their_place(survey, cli, tmp_path):
    model, out = tmp_path / "m.sspc", tmp_path / "dec.las"
    enc = subprocess.run([cli, "--quiet", "encode", "--colour-quality", "100", str(survey), str(model)],
                         check=True, capture_output=True, text=True)
    assert "GPS time" in enc.stderr  # not kept, and said so
    subprocess.run([cli, "--quiet", "decode", str(model), str(out)], check=True)
    h_in, p_in = read_las(survey)
    h_out, p_out = read_las(out)
    np.testing.assert_array_equal(h_out["scale"], h_in["scale"])
    src = np.stack([p_in["x"], p_in["y"], p_in["z"]], axis=1).astype(np.float64)
    dec = np.stack([p_out["x"], p_out["y"], p_out["z"]], axis=1).astype(np.float64)
    # The encoder took each decoded point's values from its nearest source point, before the
    # decoder rounded it to the LAS grid (up to 0.87 grid units away): any source point within
    # one grid unit of the nearest may be the one.
    wrong = {name: 0 for name in ("classification", "intensity", "returns", "rgb")}
    for start in range(0, len(dec), 1024):  # brute force, in slices that fit in memory
        d = np.sqrt(((dec[start:start + 1024, None, :] - src[None, :, :]) ** 2).sum(axis=2))
        for row, i in enumerate(range(start, min(start + 1024, len(dec)))):
            near = p_in[d[row] <= d[row].min() + 1.0]
            got = p_out[i]
            wrong["classification"] += got["classification"] not in near["classification"]
            wrong["intensity"] += got["intensity"] not in near["intensity"]
            wrong["returns"] += (got["returns"] & 0x3F) not in (near["returns"] & 0x3F)
            # 8 bits a channel: the high bytes.
            rgb = np.stack([near["red"] >> 8, near["green"] >> 8, near["blue"] >> 8], axis=1)
            wrong["rgb"] += not (rgb == [got["red"] >> 8, got["green"] >> 8, got["blue"] >> 8]).all(axis=1).any()
    assert wrong == {name: 0 for name in wrong}
