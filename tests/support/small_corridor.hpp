#pragma once
// A few frames of the synthetic corridor and extraction options that print nothing: the stack tests'
// smallest end-to-end input.
#include <filesystem>

#include "smseg/stacks/extract.hpp"
#include "smseg/synth/synth.hpp"

namespace smseg::test {

/// make-sequence --scene corridor --frames `frames` --label-every `label_every` into `dir`.
inline sequence::Sequence small_corridor(const std::filesystem::path& dir, int frames, int label_every) {
  synth::SynthOptions so;
  so.frames = frames;
  so.label_every = label_every;
  return synth::make_sequence(so, dir);
}

/// extract-features's defaults without progress output.
inline stacks::ExtractOptions quiet_extract_options() {
  stacks::ExtractOptions eo;
  eo.progress = false;
  eo.front_end.progress = false;
  return eo;
}

}  // namespace smseg::test
