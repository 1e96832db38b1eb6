// Every subcommand's --json output against the keys docs/CLI.md documents: no key that is not
// documented, every key documented as "always" present, and every documented key produced by
// one of the runs here. The document is parsed, so the two cannot drift apart.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdlib>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "cli_util.hpp"
#include "test_util.hpp"

namespace sspc {
namespace {

struct DocumentedKeys {
  std::set<std::string> all;
  std::set<std::string> always;
};

// "### name" starts a section, "## " ends it; "| `key` | type | unit | present | meaning |" rows
// list its keys.
std::map<std::string, DocumentedKeys> documented() {
  std::istringstream doc(slurp(SSPC_CLI_DOC));
  std::map<std::string, DocumentedKeys> sections;
  std::string section;
  std::string line;
  while (std::getline(doc, line)) {
    if (line.starts_with("### ")) {
      section = line.substr(4);
      continue;
    }
    if (line.starts_with("## ")) {  // a chapter that is not the CLI's JSON (sspc.distributed's)
      section.clear();
      continue;
    }
    if (section.empty() || !line.starts_with("| `")) continue;
    std::vector<std::string> cells;
    std::stringstream row(line.substr(1));
    std::string cell;
    while (std::getline(row, cell, '|')) cells.push_back(cell);
    if (cells.size() < 4) continue;
    const std::string key =
        cells[0].substr(cells[0].find('`') + 1, cells[0].rfind('`') - cells[0].find('`') - 1);
    sections[section].all.insert(key);
    if (cells[3].find("always") != std::string::npos) sections[section].always.insert(key);
  }
  return sections;
}

// Keys as docs/CLI.md writes them: "parent.child" in objects, "parent[].child" in arrays of
// objects.
void flatten(const nlohmann::json& json, const std::string& prefix, std::set<std::string>& keys) {
  for (const auto& [key, value] : json.items()) {
    const std::string name = prefix + key;
    keys.insert(name);
    if (value.is_object()) flatten(value, name + ".", keys);
    if (value.is_array() && !value.empty() && value.front().is_object()) {
      for (const auto& element : value) flatten(element, name + "[].", keys);
    }
  }
}

// `path` with a colour for every point, written to `out`: the colour keys of eval.
std::string coloured_copy(const std::string& path, const std::string& out) {
  auto cloud = read_point_cloud(path);
  if (!cloud.ok()) std::abort();
  cloud->colours.resize(cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    cloud->colours[i] =
        Rgb8{static_cast<std::uint8_t>(i), 128, static_cast<std::uint8_t>(255 - i % 256)};
  }
  if (!write_ply(*cloud, out).ok()) std::abort();
  return out;
}

class JsonKeys : public ::testing::Test {
 protected:
  // Checks one --json output against `section`.
  void check(const std::string& section, const CliRun& run, int exit_code = 0) {
    ASSERT_EQ(run.exit_code, exit_code) << section << ": " << run.err;
    ASSERT_EQ(docs_.count(section), 1u) << "docs/CLI.md has no section " << section;
    const nlohmann::json json = nlohmann::json::parse(run.out, nullptr, false);
    ASSERT_TRUE(json.is_object()) << section << ": not one JSON object: " << run.out;
    EXPECT_EQ(json.value("schema", 0), 1) << run.out;
    std::set<std::string> keys;
    flatten(json, "", keys);
    const DocumentedKeys& doc = docs_.at(section);
    for (const std::string& key : keys)
      EXPECT_TRUE(doc.all.count(key)) << section << ": undocumented key " << key;
    for (const std::string& key : doc.always)
      EXPECT_TRUE(keys.count(key)) << section << ": missing key " << key;
    seen_[section].insert(keys.begin(), keys.end());
  }

  std::map<std::string, DocumentedKeys> docs_ = documented();
  std::map<std::string, std::set<std::string>> seen_;
};

TEST_F(JsonKeys, EverySubcommandWritesTheDocumentedKeys) {
  test::TempDir dir;
  const std::string cloud = small_bunny(dir);
  const std::string d = dir.path().string() + "/";
  ASSERT_GE(docs_.size(), 10u) << "sections parsed from docs/CLI.md";

  check("info", sspc(dir, "info --json " + cloud));
  check("convert", sspc(dir, "convert --json " + cloud + " " + d + "bunny.las"));
  check("info", sspc(dir, "info --json " + d + "bunny.las"));
  check("normals", sspc(dir, "normals --json " + cloud + " " + d + "n.ply --normals estimate"));
  check("encode", sspc(dir, "encode --json " + cloud + " " + d + "m.sspc --level 9"));
  check("info (.sspc)", sspc(dir, "info --json " + d + "m.sspc"));
  check("verify", sspc(dir, "verify --json " + d + "m.sspc"));
  check("decode", sspc(dir, "decode --json " + d + "m.sspc " + d + "dec.ply"));
  check("eval",
        sspc(dir, "eval --json " + cloud + " " + d + "dec.ply --compressed " + d + "m.sspc"));
  check("eval", sspc(dir, "eval --json " + cloud + " " + d + "n.ply"));
  const std::string coloured = coloured_copy(cloud, d + "coloured.ply");
  check("eval", sspc(dir, "eval --json " + coloured + " " + coloured));
  check("render", sspc(dir, "render --json " + cloud + " -o " + d +
                                "a.png --size 32x32 --memory-budget 64"));
  check("render", sspc(dir, "render --json " + d + "m.sspc -o " + d +
                                "b.png --size 32x32 --lod 0.5 --compare " + d + "a.png"));
  check("render",
        sspc(dir, "render --json " + cloud + " -o " + d + "f.png --size 16x16 --orbit 2"));
  check("error", sspc(dir, "info --json " + d + "absent.ply"), 1);
  check("error", sspc(dir, "encode --json --level 12 " + cloud + " " + d + "x.sspc"), 2);

  for (const auto& [section, doc] : docs_) {
    ASSERT_TRUE(seen_.count(section)) << "no run checks docs/CLI.md's section " << section;
    for (const std::string& key : doc.all) {
      EXPECT_TRUE(seen_[section].count(key))
          << section << ": documented key " << key << " never written";
    }
  }
}

TEST_F(JsonKeys, AFailureNamesItsFileAndKeepsTheExitCode) {
  test::TempDir dir;
  const std::string absent = (dir.path() / "absent.ply").string();
  const CliRun missing = sspc(dir, "info --json " + absent);
  EXPECT_EQ(missing.exit_code, 1);
  const nlohmann::json error = nlohmann::json::parse(missing.out, nullptr, false);
  ASSERT_TRUE(error.is_object()) << missing.out;
  EXPECT_EQ(error["command"], "info");
  EXPECT_EQ(error["file"], absent);
  EXPECT_NE(error["error"].get<std::string>().find("absent.ply"), std::string::npos);
  EXPECT_NE(missing.err.find("sspc: error:"), std::string::npos) << "stderr keeps the message";

  const CliRun usage = sspc(dir, "verify --json");  // the file is missing
  EXPECT_EQ(usage.exit_code, 2);
  const nlohmann::json usage_error = nlohmann::json::parse(usage.out, nullptr, false);
  ASSERT_TRUE(usage_error.is_object()) << usage.out;
  EXPECT_EQ(usage_error["command"], "verify");
  EXPECT_TRUE(usage_error["file"].is_null());
}

}  // namespace
}  // namespace sspc
