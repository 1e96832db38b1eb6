// sspc verify FILE.sspc: every checksum and a decode of every block; "ok" or what is corrupt and
// where (section, block, byte offset).
#include <memory>
#include <string>

#include "command.hpp"
#include "sspc/compressed_model.hpp"

namespace sspc::cli {
namespace {

int run_verify(const std::string& input) {
  auto model = CompressedModel::open(input);
  if (!model.ok()) return report_failure(model.status());
  const Status s = model->verify();
  if (!s.ok()) return report_failure(s);
  print_line("ok");
  return kExitOk;
}

}  // namespace

Command add_verify_command(CLI::App& root, const GlobalOptions& /*global*/) {
  auto input = std::make_shared<std::string>();
  CLI::App* app = root.add_subcommand(
      "verify", "Check an .sspc file: every checksum and a decode of every block");
  app->add_option("file", *input, "Compressed model (.sspc)")->required();
  return {app, [input] { return run_verify(*input); }};
}

}  // namespace sspc::cli
