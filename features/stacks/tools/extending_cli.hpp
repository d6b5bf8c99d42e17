#pragma once
// The command line add-textons and add-people share: work folders in, OUT/<name of each> out.
#include <string>
#include <vector>

#include "smseg/common/cli.hpp"
#include "smseg/common/options.hpp"

namespace smseg::stacks {

struct ExtendingCli {
  std::vector<std::string> works;
  std::string out, frames = "0:";
  int threads = 0;
  bool quiet = false;

  /// WORK..., --frames, --threads, -q and -o, after the tool's own positionals.
  void add_to(CLI::App& app) {
    app.add_option("WORK", works, "work folders (from extract-features, or folders that extend them)")->required();
    app.add_option("--frames", frames, "frames written, A:B half-open")->capture_default_str();
    add_threads_option(app, threads, "the output does not depend on it");
    app.add_flag("-q,--quiet", quiet, "no progress on stderr");
    app.add_option("-o,--out", out, "output folder: OUT/<name of each WORK>/")->required();
  }
};

}  // namespace smseg::stacks
