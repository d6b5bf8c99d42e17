#pragma once
// The sequence reader's checks, for the importers: what they write is checked as the reader will
// check it, before it is written.

#include <array>

#include "smseg/sequence/sequence.hpp"

namespace smseg::sequence {

/// Whether R (row-major 3x3) is a rotation: R R^T = I to 1e-4 and det R > 0, as the tracks reader
/// checks its poses.
bool is_rotation(const std::array<double, 9>& R);

/// The sequence a parsed sequence.json describes, checked as load_sequence checks it (every named file
/// must exist); Error naming `manifest` and the field.
Sequence sequence_from_json(const Json& doc, const fs::path& manifest);

/// Error unless seq, written to seq.manifest, would be read back: every check of the reader, run on
/// what an importer is about to write.
void check_before_saving(const Sequence& seq);

}  // namespace smseg::sequence
