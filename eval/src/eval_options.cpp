// EvalOptions declared once (options.hpp): eval-forest's options, the keywords of Python's evaluate,
// run-experiment's evaluation keys. results.json records the evaluation as run (the mode, the trees
// used, the smoothing), EvalResult::to_json.
#include "smseg/common/options.hpp"
#include "smseg/eval/evaluate.hpp"

namespace smseg::eval {

namespace {

using O = EvalOptions;
using options::kCommandLine;
using options::kConfig;
using options::kPython;

void declare_voting(options::Table<O>& t) {
  t.number("grid", "--grid", "grid voting: cell size B in pixels (0: per pixel)", [](auto& o) -> auto& { return o.grid; },
           0, 10000)
      .checked_as("--grid");
  // Configs spell it as a name or a number; a point records it as its config spelt it (config.cpp).
  t.named("superpixels", "--superpixels",
          "superpixel voting: SLIC region size, small (" + std::to_string(kSmallSuperpixels) + " px), large (" +
              std::to_string(kLargeSuperpixels) + " px) or N px (4..1000); superpixel time is reported apart",
          [](auto& o) -> auto& { return o.superpixels; }, "none | small | large | N",
          +[](const std::string& s, const std::string& field) {
            return s == "none" ? 0 : superpixels_from_string(s, field);
          },
          +[](const int& n) { return n > 0 ? std::to_string(n) : std::string("none"); })
      .numbers_as_names()
      .checked_as("--superpixels");
  t.number("votes", "--votes", "V: random voting pixels per region (grid cell or superpixel)",
           [](auto& o) -> auto& { return o.votes; }, 1, 100000000)
      .checked_as("--votes");
  t.named("vote", "--vote", "how voters decide (sum of their distributions, or majority of their labels)",
          [](auto& o) -> auto& { return o.vote; }, "sum | majority", &vote_rule_from_string,
          +[](const VoteRule& v) { return to_string(v); });
  t.number("trees", "--trees", "use only the first m trees of the forest (0: all)", [](auto& o) -> auto& { return o.trees; },
           0, 100000)
      .checked_as("--trees");
  t.number("prior_power", "--prior-power",
           "class prior correction: each class's posterior divided by its training prior (the forest's leaf "
           "class frequencies) to this power: 0 none, 1 a flat prior; trades global accuracy for class average",
           [](auto& o) -> auto& { return o.prior_power; }, 0.0, 4.0)
      .checked_as("--prior-power")
      .recorded_unless_default();
  t.number("tolerance", "--tolerance",
           "T of the boundary-tolerant accuracy: a wrong pixel within T px (Euclidean) of a true region of its "
           "output class counts as a near miss; also the match distance of the boundary F1",
           [](auto& o) -> auto& { return o.tolerance; }, 0, 1000)
      .checked_as("--tolerance");
  t.number("seed", "--seed", "seed for where the voting pixels fall", [](auto& o) -> auto& { return o.seed; },
           std::uint64_t{0}, std::numeric_limits<std::uint64_t>::max())
      .in_configs_as("eval_seed");
}

// Smoothing: new in configs, so recorded in a point only when not the default (older points keep
// their identity).
void declare_smoothing(options::Table<O>& t) {
  const auto method = [](auto& o) -> auto& { return o.smooth.method; };
  t.named("smooth", "--smooth",
          "none, or graphcut: the per-pixel output smoothed by alpha-expansion over the class posteriors "
          "(unary -log p) with a contrast-sensitive Potts term on the greyscale image (per pixel only; its "
          "time is reported apart)",
          method, "none | graphcut", &smooth_method_from_string, +[](const SmoothMethod& m) { return to_string(m); })
      .recorded_unless_default()
      .checked_as("--smooth");
  const auto lambda = [](auto& o) -> auto& { return o.smooth.lambda; };
  t.number("lambda", "--lambda", "weight of the graph-cut smoothness term (0: per-pixel MAP)", lambda, 0.0, 1e6)
      .recorded_unless_default()
      .in_python_as("lambda_")
      .checked_as("--lambda");
  const auto connectivity = [](auto& o) -> auto& { return o.smooth.connectivity; };
  t.number("connectivity", "--connectivity", "graph-cut grid: 4 or 8 neighbours", connectivity, 4, 8)
      .recorded_unless_default()
      .checked_as("--connectivity");
  const auto cycles = [](auto& o) -> auto& { return o.smooth.cycles; };
  t.number("smooth_cycles", "--smooth-cycles", "at most this many alpha-expansion cycles (each tries every label once)",
           cycles, 1, 100)
      .recorded_unless_default()
      .checked_as("--smooth-cycles");
  const auto window = [](auto& o) -> auto& { return o.smooth.label_window; };
  t.number("smooth_window", "--smooth-window",
           "graph cut: a pixel may take only the labels that are the per-pixel MAP label somewhere within this "
           "many pixels of it; the pixels with one such label keep it and leave the graph (0: every label "
           "everywhere)",
           window, 0, 1000)
      .recorded_unless_default()
      .checked_as("--smooth-window");
  const auto bands = [](auto& o) -> auto& { return o.smooth.bands; };
  t.number("smooth_bands", "--smooth-bands",
           "graph cut with a label window: the frame's rows are cut into this many bands solved at once, then "
           "the seams between them (1: one energy over the whole frame); the labels depend on it, not on the "
           "thread count",
           bands, 1, 64)
      .recorded_unless_default()
      .checked_as("--smooth-bands");
  const auto contrast = [](auto& o) -> auto& { return o.smooth.contrast; };
  t.named("smooth_contrast", "--smooth-contrast",
          "graph cut: on (the Potts weight falls with the greyscale image's contrast across an edge) or off "
          "(plain Potts: the smoothing reads nothing of the image, for structure-and-motion-only runs)",
          contrast, "on | off",
          +[](const std::string& s, const std::string& field) {
            if (s != "on" && s != "off") throw Error("", field, "is \"" + s + "\", expected on or off");
            return s == "on";
          },
          +[](const bool& on) { return std::string(on ? "on" : "off"); })
      .recorded_unless_default();
}

}  // namespace

const options::Table<EvalOptions>& eval_options_table() {
  // results.json records the evaluation as run, not these options (EvalResult::to_json).
  static const options::Table<O> table = [] {
    options::Table<O> t("evaluate", kCommandLine | kConfig | kPython);
    declare_voting(t);
    declare_smoothing(t);
    return t;
  }();
  return table;
}

}  // namespace smseg::eval
