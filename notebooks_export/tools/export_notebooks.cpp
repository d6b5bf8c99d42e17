// export-notebooks: run-experiment results -> one Jupyter notebook per experiment that loads its JSON
// Lines and draws its figures, the figures also as PNG, and an index page linking them.
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <signal.h>
#include <unistd.h>

#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/io.hpp"
#include "smseg_plots_py.hpp"

namespace {

using smseg::Error;
using smseg::Json;
namespace fs = std::filesystem;

struct ExperimentResults {
  fs::path dir, jsonl;
  std::string name, title, description, config_file;
  bool quick = false;
  Json figures = Json::array();
  std::vector<Json> records;
};

/// The complete lines of experiment.jsonl (read only: a half-written last line is ignored, not cut).
std::vector<Json> read_records(const fs::path& path) {
  const std::string text = smseg::read_file(path);
  std::vector<Json> out;
  std::size_t pos = 0;
  int line = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) break;  // unfinished last line
    ++line;
    const std::string_view s(text.data() + pos, nl - pos);
    pos = nl + 1;
    if (s.find_first_not_of(" \t\r") == std::string_view::npos) continue;
    Json j = Json::parse(s, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("point"))
      throw Error(path.string(), "line " + std::to_string(line), "is not a run-experiment record");
    out.push_back(std::move(j));
  }
  return out;
}

ExperimentResults load_results(const fs::path& dir) {
  ExperimentResults r;
  r.dir = dir;
  const fs::path cfg = dir / "config.json";
  const Json j = smseg::read_json(cfg);
  const smseg::JsonView v(j, cfg);
  smseg::check_format(v, "smseg-experiment-run", {1});
  r.name = v.str("name");
  r.quick = v.boolean("quick");
  r.config_file = v.has("config_file") ? v.str("config_file") : "";
  const smseg::JsonView c = v.at("config");
  r.title = c.has("title") ? c.str("title") : r.name;
  r.description = c.has("description") ? c.str("description") : "";
  if (auto f = c.maybe("figures")) {
    if (!f->json().is_array()) f->fail("expected a list of figures");
    for (std::size_t i = 0; i < f->size(); ++i) {
      const smseg::JsonView fig = f->at(i);
      const std::string id = fig.str("id");
      if (id.empty() || id.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789._-") != std::string::npos)
        fig.fail("must be a name of a-z, 0-9, '.', '-', '_'", "id");
      r.figures.push_back(fig.json());
    }
  }
  r.jsonl = dir / "experiment.jsonl";
  if (fs::exists(r.jsonl)) r.records = read_records(r.jsonl);
  return r;
}

Json source_lines(const std::string& text) {
  Json lines = Json::array();
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) {
      lines.push_back(text.substr(pos));
      break;
    }
    lines.push_back(text.substr(pos, nl - pos + 1));
    pos = nl + 1;
  }
  return lines;
}

Json markdown(const std::string& text) {
  return {{"cell_type", "markdown"}, {"metadata", Json::object()}, {"source", source_lines(text)}};
}
Json code(const std::string& text) {
  return {{"cell_type", "code"},
          {"execution_count", nullptr},
          {"metadata", Json::object()},
          {"outputs", Json::array()},
          {"source", source_lines(text)}};
}

std::string py_string(const std::string& s) { return Json(s).dump(); }  // a JSON string is a Python literal

std::string png_name(const Json& fig) { return "fig-" + fig.at("id").get<std::string>() + ".png"; }

std::string figure_code(const ExperimentResults& r, const Json& fig) {
  return "spec = json.loads(" + py_string(fig.dump()) + ")\nfig = plot_figure(records, spec, " +
         py_string(r.name + "/" + png_name(fig)) + ")\n";
}

std::string load_code(const ExperimentResults& r, const fs::path& rel_jsonl) {
  return "import os\n"
         "os.makedirs(" + py_string(r.name) + ", exist_ok=True)\n"
         "records = load_records(" + py_string(rel_jsonl.generic_string()) + ")\n"
         "print(len(records), \"points\")\n"
         "for r in records[:60]:\n"
         "    swept = \", \".join(\"%s=%s\" % (k, key_text(value(r, k))) for k in r.get(\"swept\", []) if k != \"label\")\n"
         "    label = (r.get(\"label\") + \" \") if r.get(\"label\") else \"\"\n"
         "    g, c = r.get(\"global_accuracy\"), r.get(\"class_average_accuracy\")\n"
         "    print(\"%s%s: global %s, class-average %s, train %.2f s, %.1f ms per frame\" % (label, swept,\n"
         "          \"n/a\" if g is None else \"%.1f%%\" % (100 * g), \"n/a\" if c is None else \"%.1f%%\" % (100 * c),\n"
         "          r[\"train_seconds\"], 1000 * r[\"seconds_per_frame\"]))\n";
}

Json notebook(const ExperimentResults& r, const fs::path& rel_jsonl, const std::string& regenerate) {
  Json cells = Json::array();
  std::string intro = "# " + r.title + "\n\n";
  if (!r.description.empty()) intro += r.description + "\n\n";
  intro += "Results: `" + rel_jsonl.generic_string() + "` (" + std::to_string(r.records.size()) + " points" +
           (r.quick ? ", quick form" : "") + "). Regenerate:\n\n```sh\n" + regenerate + "\n```\n";
  cells.push_back(markdown(intro));
  cells.push_back(code(std::string("# The plotting helper (notebooks_export/smseg_plots.py).\n") + kSmsegPlotsPy));
  cells.push_back(code(load_code(r, rel_jsonl)));
  for (const auto& fig : r.figures) {
    cells.push_back(markdown("## Figure " + fig.at("id").get<std::string>() + ": " + fig.value("title", std::string()) +
                             "\n\nPNG: `" + r.name + "/" + png_name(fig) + "`"));
    cells.push_back(code(figure_code(r, fig)));
  }
  return {{"cells", cells},
          {"metadata",
           {{"kernelspec", {{"display_name", "Python 3"}, {"language", "python"}, {"name", "python3"}}},
            {"language_info", {{"name", "python"}}}}},
          {"nbformat", 4},
          {"nbformat_minor", 4}};
}

/// Runs `python script` in `dir` with the Agg backend and its output in `log`; its exit status (-1
/// when it could not start or was killed). No shell: the child is the interpreter itself, and it is
/// killed when this process dies (PR_SET_PDEATHSIG), so a killed export never leaves a Python still
/// drawing into its staging folder while the next run cleans it away.
int run_python(const std::string& python, const fs::path& dir, const fs::path& script, const fs::path& log) {
  // Everything that allocates is done before fork: only async-signal-safe calls in the child.
  const pid_t parent = ::getpid();
  const std::string name = script.filename().string();
  char* argv[] = {const_cast<char*>(python.c_str()), const_cast<char*>(name.c_str()), nullptr};
  ::setenv("MPLBACKEND", "Agg", 1);  // inherited by the child; the tool itself draws nothing
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);  // the parent died before the line above
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0 || ::chdir(dir.c_str()) != 0) ::_exit(127);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execvp(argv[0], argv);
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// The last non-empty line of a log (a Python traceback's exception), "" when there is none.
std::string last_line_of(const fs::path& log) {
  std::error_code ec;
  std::istringstream in(fs::exists(log, ec) ? smseg::read_file(log) : "");
  std::string last;
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) last = line;
  return last;
}

/// What went wrong when the drawing did not leave every figure: said as it is, not guessed.
std::string drawing_failure(const std::string& python, int status, const std::string& err, const std::string& missing) {
  if (status == 127 && err.empty()) return python + " could not be run (not found, or not executable)";
  if (status < 0) return python + " was killed";
  if (status != 0) {
    const bool no_matplotlib = err.find("No module named 'matplotlib'") != std::string::npos;
    return python + " failed (exit " + std::to_string(status) + ")" + (err.empty() ? "" : ": " + err) +
           (no_matplotlib ? " (install python3-matplotlib, or pass --no-png)" : "");
  }
  return python + " exited 0 without drawing " + missing + " (is it a Python 3 with matplotlib? --no-png skips the figures)";
}

/// Runs the notebook's code (helper, loading, every figure) as a plain script in `dir` to write the PNGs;
/// Error unless it exits 0 and every figure's PNG is there.
void render_pngs(const ExperimentResults& r, const fs::path& rel_jsonl, const fs::path& out, const std::string& python) {
  std::string script = std::string(kSmsegPlotsPy) + "\n" + load_code(r, rel_jsonl) + "\n";
  for (const auto& fig : r.figures) script += figure_code(r, fig) + "plt.close(\"all\")\n";
  const fs::path tmp = out / (".render-" + r.name + "-" + std::to_string(::getpid()) + ".py");
  const fs::path log = out / (".render-" + r.name + "-" + std::to_string(::getpid()) + ".log");
  smseg::write_file_atomic(tmp, script);
  const int status = run_python(python, out, tmp, log);
  const std::string err = status != 0 ? last_line_of(log) : "";
  std::error_code ec;
  fs::remove(tmp, ec);
  fs::remove(log, ec);
  std::string missing;
  for (const auto& fig : r.figures)
    if (missing.empty() && !fs::exists(out / r.name / png_name(fig), ec)) missing = r.name + "/" + png_name(fig);
  if (status != 0 || !missing.empty())
    throw Error((out / (r.name + ".ipynb")).string(), "figures", "drawing them: " + drawing_failure(python, status, err, missing));
}

std::string html_escape(const std::string& s) {
  std::string o;
  for (char c : s) o += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : c == '"' ? "&quot;" : std::string(1, c);
  return o;
}

/// The results folders to export: RESULTS itself when it holds config.json, else its folders that do
/// (sorted). Error when there are none.
std::vector<fs::path> results_folders(const std::string& results) {
  const fs::path root(results);
  if (!fs::is_directory(root)) throw Error(results, "", "is not a folder");
  std::vector<fs::path> dirs;
  if (fs::exists(root / "config.json")) {
    dirs.push_back(root);
  } else {
    for (const auto& e : fs::directory_iterator(root))
      if (e.is_directory() && fs::exists(e.path() / "config.json")) dirs.push_back(e.path());
    std::sort(dirs.begin(), dirs.end());
  }
  if (dirs.empty()) throw Error(results, "", "holds no run-experiment results (no config.json in it or its folders)");
  return dirs;
}

/// The index pages, Markdown and HTML, built an experiment at a time.
struct IndexPages {
  std::string md, html;

  IndexPages(const std::string& results, const std::string& out) {
    md = "# Experiment notebooks\n\nMade by `export-notebooks " + results + " -o " + out +
         "` from run-experiment results. Each notebook loads its experiment's JSON Lines and draws its "
         "figures; run one with `jupyter nbconvert --to notebook --execute NAME.ipynb`.\n\n"
         "| experiment | points | notebook | figures |\n|---|---|---|---|\n";
    html = "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>Experiment notebooks</title></head><body>\n"
           "<h1>Experiment notebooks</h1>\n";
  }

  /// One experiment: a table row in Markdown, a heading and its figures' thumbnails in HTML.
  void add(const ExperimentResults& r) {
    std::string figs, figs_html;
    for (const auto& fig : r.figures) {
      const std::string id = fig.at("id").get<std::string>(), png = r.name + "/" + png_name(fig);
      figs += (figs.empty() ? "" : ", ") + std::string("[") + id + "](" + png + ")";
      figs_html += "<figure style=\"display:inline-block;margin:4px\"><a href=\"" + png + "\"><img src=\"" + png +
                   "\" width=\"320\" alt=\"Figure " + html_escape(id) + "\"></a><figcaption>Figure " +
                   html_escape(id) + ": " + html_escape(fig.value("title", std::string())) + "</figcaption></figure>\n";
    }
    md += "| " + r.title + (r.quick ? " (quick)" : "") + " | " + std::to_string(r.records.size()) + " | [" + r.name +
          ".ipynb](" + r.name + ".ipynb) | " + figs + " |\n";
    html += "<h2>" + html_escape(r.title) + (r.quick ? " (quick)" : "") + "</h2>\n<p>" +
            std::to_string(r.records.size()) + " points; notebook <a href=\"" + r.name + ".ipynb\">" + r.name +
            ".ipynb</a></p>\n" + figs_html;
  }
};

}  // namespace

int main(int argc, char** argv) {
  using namespace smseg;
  CLI::App app{
      "Turn run-experiment results into Jupyter notebooks: for each results folder (config.json +\n"
      "experiment.jsonl) found in RESULTS (or RESULTS itself), OUT/NAME.ipynb loads the JSON Lines and draws\n"
      "the figures its config lists (titled and labelled like the thesis figures), and OUT/NAME/fig-ID.png\n"
      "holds each figure as PNG (drawn by running the notebook's code with python3-matplotlib).\n"
      "OUT/index.md and OUT/index.html link them all. Notebooks run with\n"
      "`jupyter nbconvert --to notebook --execute OUT/NAME.ipynb`. OUT is rebuilt beside itself and swapped\n"
      "in whole at the end: a killed or failed export leaves it as it was (files in OUT that this export\n"
      "does not write are kept).",
      "export-notebooks"};
  std::string results, out, python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  bool no_png = false, quiet = false;
  app.add_option("RESULTS", results, "a folder of results folders (each from run-experiment -o), or one of them")->required();
  app.add_option("-o,--out", out, "folder for the notebooks, PNGs and index")->required();
  app.add_option("--python", python, "Python interpreter that draws the PNGs (Debian's, where python3-matplotlib is)")->capture_default_str();
  app.add_flag("--no-png", no_png, "write the notebooks and index only");
  app.add_flag("-q,--quiet", quiet, "no line per experiment");
  return run_tool(app, argc, argv, [&] {
    const smseg::OutputLock one_writer(out, {results});
    const std::vector<fs::path> dirs = results_folders(results);
    const fs::path out_dir = fs::absolute(out).lexically_normal();
    // Everything is written into a folder beside OUT and swapped in whole at the end: a killed or failed
    // export leaves OUT as it was, never notebooks of this run beside an index of the last one.
    FolderReplacement replacement(out_dir);
    const fs::path staging = replacement.staging();
    IndexPages index(results, out);
    std::vector<std::string> names;
    for (const auto& dir : dirs) {
      const ExperimentResults r = load_results(dir);
      if (std::find(names.begin(), names.end(), r.name) != names.end())
        throw Error((dir / "config.json").string(), "name", "another results folder has the experiment name \"" + r.name + "\"");
      names.push_back(r.name);
      const fs::path rel_jsonl = fs::relative(fs::absolute(r.jsonl), out_dir);
      std::string regenerate = "run-experiment " + (r.config_file.empty() ? std::string("CONFIG") : r.config_file) +
                               (r.quick ? " --quick" : "") + " -o " + dir.string() + "\nexport-notebooks " + results +
                               " -o " + out;
      write_json_atomic(staging / (r.name + ".ipynb"), notebook(r, rel_jsonl, regenerate), 1);
      fs::create_directories(staging / r.name);
      // The notebook names the JSON Lines from OUT; the drawing runs in the staging folder beside it.
      if (!no_png && !r.figures.empty())
        render_pngs(r, fs::relative(fs::absolute(r.jsonl), staging), staging, python);
      index.add(r);
      if (!quiet)
        std::cout << r.name << ": " << r.records.size() << " points, " << r.figures.size() << " figures -> "
                  << (out_dir / (r.name + ".ipynb")).string() << "\n";
    }
    index.html += "</body></html>\n";
    write_file_atomic(staging / "index.md", index.md);
    write_file_atomic(staging / "index.html", index.html);
    replacement.commit();
    if (!quiet) std::cout << "index: " << (out_dir / "index.html").string() << "\n";
    return 0;
  });
}
