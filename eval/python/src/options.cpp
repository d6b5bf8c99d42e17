// The options tables (smseg/common/options.hpp) as Python sees them: each declared field with its
// spelling on every surface and its default, for the test that every surface takes what its tables
// declare (tests/eval/python/test_option_surfaces.py) and for anyone who builds option lists.
#include <string>
#include <vector>

#include "bindings.hpp"
#include "smseg/common/options.hpp"
#include "smseg/eval/evaluate.hpp"
#include "smseg/eval/stream_output.hpp"
#include "smseg/forest/params.hpp"
#include "smseg/stacks/extract.hpp"
#include "smseg/synth/synth.hpp"

namespace smseg::python {

namespace {

nlohmann::json surfaces_json(unsigned surfaces) {
  nlohmann::json s = nlohmann::json::array();
  for (const auto& [bit, name] : std::vector<std::pair<options::Surface, const char*>>{
           {options::kCommandLine, "command_line"},
           {options::kFile, "file"},
           {options::kConfig, "config"},
           {options::kPython, "python"}})
    if (surfaces & bit) s.push_back(name);
  return s;
}

template <class S>
nlohmann::json table_json(const options::Table<S>& table) {
  nlohmann::json fields = nlohmann::json::array();
  const S defaults{};
  for (const auto& f : table.fields())
    fields.push_back({{"key", f.key},
                      {"flag", f.flag},
                      {"config_key", f.config_key},
                      {"python_key", f.python_key},
                      {"type", f.type},
                      {"help", f.help},
                      {"surfaces", surfaces_json(f.surfaces)},
                      {"default", f.write(defaults)}});
  return {{"name", table.name()}, {"fields", fields}};
}

py::object option_tables() {
  return to_python({{"training", table_json(forest::train_params_table())},
                    {"extract_features", table_json(stacks::extract_options_table())},
                    {"evaluate", table_json(eval::eval_options_table())},
                    {"label_stream", table_json(eval::label_stream_options_table())},
                    {"make_sequence", table_json(synth::synth_options_table())}});
}

}  // namespace

void bind_options(py::module_& m) {
  m.def("option_tables", &option_tables,
        "The declared options of training, extract_features, evaluate, label_stream (its own) and make_sequence: per field its key, command-line "
        "flag, config and Python spellings, type, help, surfaces and default.");
}

}  // namespace smseg::python
