// LAS files built byte by byte from the ASPRS LAS specification R15 (§2.4 header, §2.5 VLRs,
// §2.6-§2.9 point formats 0-3), independently of sspc's writer, so that the reader is not only
// tested against the writer.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "io_test_util.hpp"

namespace sspc::test {

struct HandLasPoint {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint16_t intensity = 0;
  std::uint8_t return_number = 1, number_of_returns = 1;
  std::uint8_t classification = 0;  // 0..31
  std::int8_t scan_angle = 0;
  std::uint8_t user_data = 0;
  std::uint16_t point_source_id = 0;
  double gps_time = 0;
  std::uint16_t r = 0, g = 0, b = 0;
};

struct HandVlr {
  std::string user_id;
  std::uint16_t record_id = 0;
  std::string data;
};

inline void put_fixed_text(std::string& out, const std::string& s, std::size_t n) {
  std::string f = s.substr(0, n);
  f.resize(n, '\0');
  out += f;
}

// A LAS 1.2 file of point format 0-3 with the given scale, offset and records.
inline std::string hand_las12(int format, const std::vector<HandLasPoint>& points, double scale,
                              double offset_x, double offset_y, double offset_z,
                              const std::vector<HandVlr>& vlrs = {}) {
  const std::uint16_t lengths[4] = {20, 28, 26, 34};
  std::size_t vlr_bytes = 0;
  for (const HandVlr& v : vlrs) vlr_bytes += 54 + v.data.size();
  std::string h = "LASF";
  put<std::uint16_t>(h, 7);  // file source id
  put<std::uint16_t>(h, 0);  // global encoding
  h.append(16, '\0');        // GUID
  put<std::uint8_t>(h, 1);
  put<std::uint8_t>(h, 2);
  put_fixed_text(h, "hand", 32);
  put_fixed_text(h, "las_test_files.hpp", 32);
  put<std::uint16_t>(h, 100);
  put<std::uint16_t>(h, 2024);
  put<std::uint16_t>(h, 227);
  put<std::uint32_t>(h, static_cast<std::uint32_t>(227 + vlr_bytes));
  put<std::uint32_t>(h, static_cast<std::uint32_t>(vlrs.size()));
  put<std::uint8_t>(h, static_cast<std::uint8_t>(format));
  put<std::uint16_t>(h, lengths[format]);
  put<std::uint32_t>(h, static_cast<std::uint32_t>(points.size()));
  for (int r = 0; r < 5; ++r) put<std::uint32_t>(h, 0);
  for (int k = 0; k < 3; ++k) put<double>(h, scale);
  put<double>(h, offset_x);
  put<double>(h, offset_y);
  put<double>(h, offset_z);
  for (int k = 0; k < 6; ++k) put<double>(h, 0.0);  // bounds (not checked by readers)
  for (const HandVlr& v : vlrs) {
    put<std::uint16_t>(h, 0);
    put_fixed_text(h, v.user_id, 16);
    put<std::uint16_t>(h, v.record_id);
    put<std::uint16_t>(h, static_cast<std::uint16_t>(v.data.size()));
    put_fixed_text(h, "", 32);
    h += v.data;
  }
  for (const HandLasPoint& p : points) {
    put<std::int32_t>(h, p.x);
    put<std::int32_t>(h, p.y);
    put<std::int32_t>(h, p.z);
    put<std::uint16_t>(h, p.intensity);
    put<std::uint8_t>(h, static_cast<std::uint8_t>(p.return_number | (p.number_of_returns << 3)));
    put<std::uint8_t>(h, p.classification);
    put<std::int8_t>(h, p.scan_angle);
    put<std::uint8_t>(h, p.user_data);
    put<std::uint16_t>(h, p.point_source_id);
    if (format == 1 || format == 3) put<double>(h, p.gps_time);
    if (format >= 2) {
      put<std::uint16_t>(h, p.r);
      put<std::uint16_t>(h, p.g);
      put<std::uint16_t>(h, p.b);
    }
  }
  return h;
}

// Points of a 0.15 m patch at (500000, 4500000, 100) on a millimetre grid, with varied fields.
inline std::vector<HandLasPoint> hand_points(int n) {
  std::vector<HandLasPoint> out;
  for (int i = 0; i < n; ++i) {
    HandLasPoint p;
    p.x = 50000000 + (i * 37) % 150;
    p.y = 450000000 + (i * 53) % 150;
    p.z = 10000 + (i * 11) % 40;
    p.intensity = static_cast<std::uint16_t>(i * 1000);
    p.return_number = static_cast<std::uint8_t>(1 + i % 3);
    p.number_of_returns = 3;
    p.classification = static_cast<std::uint8_t>(2 + i % 4);
    p.scan_angle = static_cast<std::int8_t>(i % 30 - 15);
    p.user_data = static_cast<std::uint8_t>(i);
    p.point_source_id = static_cast<std::uint16_t>(17 + i % 2);
    p.gps_time = 123456.789 + i * 1e-5;
    p.r = static_cast<std::uint16_t>(i * 257);
    p.g = static_cast<std::uint16_t>(65535 - i * 100);
    p.b = 4096;
    out.push_back(p);
  }
  return out;
}

}  // namespace sspc::test
