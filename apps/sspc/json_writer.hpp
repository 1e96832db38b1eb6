// A small streaming JSON writer for `--json` output: objects, arrays, strings, numbers.
//
// Non-finite numbers have no JSON spelling; they are written as null (PSNR of identical clouds
// is +inf, reported as null with the reason in a sibling field where it matters).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "sspc/point_cloud.hpp"

namespace sspc::cli {

class JsonWriter {
 public:
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();
  JsonWriter& key(std::string_view k);
  JsonWriter& value(std::string_view v);
  JsonWriter& value(const char* v) { return value(std::string_view(v)); }
  JsonWriter& value(double v);
  JsonWriter& value(std::uint64_t v);
  JsonWriter& value(std::int64_t v);
  JsonWriter& value(int v) { return value(static_cast<std::int64_t>(v)); }
  JsonWriter& value(bool v);
  JsonWriter& null();

  template <typename T>
  JsonWriter& field(std::string_view k, const T& v) {
    key(k);
    return value(v);
  }

  const std::string& str() const { return out_; }

 private:
  void separator();
  std::string out_;
  std::vector<bool> first_;  // per open container: no element written yet
  bool after_key_ = false;
};

// [x, y, z] as a JSON array of numbers.
void write_vec3(JsonWriter& json, const Vec3f& v);
void write_vec3(JsonWriter& json, const Vec3d& v);

}  // namespace sspc::cli
