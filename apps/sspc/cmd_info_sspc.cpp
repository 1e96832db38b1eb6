// The .sspc branch of `sspc info`: header, sections and their sizes, patches, code words,
// code-book ratio and bits per point.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "command.hpp"
#include "sspc/compressed_model.hpp"
#include "sspc/encoder.hpp"

namespace sspc::cli {
bool is_sspc_file(const std::string& path) {
  static constexpr char kMagic[8] = {'\x8A', 'S', 'P', 'C', '\r', '\n', '\x1A', '\n'};
  if (is_stdio(path)) {
    // The bytes stay for the reader that follows, which reports a failure to read them.
    const auto bytes = stdin_bytes();
    return bytes.ok() && bytes->size() >= sizeof kMagic && std::memcmp(bytes->data(), kMagic, sizeof kMagic) == 0;
  }
  // Opening a FIFO would wait for a writer; anything but a regular file is left to the reader
  // that follows, which refuses it with a message naming what it is.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  return in.read(head, sizeof head) && std::memcmp(head, kMagic, sizeof head) == 0;
}

int run_info_sspc(const std::string& path, bool as_json) {
  auto model = open_model(path);
  if (!model.ok()) return report_failure(model.status());
  const ModelInfo m = model->info();
  std::string attributes = "positions";
  if (m.has_normals) attributes += " normals";
  if (m.has_colours) attributes += " colours";
  if (m.attributes & kAttributeIntensity) attributes += " intensity";
  if (m.attributes & kAttributeClassification) attributes += " classification";
  if (m.attributes & kAttributeReturns) attributes += " returns";
  if (m.attributes != 0) {
    attributes += " (per point";
    if (m.colour_step > 0) attributes += ", colour step " + std::to_string(m.colour_step);
    if (m.intensity_step > 0) attributes += ", intensity step " + std::to_string(m.intensity_step);
    attributes += ")";
  }

  if (as_json) {
    Json json = json_report("info");
    json["file"] = path;
    json["format"] = "sspc";
    json["version"] = m.version;
    json["file_bytes"] = m.file_bytes;
    json["origin"] = json_vec3(model->origin());
    json["crs"] = model->metadata().has_crs();
    json["comments"] = model->metadata().comments.size();
    json["las_grid"] = model->metadata().las.has_value();
    json["normals"] = m.has_normals;
    json["colours"] = m.has_colours;
    json["intensity"] = (m.attributes & kAttributeIntensity) != 0;
    json["classification"] = (m.attributes & kAttributeClassification) != 0;
    json["returns"] = (m.attributes & kAttributeReturns) != 0;
    json["colour_step"] = m.colour_step;
    json["intensity_step"] = m.intensity_step;
    json["attribute_bytes"] = m.attribute_bytes;
    json["source_points"] = m.source_points;
    json["patches"] = m.patches;
    json["codewords"] = m.codewords;
    json["codeword_points"] = m.codeword_points;
    json["codebook_ratio"] = m.codebook_ratio;
    json["bits_per_point"] = m.bits_per_point;
    json["patch_radius"] = double{m.patch_radius};
    json["coverage_radius"] = double{m.coverage_radius};
    json["codeword_radius"] = double{m.codeword_radius};
    json["spacing"] = double{m.spacing};
    json["bbox_min"] = json_vec3(m.bounds.min());
    json["bbox_max"] = json_vec3(m.bounds.max());
    json["position_bits"] = m.position_bits;
    json["normal_bits"] = m.normal_bits;
    json["rotation_bits"] = m.rotation_bits;
    json["translation_step"] = double{m.translation_step};
    json["resample"] = m.resample;
    json["patches_per_block"] = m.patches_per_block;
    json["codewords_per_block"] = m.codewords_per_block;
    Json sections = Json::array();
    sections.push_back(Json{{"name", "header"}, {"offset", 0}, {"bytes", m.header_bytes}, {"raw_bytes", m.header_bytes}, {"blocks", 0}});
    for (const SectionInfo& s : m.sections) {
      sections.push_back(Json{{"name", s.name}, {"offset", s.offset}, {"bytes", s.bytes}, {"raw_bytes", s.raw_bytes}, {"blocks", s.blocks}});
    }
    json["sections"] = std::move(sections);
    print_json(json);
    return kExitOk;
  }
  auto pct = [&m](std::uint64_t b) {
    return m.file_bytes == 0 ? 0.0
                             : 100.0 * static_cast<double>(b) / static_cast<double>(m.file_bytes);
  };
  std::printf("file           %s (%llu bytes, sspc version %d)\n", path.c_str(),
              static_cast<unsigned long long>(m.file_bytes), m.version);
  std::printf("attributes     %s\n", attributes.c_str());
  std::printf("source points  %llu\n", static_cast<unsigned long long>(m.source_points));
  std::printf("patches        %llu\n", static_cast<unsigned long long>(m.patches));
  std::printf("code words     %llu (%llu points)\n", static_cast<unsigned long long>(m.codewords),
              static_cast<unsigned long long>(m.codeword_points));
  std::printf("code-book ratio %.3f (patches / code words)\n", m.codebook_ratio);
  std::printf("bits per point %.3f (file bytes × 8 / source points)\n", m.bits_per_point);
  std::printf("patch radius   %.9g (coverage %.9g, code words reach %.9g)\n",
              double{m.patch_radius}, double{m.coverage_radius}, double{m.codeword_radius});
  std::printf("spacing        %.9g\n", double{m.spacing});
  const Vec3d origin = model->origin();
  const CloudMetadata& meta = model->metadata();
  std::printf("origin         %.15g %.15g %.15g (the bounds below are relative to it)\n",
              origin.x(), origin.y(), origin.z());
  std::printf("metadata       %zu comments, CRS %s, LAS grid %s\n", meta.comments.size(),
              meta.has_crs() ? "yes" : "none", meta.las ? "yes" : "none");
  std::printf("bbox min       %.9g %.9g %.9g\n", double{m.bounds.min().x()},
              double{m.bounds.min().y()}, double{m.bounds.min().z()});
  std::printf("bbox max       %.9g %.9g %.9g\n", double{m.bounds.max().x()},
              double{m.bounds.max().y()}, double{m.bounds.max().z()});
  std::printf(
      "quantisation   positions %d bits, normals %d bits, rotations %d bits, "
      "translation step %.9g\n",
      m.position_bits, m.normal_bits, m.rotation_bits, double{m.translation_step});
  if (m.resample > 0) {
    std::printf("resample       %d x %d points a decoded point, on its code word's surface\n", m.resample,
                m.resample);
  }
  std::printf("blocks         %u patches, %u code words per block\n", m.patches_per_block,
              m.codewords_per_block);
  std::printf("sections\n");
  std::printf("  %-22s %12s %12s %8s %7s\n", "name", "bytes", "raw bytes", "blocks", "share");
  std::printf("  %-22s %12llu %12llu %8s %6.1f%%\n", "header",
              static_cast<unsigned long long>(m.header_bytes),
              static_cast<unsigned long long>(m.header_bytes), "-", pct(m.header_bytes));
  for (const SectionInfo& s : m.sections) {
    std::printf("  %-22s %12llu %12llu %8llu %6.1f%%\n", s.name.c_str(),
                static_cast<unsigned long long>(s.bytes),
                static_cast<unsigned long long>(s.raw_bytes),
                static_cast<unsigned long long>(s.blocks), pct(s.bytes));
  }
  return kExitOk;
}

}  // namespace sspc::cli
