// Point clouds given in double, and the files that store them at that precision (XYZ text, PLY
// ascii and binary double, PCD ascii and binary F 8), for the tests of what float32 keeps.
#pragma once

#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "sspc/point_cloud.hpp"

namespace sspc::test {

// A wavy square patch about the size of the Stanford bunny (0.15 across), sampled on an n x n
// grid, near the origin.
inline std::vector<Vec3d> wavy_patch(int n) {
  std::vector<Vec3d> points;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double u = 0.15 * i / (n - 1) - 0.08, v = 0.15 * j / (n - 1) - 0.05;
      points.emplace_back(u, v, 0.01 * std::sin(40 * u) * std::cos(30 * v));
    }
  }
  return points;
}

// `points` moved by a small known amount: a stand-in for a decoded copy.
inline std::vector<Vec3d> perturbed(const std::vector<Vec3d>& points, double amount) {
  std::vector<Vec3d> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double t = static_cast<double>(i);
    out.push_back(points[i] +
                  amount * Vec3d(std::sin(1.3 * t), std::cos(0.7 * t), std::sin(2.1 * t)));
  }
  return out;
}

inline std::vector<Vec3d> shifted(std::vector<Vec3d> points, const Vec3d& by) {
  for (Vec3d& p : points) p += by;
  return points;
}

// The shortest decimal that reads back as exactly `v`.
inline std::string shortest(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

inline std::string xyz_text(const std::vector<Vec3d>& points) {
  std::string out;
  for (const Vec3d& p : points) {
    out += shortest(p.x()) + " " + shortest(p.y()) + " " + shortest(p.z()) + "\n";
  }
  return out;
}

inline void append_double(std::string& out, double v) {
  char b[8];
  std::memcpy(b, &v, 8);  // little-endian hosts, as every platform sspc builds on
  out.append(b, 8);
}

inline std::string ply_double(const std::vector<Vec3d>& points, bool binary) {
  std::string out = "ply\nformat " + std::string(binary ? "binary_little_endian" : "ascii") +
                    " 1.0\nelement vertex " + std::to_string(points.size()) +
                    "\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
  if (!binary) return out + xyz_text(points);
  for (const Vec3d& p : points) {
    for (int k = 0; k < 3; ++k) append_double(out, p[k]);
  }
  return out;
}

inline std::string pcd_double(const std::vector<Vec3d>& points, bool binary) {
  std::string out =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n"
      "WIDTH " +
      std::to_string(points.size()) + "\nHEIGHT 1\nPOINTS " + std::to_string(points.size()) +
      "\nDATA " + (binary ? "binary" : "ascii") + "\n";
  if (!binary) return out + xyz_text(points);
  for (const Vec3d& p : points) {
    for (int k = 0; k < 3; ++k) append_double(out, p[k]);
  }
  return out;
}

inline void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

}  // namespace sspc::test
