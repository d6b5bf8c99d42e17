// Fuzzes the command lines made from the option tables (options::Table::add_to): the training options
// of train-forest, the extraction options of extract-features and label-stream, the evaluation options of
// eval-forest and label-stream, the scene options of make-sequence. The input picks options from each
// table's own declarations and gives them values (edge numbers from a list, or raw bytes); the parser
// and then the library's resolve()/validate() must either accept or refuse them as documented
// (CLI::ParseError: a usage error; smseg::Error). An accepted command line must record only finite
// numbers (the file surface, Table::to_json) and only text JSON can carry. Anything else is a finding.
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "fuzz_support.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/options.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/forest/params.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/synth/synth.hpp"

namespace {

using namespace smseg;

/// Values that have broken parsers before: out of range, overflowing, non-finite, not numbers at all.
const std::vector<std::string> kEdgeValues = {
    "0", "-0", "1", "-1", "2", "15", "16", "17", "255", "256", "65535", "100000", "100001", "1e308", "-1e308",
    "1e999", "1e-320", "nan", "-nan", "inf", "-inf", "NaN", "Infinity", "0x10", "010", "1.5", "0.999999", "1e6",
    "2147483647", "2147483648", "-2147483649", "18446744073709551615", "18446744073709551616", "", " ", "a",
    "4294967296", "9223372036854775808", "1:2", "5:2", "0:", "auto", "sift", "klt", "sum", "tabletop"};

/// The byte reader over the fuzzer's input.
struct Bytes {
  const std::uint8_t* data;
  std::size_t size, at = 0;
  bool empty() const { return at >= size; }
  std::uint8_t next() { return at < size ? data[at++] : 0; }
  std::string text(std::size_t n) {
    std::string s;
    while (n-- && !empty()) s += static_cast<char>(next());
    return s;
  }
};

/// Every number in j is finite (an accepted value that a file would record as null is a finding).
void require_finite(const nlohmann::json& j) {
  if (j.is_number_float() && !std::isfinite(j.get<double>())) std::abort();
  if (j.is_structured())
    for (const auto& item : j) require_finite(item);
}

/// Builds argv from the input over `table`'s command-line fields, parses it into a fresh S, runs
/// `check` (the library's resolve/validate), and requires what was accepted to record cleanly.
template <class S, class Check>
void run_table(const options::Table<S>& table, Bytes& in, Check&& check) {
  std::vector<const options::Field<S>*> fields;
  for (const auto& f : table.fields())
    if (f.on(options::kCommandLine) && !f.flag.empty()) fields.push_back(&f);
  if (fields.empty()) return;
  std::vector<std::string> argv;
  for (int n = in.next() % 6; n >= 0 && !in.empty(); --n) {
    const options::Field<S>& f = *fields[in.next() % fields.size()];
    argv.push_back(f.flag);
    if (f.type == "flag") continue;
    const std::uint8_t v = in.next();
    argv.push_back(v < 0xc0 ? kEdgeValues[v % kEdgeValues.size()] : in.text(v & 0x1f));
  }
  S s;
  CLI::App app("fuzz", "fuzz");
  table.add_to(app, s);
  std::vector<std::string> reversed(argv.rbegin(), argv.rend());  // CLI11 takes them last first
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError&) {
    return;  // a usage error, as documented (exit status 2)
  }
  fuzz::run_reader([&] {
    check(s);
    const nlohmann::json recorded = table.to_json(s, options::kFile);
    require_finite(recorded);
    json_text(recorded, "fuzz");  // text JSON cannot carry is refused with smseg::Error, never thrown raw
  });
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in{data, size};
  switch (in.next() % 4) {
    case 0:
      run_table(forest::train_params_table(), in, [](const forest::TrainParams& p) { p.validate(); });
      break;
    case 1:
      run_table(stacks::extract_options_table(), in, [](stacks::ExtractOptions& o) {
        o.resolve();
        o.validate();
      });
      break;
    case 2:
      run_table(eval::eval_options_table(), in, [](const eval::EvalOptions& o) { o.validate(); });
      break;
    default:
      run_table(synth::synth_options_table(), in, [](const synth::SynthOptions& o) { o.validate(); });
  }
  return 0;
}
