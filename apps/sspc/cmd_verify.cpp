// sspc verify FILE.sspc: every checksum and a decode of every block; "ok" or what is corrupt and
// where (section, block, byte offset).
#include <chrono>
#include <memory>
#include <string>

#include "command.hpp"
#include "sspc/compressed_model.hpp"

namespace sspc::cli {
namespace {

struct VerifyOptions {
  std::string input;
  bool json = false;
};

int run_verify(const VerifyOptions& o, const GlobalOptions& global) {
  const auto start = std::chrono::steady_clock::now();
  auto model = open_model(o.input);
  if (!model.ok()) return report_failure(model.status());
  const Status s = model->verify();
  if (!s.ok()) return report_failure(s);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (o.json) {
    const ModelInfo m = model->info();
    Json json = json_report("verify");
    json["file"] = o.input;
    json["ok"] = true;
    json["file_bytes"] = m.file_bytes;
    json["patches"] = m.patches;
    json["codewords"] = m.codewords;
    json["seconds"] = seconds;
    print_json(json);
  } else if (!global.quiet) {
    print_line("ok");
  }
  return kExitOk;
}

}  // namespace

Command add_verify_command(CLI::App& root, const GlobalOptions& global) {
  auto o = std::make_shared<VerifyOptions>();
  CLI::App* app = root.add_subcommand("verify",
                                      "Check an .sspc file: every checksum and a decode of every "
                                      "block; prints \"ok\" or what is corrupt");
  app->add_option("file", o->input, "Compressed model (.sspc; '-' reads stdin)")->required();
  app->add_flag("--json", o->json, "Machine-readable result on stdout (keys: docs/CLI.md)");
  app->footer("Example: sspc verify model.sspc");
  return {app, [o, &global] { return run_verify(*o, global); }};
}

}  // namespace sspc::cli
