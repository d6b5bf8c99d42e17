#pragma once
// The check every reader of a frame's labels makes (open_stacks, learn-hog-classes' samples).
#include <cstddef>

#include "smseg/common/io.hpp"
#include "smseg/forest/data.hpp"

namespace smseg::stacks {

/// Every label of a frame (opened with labels) is a class position below `classes` or 255 (void); Error
/// naming `file` (the frame's labels file) and the pixel otherwise.
void check_labels(const forest::FrameData& frame, const fs::path& file, std::size_t classes);

}  // namespace smseg::stacks
