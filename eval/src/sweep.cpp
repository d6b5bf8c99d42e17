#include "smseg/eval/sweep.hpp"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <unistd.h>

#include "smseg/common/io.hpp"

namespace smseg::eval {

std::vector<int> SweepSpec::values() const {
  std::vector<int> v;
  for (int x = first; x <= last; x += step) v.push_back(x);
  return v;
}

std::string SweepSpec::str() const {
  return std::string(1, param) + "=" + std::to_string(first) + ":" + std::to_string(last) + ":" + std::to_string(step);
}

SweepSpec SweepSpec::parse(const std::string& text, const std::string& option) {
  const auto bad = [&](const std::string& why) {
    return Error("", option, "\"" + text + "\": " + why + " (expected M=A:B, B=A:B:S or V=A:B; bounds inclusive)");
  };
  if (text.size() < 3 || text[1] != '=') throw bad("not PARAM=A:B[:S]");
  SweepSpec s;
  s.param = text[0];
  if (s.param != 'M' && s.param != 'B' && s.param != 'V') throw bad("the parameter must be M, B or V");
  std::vector<int> nums;
  std::size_t pos = 2;
  for (;;) {
    const std::size_t colon = text.find(':', pos);
    const std::string part = text.substr(pos, colon == std::string::npos ? std::string::npos : colon - pos);
    std::size_t used = 0;
    int n = 0;
    try {
      n = std::stoi(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (part.empty() || used != part.size()) throw bad("\"" + part + "\" is not a whole number");
    nums.push_back(n);
    if (colon == std::string::npos) break;
    pos = colon + 1;
  }
  if (nums.size() > 3) throw bad("too many fields");
  s.first = nums[0];
  s.last = nums.size() > 1 ? nums[1] : nums[0];
  s.step = nums.size() > 2 ? nums[2] : 1;
  if (s.first < 1) throw bad("values start at 1");
  if (s.last < s.first) throw bad("the last value is below the first");
  if (s.step < 1) throw bad("the step must be at least 1");
  return s;
}

std::vector<nlohmann::json> read_jsonl(const fs::path& path) {
  std::vector<nlohmann::json> out;
  if (!fs::exists(path)) return out;
  const std::string text = read_file(path);
  const std::size_t end = text.rfind('\n');
  const std::size_t complete = end == std::string::npos ? 0 : end + 1;
  if (complete < text.size()) {  // a half-written last line: cut it off
    std::error_code ec;
    fs::resize_file(path, complete, ec);
    if (ec) throw Error(path.string(), "", "cannot drop the half-written last line: " + ec.message());
  }
  std::size_t pos = 0;
  int line = 0;
  while (pos < complete) {
    const std::size_t nl = text.find('\n', pos);
    ++line;
    const std::string_view s(text.data() + pos, nl - pos);
    pos = nl + 1;
    if (s.find_first_not_of(" \t\r") == std::string_view::npos) continue;
    nlohmann::json j = nlohmann::json::parse(s, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      throw Error(path.string(), "line " + std::to_string(line), "is not a JSON object (not a sweep file?)");
    out.push_back(std::move(j));
  }
  return out;
}

void append_jsonl(const fs::path& path, const nlohmann::json& j) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  const std::string line = j.dump() + "\n";
  const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(path.string(), "", std::string("cannot be opened for appending: ") + std::strerror(errno));
  std::size_t written = 0;
  while (written < line.size()) {
    const ssize_t n = ::write(fd, line.data() + written, line.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = errno;
      ::close(fd);
      throw Error(path.string(), "", std::string("write failed: ") + std::strerror(e));
    }
    written += std::size_t(n);
  }
  if (::fsync(fd) != 0) {
    const int e = errno;
    ::close(fd);
    throw Error(path.string(), "", std::string("fsync failed: ") + std::strerror(e));
  }
  ::close(fd);
}

namespace {

nlohmann::json run_identity(const forest::Forest& forest, const std::string& forest_file,
                            const std::vector<fs::path>& works, const EvalOptions& opt, char param) {
  using nlohmann::json;
  std::vector<std::string> w;
  for (const auto& p : works) w.push_back(p.string());
  const bool voting = opt.voting() || param == 'B';  // a B sweep votes with --votes and --vote
  json run = {{"forest", forest_file},
              {"forest_params", forest::params_to_json(forest.params)},
              {"forest_trees", forest.trees.size()},
              {"classes", forest.classes},
              {"features", forest.features},
              {"works", w},
              {"test_frames", opt.frames.str()},
              {"mode", opt.mode()},
              {"grid", opt.grid},
              {"superpixels", opt.superpixels},
              {"votes", voting ? json(opt.votes) : json(nullptr)},
              {"vote", voting ? json(to_string(opt.vote)) : json(nullptr)},
              {"trees", opt.trees},
              {"tolerance", opt.tolerance},
              {"costs", opt.costs_file},
              {"seed", opt.seed}};
  run[param == 'M' ? "trees" : param == 'B' ? "grid" : "votes"] = "swept";
  if (param == 'B') run["mode"] = "grid";
  return run;
}

}  // namespace

SweepReport run_sweep(const forest::Forest& forest, const std::string& forest_file, const std::vector<fs::path>& works,
                      const EvalOptions& opt, const SweepSpec& spec, const fs::path& jsonl,
                      const std::function<void(const nlohmann::json&)>& on_point) {
  opt.validate();
  const std::string option = "--sweep";
  if (spec.param == 'M' && spec.last > static_cast<int>(forest.trees.size()))
    throw Error("", option, spec.str() + " goes to " + std::to_string(spec.last) + " trees, the forest has " +
                                std::to_string(forest.trees.size()) + " (train the largest M once)");
  if (spec.param == 'B' && opt.superpixels > 0) throw Error("", option, "a B sweep is a grid sweep: drop --superpixels");
  if (spec.param == 'V' && !opt.voting()) throw Error("", option, "a V sweep needs --grid or --superpixels");

  const nlohmann::json run = run_identity(forest, forest_file, works, opt, spec.param);
  const std::string name(1, spec.param);
  std::vector<int> done;
  for (const auto& rec : read_jsonl(jsonl)) {
    if (!rec.contains("sweep") || !rec.contains("value") || !rec.contains("run"))
      throw Error(jsonl.string(), "sweep", "a line is not a sweep record");
    if (rec["sweep"] != name) continue;
    if (rec["run"] != run)
      throw Error(jsonl.string(), "run",
                  "holds " + name + " points of another run (other forest, frames or options); write to another -o");
    done.push_back(rec["value"].get<int>());
  }

  stacks::StackSet set = stacks::open_stacks(works, opt.frames, true, true, forest.features);
  stacks::lighten_frames(set, forest.params.lightness);
  check_forest_fits(forest, set);
  SweepReport report;
  for (int v : spec.values()) {
    if (std::find(done.begin(), done.end(), v) != done.end()) {
      ++report.done_before;
      continue;
    }
    EvalOptions o = opt;
    o.pictures.clear();
    o.progress = false;
    if (spec.param == 'M') o.trees = v;
    if (spec.param == 'B') o.grid = v;
    if (spec.param == 'V') o.votes = v;
    const EvalResult r = evaluate(forest, set, works, o);
    std::vector<std::string> w;
    for (const auto& p : works) w.push_back(p.string());
    const nlohmann::json full = r.to_json(forest, o, w);
    nlohmann::json rec = {{"format", "smseg-sweep-point"}, {"version", 1}, {"sweep", name}, {"value", v}, {"run", run}};
    for (const char* key : {"global_accuracy", "class_average_accuracy", "mean_iou", "boundary_tolerant_accuracy",
                            "mean_cost", "accuracy_spread", "seconds_per_frame", "superpixel_seconds_per_frame"})
      rec[key] = full[key];
    rec["frames"] = r.frames.size();
    rec["confusion"] = full["confusion"]["counts"];
    append_jsonl(jsonl, rec);
    ++report.run;
    if (on_point) on_point(rec);
  }
  return report;
}

}  // namespace smseg::eval
