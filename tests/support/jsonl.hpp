#pragma once
// Reading a JSON Lines file (one record per line, e.g. run-experiment's experiment.jsonl) in tests.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace smseg::test {

/// Every non-empty line of `path` parsed as JSON (none when the file does not exist).
inline std::vector<nlohmann::json> read_jsonl(const std::filesystem::path& path) {
  std::vector<nlohmann::json> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(nlohmann::json::parse(line));
  return out;
}

}  // namespace smseg::test
