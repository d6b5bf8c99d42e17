// Dataset validation, training parameters and their JSON form.
#include <algorithm>
#include <set>

#include "smseg/common/error.hpp"
#include "smseg/common/names.hpp"
#include "smseg/common/options.hpp"
#include "smseg/forest/data.hpp"
#include "smseg/forest/params.hpp"

namespace smseg::forest {

void validate_frame(const FrameData& frame, int width, int height, std::size_t num_features,
                    bool need_gray, const std::string& source, const std::string& field) {
  if (frame.width != width || frame.height != height)
    throw Error(source, field, "is " + std::to_string(frame.width) + "x" + std::to_string(frame.height) +
                                   ", expected " + std::to_string(width) + "x" + std::to_string(height));
  if (frame.sats.size() != num_features)
    throw Error(source, field + ".sats",
                "has " + std::to_string(frame.sats.size()) + " summed-area tables, expected " +
                    std::to_string(num_features) + " (one per feature)");
  for (std::size_t f = 0; f < frame.sats.size(); ++f)
    if (frame.sats[f] == nullptr) throw Error(source, field + ".sats[" + std::to_string(f) + "]", "is null");
  if (need_gray && frame.gray == nullptr)
    throw Error(source, field + ".gray", "is missing (texton tests need the greyscale image)");
}

void Dataset::validate(bool need_labels, bool need_gray, const std::string& source) const {
  if (width < 1 || height < 1)
    throw Error(source, "image size", "must be at least 1x1, got " + std::to_string(width) + "x" +
                                          std::to_string(height));
  if (width > 32000 || height > 32000) throw Error(source, "image size", "larger than 32000 pixels");
  if (classes.empty()) throw Error(source, "classes", "is empty");
  if (classes.size() > 255) throw Error(source, "classes", "more than 255 classes (255 is void)");
  if (std::set<std::string>(classes.begin(), classes.end()).size() != classes.size())
    throw Error(source, "classes", "contains a name twice");
  if (std::set<std::string>(features.begin(), features.end()).size() != features.size())
    throw Error(source, "features", "contains a name twice");
  if (features.empty() && !need_gray) throw Error(source, "features", "is empty");
  if (frames.empty()) throw Error(source, "frames", "no frames");
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::string field = "frames[" + std::to_string(i) + "]";
    validate_frame(frames[i], width, height, features.size(), need_gray, source, field);
    if (need_labels) {
      if (frames[i].labels == nullptr) throw Error(source, field + ".labels", "is missing");
      const std::uint8_t* l = frames[i].labels;
      const std::size_t n = static_cast<std::size_t>(width) * height;
      for (std::size_t p = 0; p < n; ++p)
        if (l[p] != kVoidLabel && l[p] >= classes.size())
          throw Error(source, field + ".labels",
                      "pixel (" + std::to_string(p % width) + ", " + std::to_string(p / width) +
                          ") has label " + std::to_string(l[p]) + ", but there are only " +
                          std::to_string(classes.size()) + " classes (255 = void)");
    }
  }
}

constexpr std::array<EnumName<Balance>, 3> kBalanceNames{
    {{Balance::None, "none"}, {Balance::Classes, "classes"}, {Balance::Sqrt, "sqrt"}}};
constexpr std::array<EnumName<Score>, 2> kScoreNames{
    {{Score::WehenkelPavella, "wehenkel-pavella"}, {Score::InformationGain, "information-gain"}}};

std::string to_string(Balance b) { return name_of(kBalanceNames, b); }
Balance balance_from_string(const std::string& s, const std::string& field) { return value_named(kBalanceNames, s, field); }
std::string to_string(Score s) { return name_of(kScoreNames, s); }
Score score_from_string(const std::string& s, const std::string& field) { return value_named(kScoreNames, s, field); }

void TrainParams::validate(const std::string& source) const {
  auto bad = [&](const char* field, const std::string& why) { throw Error(source, field, why); };
  if (K < 1) bad("K", "must be >= 1, got " + std::to_string(K));
  if (Ks < 0) bad("Ks", "must be >= 0 (0: K), got " + std::to_string(Ks));
  if (Kt < 0) bad("Kt", "must be >= 0 (0: K), got " + std::to_string(Kt));
  if (ks() > 1000000) bad("Ks", "must be <= 1000000");
  if (kt() > 100000000) bad("Kt", "must be <= 100000000");
  if (M < 1 || M > 100000) bad("M", "must be in [1, 100000], got " + std::to_string(M));
  if (n_min < 1) bad("n_min", "must be >= 1, got " + std::to_string(n_min));
  if (!(lightness == 0.0 || (lightness >= 0.05 && lightness <= 0.95)))
    bad("lightness", "must be 0 (off) or in [0.05, 0.95]");
  if (leaf_tests < 0 || leaf_tests > 100000000) bad("leaf_tests", "must be in [0, 100000000]");
  if (memory_mb < 1 || memory_mb > (std::size_t{1} << 30)) bad("memory_mb", "must be 1 .. 2^30 MiB (1 PiB)");
  if (score != Score::WehenkelPavella && score != Score::InformationGain)
    bad("score", "is not wehenkel-pavella or information-gain");
  try {
    windows.validate();
  } catch (const Error& e) {
    throw Error(source, e.field(), e.reason());
  }
}

nlohmann::json histograms_to_json(const WindowHistograms& h) {
  return {{"bounds",
           {{"max_dx", h.bounds.max_dx}, {"max_dy", h.bounds.max_dy}, {"max_w", h.bounds.max_w},
            {"max_h", h.bounds.max_h}}},
          {"dx", h.dx},
          {"dy", h.dy},
          {"w", h.w},
          {"h", h.h}};
}

WindowHistograms histograms_from_json(const JsonView& j) {
  const JsonView b = j.at("bounds");
  WindowBounds bounds;
  bounds.max_dx = static_cast<int>(b.integer("max_dx"));
  bounds.max_dy = static_cast<int>(b.integer("max_dy"));
  bounds.max_w = static_cast<int>(b.integer("max_w"));
  bounds.max_h = static_cast<int>(b.integer("max_h"));
  if (bounds.max_dx < 0 || bounds.max_dy < 0 || bounds.max_w < 1 || bounds.max_h < 1 ||
      bounds.max_dx > 100000 || bounds.max_dy > 100000 || bounds.max_w > 100000 || bounds.max_h > 100000)
    b.fail("window bounds out of range");
  WindowHistograms h = WindowHistograms::zeros(bounds);
  auto read = [&](const char* key, std::vector<double>& out) {
    const JsonView a = j.at(key);
    if (a.size() != out.size())
      a.fail("has " + std::to_string(a.size()) + " bins, expected " + std::to_string(out.size()));
    for (std::size_t i = 0; i < out.size(); ++i) {
      out[i] = a.at(i).as_num();
      if (!(out[i] >= 0.0)) a.at(i).fail("must be >= 0");
    }
  };
  read("dx", h.dx);
  read("dy", h.dy);
  read("w", h.w);
  read("h", h.h);
  return h;
}

const options::Table<TrainParams>& train_params_table() {
  using T = TrainParams;
  static const options::Table<T> table = [] {
    options::Table<T> t("training");
    // The ranges are validate()'s: a bad value is refused by the parser (bad usage) or the reader.
    t.number("K", "-K", "sets Ks = Kt (thesis 400)", [](auto& p) -> auto& { return p.K; }, 1, 100000000)
        .in_python_as("k");
    // Ks = Kt = 0 (the default) stand for K; a file or a config holds the value itself.
    t.number("Ks", "--Ks", "sampling windows per tree", [](auto& p) -> auto& { return p.Ks; }, 1, 1000000)
        .default_shown_as("K")
        .written_as([](const T& p) { return nlohmann::json(p.ks()); })
        .in_python_as("ks");
    t.number("Kt", "--Kt", "tests (training pixels) per tree", [](auto& p) -> auto& { return p.Kt; }, 1, 100000000)
        .default_shown_as("K")
        .written_as([](const T& p) { return nlohmann::json(p.kt()); })
        .in_python_as("kt");
    t.number("M", "-M", "number of trees", [](auto& p) -> auto& { return p.M; }, 1, 100000).in_python_as("n_estimators");
    t.number("n_min", "--n-min", "nodes with fewer tests become leaves", [](auto& p) -> auto& { return p.n_min; }, 1,
             100000000);
    t.number("seed", "--seed", "random seed (each tree derives its own from it)",
             [](auto& p) -> auto& { return p.seed; }, std::uint64_t{0},
             std::numeric_limits<std::uint64_t>::max());
    // Files record the whole window sampling (its shares and learned histograms), params_to_json.
    t.named("windows", "--windows", "window sampling (thesis 4.5.3)",
            [](auto& p) -> auto& { return p.windows.mode; }, "uniform | thesis-biased | learned",
            &window_sampling_from_string, +[](const WindowSampling& w) { return to_string(w); })
        .only(options::kCommandLine | options::kConfig | options::kPython);
    t.choice("balance", "--balance",
             "draw tests per class so no class swamps the rest (classes: each class equally often; sqrt: in "
             "proportion to the square root of its pixel count)",
             [](auto& p) -> auto& { return p.balance; }, kBalanceNames);
    t.flag("textons", "--textons", "add the texton tests fP, fPs, fPd, fPda on the greyscale image",
           [](auto& p) -> auto& { return p.textons; });
    t.number("lightness", "--lightness",
             "bring every frame to this mean lightness fL (L* / 100) by the exposure map of its Lab and gradient "
             "channels, in training and wherever the forest classifies (a dusk run then looks like a day run; "
             "needs fL; 0: off)",
             [](auto& p) -> auto& { return p.lightness; }, 0.0, 0.95)
        .recorded_unless([](const T& p) { return p.lightness == 0.0; });
    t.number("leaf_tests", "--leaf-tests",
             "after a tree has grown on its Kt tests, count this many more in its leaves (drawn as those are): "
             "the same splits, leaf distributions from Kt + N tests (0: from the Kt)",
             [](auto& p) -> auto& { return p.leaf_tests; }, 0, 100000000)
        .recorded_unless([](const T& p) { return p.leaf_tests == 0; });
    t.choice("score", "--score", "split score (wehenkel-pavella: the thesis)", [](auto& p) -> auto& { return p.score; },
             kScoreNames)
        .optional_in_files()  // files written before the option: the thesis's score
        .in_python_as("criterion");
    // Does not change the forest: not recorded; run-experiment sets it itself.
    t.number("memory_mb", "--memory-mb",
             "memory budget of training in MiB: trees are built in batches that fit; refused if one tree does not",
             [](auto& p) -> auto& { return p.memory_mb; }, std::size_t{1}, std::size_t{1} << 30)
        .only(options::kCommandLine);
    return t;
  }();
  return table;
}

nlohmann::json params_to_json(const TrainParams& p) {
  nlohmann::json j = train_params_table().to_json(p, options::kFile);
  nlohmann::json w = {{"mode", to_string(p.windows.mode)},
                      {"thesis_dy_share", p.windows.thesis_dy_share},
                      {"thesis_size_share", p.windows.thesis_size_share}};
  if (p.windows.mode == WindowSampling::Learned) w["learned"] = histograms_to_json(p.windows.learned);
  j["windows"] = w;
  return j;
}

TrainParams params_from_json(const JsonView& j) {
  TrainParams p;
  train_params_table().read(p, j, options::kFile);
  const JsonView w = j.at("windows");
  try {
    p.windows.mode = window_sampling_from_string(w.str("mode"), "mode");
  } catch (const Error& e) {
    w.fail(e.reason(), "mode");
  }
  p.windows.thesis_dy_share = w.num("thesis_dy_share");
  p.windows.thesis_size_share = w.num("thesis_size_share");
  if (p.windows.mode == WindowSampling::Learned) p.windows.learned = histograms_from_json(w.at("learned"));
  try {
    p.validate(j.file().string());
  } catch (const Error& e) {
    j.fail(e.reason(), e.field());
  }
  return p;
}

}  // namespace smseg::forest
