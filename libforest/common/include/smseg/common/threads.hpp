#pragma once
// --threads, as every tool has it: 0 means all cores; N > 0 means exactly N worker threads, even more
// than the machine has cores (so the determinism tests can run 8 threads on a 2-core machine; the
// results must not depend on it). Values outside [0, kMaxThreads] are bad usage (exit status 2).
#include <string>
#include <utility>

#include <CLI/CLI.hpp>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/task_arena.h>

namespace smseg {

/// More threads than this is a typing error, not a machine (and each costs a stack).
inline constexpr int kMaxThreads = 1024;

/// Adds `--threads` to app, storing into threads; `extra` ends the help text (what does not depend
/// on the count, say). A value outside [0, kMaxThreads] is refused by the parser (exit status 2).
inline CLI::Option* add_threads_option(CLI::App& app, int& threads, const std::string& extra = "") {
  return app
      .add_option("--threads", threads,
                  "worker threads (0: all cores; at most " + std::to_string(kMaxThreads) + ")" +
                      (extra.empty() ? "" : "; " + extra))
      ->check(CLI::Range(0, kMaxThreads))
      ->capture_default_str();
}

/// Runs body() with `threads` worker threads (0: TBB's default, one per core) and returns what it
/// returns. A global_control alone only lowers the count; the arena of that many slots is what makes
/// N above the core count real. Exceptions from body() propagate.
template <class Body>
auto with_threads(int threads, Body&& body) {
  if (threads <= 0) return body();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  tbb::task_arena arena(threads);
  return arena.execute(std::forward<Body>(body));
}

}  // namespace smseg
