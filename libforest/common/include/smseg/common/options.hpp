#pragma once
// Options said once. Each options struct declares each of its fields once, in its own module, in an
// options::Table: the key (files, experiment configs, Python keywords), the command-line spelling, a
// one-line help, the allowed range or names, where it is offered. Every surface is made from that one
// declaration, as LightGBM's config.h generates its parsers and COLMAP's OptionManager registers an
// option group once for every command:
//   - the command line: Table::add_to(app, options) gives CLI11 options writing into the struct, with
//     their checks (range, finite numbers, names) as parse errors (exit status 2);
//   - files and configs: Table::to_json / Table::read, errors naming the file and the key;
//   - Python: the bindings turn keyword arguments into JSON and read them with the same Table::read;
//   - errors of a library's validate() renamed to what the user typed: Table::option_names().
// A test (tests/architecture/option_surfaces) walks every declared field and checks each surface it is
// declared on takes it, so a new option cannot be forgotten on one of them.
//
//   static const options::Table<TrainParams> t = options::Table<TrainParams>("training")
//       .number("M", "-M", "number of trees", [](auto& p) -> auto& { return p.M; }, 1, 100000)
//       .choice("balance", "--balance", "...", [](auto& p) -> auto& { return p.balance; }, kBalanceNames);
//
// A field's access is a generic lambda, called with the struct (the command line and the readers
// write through it) and with a const struct (the writers read through it).

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "smseg/common/cli.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/io.hpp"
#include "smseg/common/names.hpp"

namespace smseg::options {

/// Where a field is offered (a bit set).
enum Surface : unsigned {
  kCommandLine = 1u,  ///< the tools that take the struct
  kFile = 2u,         ///< the files that record it (forest.json's params, stacks.json, results.json)
  kConfig = 4u,       ///< run-experiment configs
  kPython = 8u,       ///< keyword arguments of the Python functions that take the struct
  kEverywhere = 15u
};

/// "a | b | c" for help texts.
template <class E, std::size_t N>
std::string choices_text(const std::array<EnumName<E>, N>& table) {
  std::string s;
  for (const auto& e : table) s += (s.empty() ? "" : " | ") + std::string(e.name);
  return s;
}

/// The name of a text field as it is written: Table::named's name function for a field that holds the
/// name itself (a front end's, a scene's), which its parse function checks.
inline std::string as_written(const std::string& name) { return name; }

/// One declared field of the options struct S.
template <class S>
struct Field {
  std::string key;         ///< files (and configs and Python unless they spell it otherwise)
  std::string config_key;  ///< run-experiment configs ("eval_seed" where the key "seed" is taken)
  std::string python_key;  ///< Python keywords and estimator parameters ("n_estimators" for M)
  std::string flag;        ///< command line ("--max-keypoints", "-K"); empty: not on the command line
  std::string help;        ///< one line (or a few), without the default: the surfaces add it
  std::string type;        ///< "integer", "number", "flag", "name", "text": for the surface test and docs
  unsigned surfaces = kEverywhere;
  std::string default_text;  ///< the default as help shows it, when not the value itself ("K")
  std::vector<std::string> library_names;  ///< how the libraries' validate() name it ("stereo.block_size")
  bool required_in_files = true;  ///< false: a file without it reads as the default (added later)
  /// Left out of files and of experiment records (a point's parameters) when true: a value whose
  /// absence older records mean, so that what they record stays the same for the values they could
  /// already hold (their work folders still resume, their points keep their identity).
  std::function<bool(const S&)> omitted_from_records;
  std::function<CLI::Option*(CLI::App&, S&)> add_option;
  std::function<nlohmann::json(const S&)> write;
  std::function<void(S&, const JsonView&)> read;  ///< the value's view; an Error names its place

  bool on(Surface s) const { return (surfaces & s) != 0; }
};

namespace detail {

template <class T>
std::string number_text(T v) {
  std::ostringstream s;
  s << std::setprecision(15) << v;  // exact for every bound we declare (1073741824, not 1.07374e+09)
  return s.str();
}

template <class T>
std::string range_text(T lo, T hi) {
  return "must be in [" + number_text(lo) + ", " + number_text(hi) + "]";
}

/// A number from a file or a config: whole numbers for integer fields, finite ones always, in range.
template <class T>
T read_number(const JsonView& v, T lo, T hi) {
  const nlohmann::json& j = v.json();
  if constexpr (std::is_integral_v<T>) {
    if (!j.is_number_integer()) v.fail("expected a whole number, found " + j.dump());
    if constexpr (std::is_unsigned_v<T>) {
      if (j.is_number_unsigned()) {
        const auto x = j.get<std::uint64_t>();
        if (x < static_cast<std::uint64_t>(lo) || x > static_cast<std::uint64_t>(hi))
          v.fail(range_text(lo, hi) + ", got " + j.dump());
        return static_cast<T>(x);
      }
      v.fail(range_text(lo, hi) + ", got " + j.dump());
    } else {
      const auto x = j.get<std::int64_t>();
      if (x < static_cast<std::int64_t>(lo) || x > static_cast<std::int64_t>(hi))
        v.fail(range_text(lo, hi) + ", got " + j.dump());
      return static_cast<T>(x);
    }
  } else {
    if (!j.is_number()) v.fail("expected a number, found " + j.dump());
    const double x = j.get<double>();
    if (!std::isfinite(x)) v.fail("must be a finite number");
    if (x < lo || x > hi) v.fail(range_text(lo, hi) + ", got " + j.dump());
    return static_cast<T>(x);
  }
}

/// `text` read whole as T: a whole number within T's own range for integer T (CLI11's own cast lets
/// 2^64 wrap into a uint64_t), any number for floating-point T.
template <class T>
bool parse_number(const std::string& text, T& x) {
  if constexpr (std::is_integral_v<T>) {
    const char* end = text.data() + text.size();
    const auto r = std::from_chars(text.data(), end, x);
    return r.ec == std::errc() && r.ptr == end;
  } else {
    return CLI::detail::lexical_cast(text, x);
  }
}

/// The command line's check of a number: CLI11's Range lets NaN through (every comparison is false).
template <class T>
CLI::Validator number_check(T lo, T hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) -> std::string {
        T x{};
        if (!parse_number(text, x))
          return std::string(std::is_integral_v<T> ? "expected a whole number" : "expected a number") + " in [" +
                 number_text(lo) + ", " + number_text(hi) + "], got '" + text + "'";
        if constexpr (std::is_floating_point_v<T>)
          if (!std::isfinite(x)) return "must be a finite number, got '" + text + "'";
        if (x < lo || x > hi) return range_text(lo, hi) + ", got " + text;
        return std::string();
      },
      "[" + number_text(lo) + " - " + number_text(hi) + "]");
}

}  // namespace detail

/// The check of a numeric option declared outside a Table (a tool's own options): a whole number for
/// integer T, finite, in [lo, hi]; --help shows "[lo - hi]". Use it instead of CLI::Range, which lets
/// NaN and wrapped integers through.
template <class T>
CLI::Validator in_range(T lo, T hi) {
  return detail::number_check(lo, hi);
}

/// A seed option's range outside a Table: every uint64_t (pair it with kDecimalDigits, which refuses
/// "-1" and octal).
inline CLI::Validator any_seed() {
  return in_range<std::uint64_t>(0, std::numeric_limits<std::uint64_t>::max());
}

/// The declarations of one options struct, and the surfaces made from them.
template <class S>
class Table {
 public:

  /// `surfaces`: where its fields are offered unless a declaration says otherwise (only()).
  explicit Table(std::string name, unsigned surfaces = kEverywhere) : name_(std::move(name)), surfaces_(surfaces) {}

  const std::string& name() const { return name_; }
  const std::vector<Field<S>>& fields() const { return fields_; }

  /// A number in [lo, hi] (whole for integer types; finite always).
  template <class T, class Access>
  Table& number(std::string key, std::string flag, std::string help, Access access, T lo, T hi) {
    check_access<T>(access);
    Field<S> f = base(std::move(key), std::move(flag), std::move(help), std::is_integral_v<T> ? "integer" : "number");
    f.add_option = [flag = f.flag, help = f.help, access, lo, hi](CLI::App& app, S& s) {
      T& target = access(s);
      CLI::Option* o = app.add_option(flag, target, help)->capture_default_str();
      if constexpr (std::is_unsigned_v<T>)  // not "-1" as 2^64-1, not "010" as octal
        o->check(CLI::Validator(kDecimalDigits).description(""));
      return o->check(detail::number_check(lo, hi));
    };
    f.write = [access](const S& s) { return nlohmann::json(access(s)); };
    f.read = [access, lo, hi](S& s, const JsonView& v) { access(s) = detail::read_number(v, lo, hi); };
    return add(std::move(f));
  }

  /// A number that may be left unset (the library then decides: the sequence's camera height, ...).
  template <class T, class Access>
  Table& optional_number(std::string key, std::string flag, std::string help, Access access, T lo, T hi) {
    check_access<std::optional<T>>(access);
    Field<S> f = base(std::move(key), std::move(flag), std::move(help), std::is_integral_v<T> ? "integer" : "number");
    f.add_option = [flag = f.flag, help = f.help, access, lo, hi](CLI::App& app, S& s) {
      std::optional<T>* target = &access(s);
      return app.add_option_function<T>(flag, [target](const T& v) { *target = v; }, help)
          ->check(detail::number_check(lo, hi));
    };
    f.write = [access](const S& s) {
      const auto& v = access(s);
      return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
    };
    f.read = [access, lo, hi](S& s, const JsonView& v) {
      if (v.json().is_null()) access(s).reset();
      else access(s) = detail::read_number(v, lo, hi);
    };
    f.required_in_files = false;
    return add(std::move(f));
  }

  /// A yes/no: a flag on the command line, true or false elsewhere.
  template <class Access>
  Table& flag(std::string key, std::string flag, std::string help, Access access) {
    check_access<bool>(access);
    Field<S> f = base(std::move(key), std::move(flag), std::move(help), "flag");
    f.add_option = [flag = f.flag, help = f.help, access](CLI::App& app, S& s) {
      return app.add_flag(flag, access(s), help);
    };
    f.write = [access](const S& s) { return nlohmann::json(access(s)); };
    f.read = [access](S& s, const JsonView& v) {
      if (!v.json().is_boolean()) v.fail("expected true or false, found " + v.json().dump());
      access(s) = v.json().get<bool>();
    };
    return add(std::move(f));
  }

  /// Free text the tool checks itself (a frame range, a source, a file name).
  template <class Access>
  Table& text(std::string key, std::string flag, std::string help, Access access) {
    check_access<std::string>(access);
    Field<S> f = base(std::move(key), std::move(flag), std::move(help), "text");
    f.add_option = [flag = f.flag, help = f.help, access](CLI::App& app, S& s) {
      return app.add_option(flag, access(s), help)->capture_default_str();
    };
    f.write = [access](const S& s) { return nlohmann::json(access(s)); };
    f.read = [access](S& s, const JsonView& v) {
      if (!v.json().is_string()) v.fail("expected a text, found " + v.json().dump());
      access(s) = v.json().get<std::string>();
    };
    return add(std::move(f));
  }

  /// One of an enum's names (its table in names.hpp).
  template <class E, std::size_t N, class Access>
  Table& choice(std::string key, std::string flag, std::string help, Access access,
                const std::array<EnumName<E>, N>& names) {
    check_access<E>(access);
    Field<S> f = base(std::move(key), std::move(flag), std::move(help) + ": " + choices_text(names), "name");
    f.add_option = [flag = f.flag, help = f.help, access, &names](CLI::App& app, S& s) {
      E* target = &access(s);
      return app
          .add_option_function<std::string>(
              flag, [target, &names, flag](const std::string& v) { *target = as_usage_value(names, v, flag); }, help)
          ->default_str(name_of(names, access(s)));
    };
    f.write = [access, &names](const S& s) { return nlohmann::json(name_of(names, access(s))); };
    f.read = [access, &names](S& s, const JsonView& v) {
      if (!v.json().is_string()) v.fail("expected a name (" + name_choices(names) + "), found " + v.json().dump());
      try {
        access(s) = value_named(names, v.json().get<std::string>(), "");
      } catch (const Error& e) {
        v.fail(e.reason());
      }
    };
    return add(std::move(f));
  }

  /// One of a set of names that a library checks itself (parse throws Error naming its field).
  template <class T, class Access>
  Table& named(std::string key, std::string flag, std::string help, Access access, std::string choices,
               T (*parse)(const std::string&, const std::string&), std::string (*name)(const T&)) {
    check_access<T>(access);
    Field<S> f = base(std::move(key), std::move(flag), std::move(help) + ": " + choices, "name");
    f.add_option = [flag = f.flag, help = f.help, access, parse, name](CLI::App& app, S& s) {
      T* target = &access(s);
      return app
          .add_option_function<std::string>(
              flag,
              [target, parse, flag](const std::string& v) {
                try {
                  *target = parse(v, flag);
                } catch (const Error& e) {
                  throw CLI::ValidationError(flag, e.reason());
                }
              },
              help)
          ->default_str(name(access(s)));
    };
    f.write = [access, name](const S& s) { return nlohmann::json(name(access(s))); };
    f.read = [access, parse](S& s, const JsonView& v) {
      if (!v.json().is_string()) v.fail("expected a name, found " + v.json().dump());
      try {
        access(s) = parse(v.json().get<std::string>(), "");
      } catch (const Error& e) {
        v.fail(e.reason());
      }
    };
    return add(std::move(f));
  }

  /// Every field of another struct's table, for the member `access` of this one (an options struct
  /// made of others: extraction's of the features', the front ends').
  template <class Part, class Access>
  Table& include(const Table<Part>& part, Access access) {
    check_access<Part>(access);
    for (const Field<Part>& p : part.fields()) {
      Field<S> f;
      f.key = p.key, f.config_key = p.config_key, f.python_key = p.python_key, f.flag = p.flag, f.help = p.help;
      f.type = p.type, f.surfaces = p.surfaces, f.required_in_files = p.required_in_files;
      f.library_names = p.library_names, f.default_text = p.default_text;
      f.add_option = [p, access](CLI::App& app, S& s) { return p.add_option(app, access(s)); };
      f.write = [p, access](const S& s) { return p.write(access(s)); };
      f.read = [p, access](S& s, const JsonView& v) { p.read(access(s), v); };
      if (p.omitted_from_records)
        f.omitted_from_records = [p, access](const S& s) { return p.omitted_from_records(access(s)); };
      add(std::move(f));
    }
    return *this;
  }

  /// A field whose surfaces are written by hand (a name resolved by a registry, a list).
  Table& custom(Field<S> f) { return add(std::move(f)); }

  // Modifiers of the field declared last.
  /// Offered only on these surfaces.
  Table& only(unsigned surfaces) {
    fields_.back().surfaces = surfaces;
    return *this;
  }
  /// Written to files this way (a resolved value: Ks as K when 0).
  Table& written_as(std::function<nlohmann::json(const S&)> write) {
    fields_.back().write = std::move(write);
    return *this;
  }
  /// A file without it reads as the default (files written before the field existed).
  Table& optional_in_files() {
    fields_.back().required_in_files = false;
    return *this;
  }
  /// Left out of files and experiment records while `omit` holds (read as the default when absent).
  Table& recorded_unless(std::function<bool(const S&)> omit) {
    fields_.back().omitted_from_records = std::move(omit);
    fields_.back().required_in_files = false;
    return *this;
  }
  /// Help shows this as the default (a value the field's own default stands for: "K" for Ks = 0).
  Table& default_shown_as(std::string text) {
    fields_.back().default_text = std::move(text);
    return *this;
  }
  /// Named this way (too) by the library's validate(): its errors then name the user's spelling.
  Table& checked_as(std::string library_name) {
    fields_.back().library_names.push_back(std::move(library_name));
    return *this;
  }
  /// Left out of files and experiment records while it holds the struct's default (a field added
  /// after the first records were written).
  Table& recorded_unless_default() {
    return recorded_unless([write = fields_.back().write](const S& s) {
      static const S defaults{};
      return write(s) == write(defaults);
    });
  }
  /// A named field that takes a whole number as its decimal text where JSON gives one (a config's
  /// superpixels: "small" or 12).
  Table& numbers_as_names() {
    fields_.back().read = [read = fields_.back().read](S& s, const JsonView& v) {
      if (!v.json().is_number_integer()) return read(s, v);
      const nlohmann::json text = v.json().dump();  // the number as written, as a name
      read(s, JsonView(text, v.file(), v.where()));
    };
    return *this;
  }
  /// Spelt this way in run-experiment configs.
  Table& in_configs_as(std::string key) {
    fields_.back().config_key = std::move(key);
    return *this;
  }
  /// Spelt this way in Python.
  Table& in_python_as(std::string key) {
    fields_.back().python_key = std::move(key);
    return *this;
  }

  /// The declared field of that key, or null.
  const Field<S>* find(const std::string& key) const {
    for (const auto& f : fields_)
      if (f.key == key) return &f;
    return nullptr;
  }

  /// How `surface` spells a field (files and the command line: its key).
  static const std::string& key_on(const Field<S>& f, Surface surface) {
    return surface == kConfig ? f.config_key : surface == kPython ? f.python_key : f.key;
  }
  /// The field `surface` spells `key`, or null.
  const Field<S>* find_on(const std::string& key, Surface surface) const {
    for (const auto& f : fields_)
      if (f.on(surface) && key_on(f, surface) == key) return &f;
    return nullptr;
  }

  /// CLI11 options for every field on the command line, writing into `s` as they are parsed.
  void add_to(CLI::App& app, S& s) const {
    for (const auto& f : fields_) {
      if (!f.on(kCommandLine) || f.flag.empty()) continue;
      CLI::Option* o = f.add_option(app, s);
      if (!f.default_text.empty()) o->default_str(f.default_text);
    }
  }

  /// CLI11 options for the fields of these keys only, in this order (a tool that takes part of a
  /// struct: label-stream takes the stereo front end's and the voting's).
  void add_to(CLI::App& app, S& s, const std::vector<std::string>& keys) const {
    for (const auto& key : keys) {
      const Field<S>* f = find(key);
      if (!f || !f->on(kCommandLine)) throw std::logic_error("options: " + name_ + " has no command-line field " + key);
      CLI::Option* o = f->add_option(app, s);
      if (!f->default_text.empty()) o->default_str(f->default_text);
    }
  }

  /// The fields on `surface`, as one JSON object.
  nlohmann::json to_json(const S& s, Surface surface = kFile) const {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& f : fields_) {
      if (!f.on(surface)) continue;
      if (surface != kPython && f.omitted_from_records && f.omitted_from_records(s)) continue;
      j[key_on(f, surface)] = f.write(s);
    }
    return j;
  }

  /// Reads the members of `object` that are fields on `surface` into `s`. Files (kFile) must hold every
  /// field that is required_in_files; configs and Python give only what they change. Members that are
  /// not fields are left to the caller (a file holds other things); see check_known.
  void read(S& s, const JsonView& object, Surface surface) const {
    if (!object.json().is_object()) object.fail("expected an object of " + name_ + " options");
    for (const auto& f : fields_) {
      if (!f.on(surface)) continue;
      const std::string& key = key_on(f, surface);
      if (!object.has(key)) {
        if (surface == kFile && f.required_in_files) object.at(key);  // the reader's "missing" error
        continue;
      }
      f.read(s, object.at(key));
    }
  }

  /// Error naming the first member of `object` that is not a field on `surface` (nor in `also`).
  void check_known(const JsonView& object, Surface surface, const std::vector<std::string>& also = {}) const {
    for (const auto& [k, _] : object.json().items()) {
      if (find_on(k, surface) || std::find(also.begin(), also.end(), k) != also.end()) continue;
      object.fail("is not an option of " + name_ + " (options: " + keys_text(surface, also) + ")", k);
    }
  }

  /// "a, b, c": the keys on `surface` (and `also`).
  std::string keys_text(Surface surface, const std::vector<std::string>& also = {}) const {
    std::string s;
    for (const auto& f : fields_)
      if (f.on(surface)) s += (s.empty() ? "" : ", ") + key_on(f, surface);
    for (const auto& a : also) s += (s.empty() ? "" : ", ") + a;
    return s;
  }

  /// Key (and the libraries' names of the field) -> the spelling on `surface`, for errors of validate()
  /// found after reading (option_names.hpp's validate_options).
  std::map<std::string, std::string> option_names(Surface surface = kCommandLine) const {
    std::map<std::string, std::string> m;
    for (const auto& f : fields_) {
      if (!f.on(surface)) continue;
      const std::string& spelling = surface == kCommandLine ? f.flag : key_on(f, surface);
      if (spelling.empty()) continue;
      m[f.key] = spelling;
      for (const auto& n : f.library_names) m[n] = spelling;
    }
    return m;
  }

 private:
  /// A field's access gives the member of that type, writable from S& and readable from const S&.
  template <class T, class Access>
  static void check_access(const Access&) {
    static_assert(std::is_same_v<std::invoke_result_t<const Access&, S&>, T&>,
                  "options: the access must give the field's member (T&) from the struct");
    static_assert(std::is_same_v<std::invoke_result_t<const Access&, const S&>, const T&>,
                  "options: the access must also give it (const T&) from a const struct: [](auto& s) -> auto&");
  }
  Field<S> base(std::string key, std::string flag, std::string help, std::string type) {
    Field<S> f;
    f.key = f.config_key = f.python_key = std::move(key);
    f.flag = std::move(flag);
    f.help = std::move(help);
    f.type = std::move(type);
    f.surfaces = surfaces_;
    return f;
  }
  Table& add(Field<S> f) {
    if (f.config_key.empty()) f.config_key = f.key;
    if (f.python_key.empty()) f.python_key = f.key;
    if (find(f.key)) throw std::logic_error("options: " + name_ + " declares " + f.key + " twice");
    fields_.push_back(std::move(f));
    return *this;
  }
  template <class E, std::size_t N>
  static E as_usage_value(const std::array<EnumName<E>, N>& names, const std::string& v, const std::string& flag) {
    for (const auto& entry : names)
      if (entry.name == v) return entry.value;
    throw CLI::ValidationError(flag, "is \"" + v + "\", expected " + name_choices(names));
  }

  std::string name_;
  unsigned surfaces_;
  std::vector<Field<S>> fields_;
};

}  // namespace smseg::options
