#pragma once
// What every folder that extends a work folder (add-textons, add-people) must read as: its base's frames
// and, through the base, its tables and labels, then `added` channels of its own.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "smseg/stacks/stack.hpp"

namespace smseg::test {

/// Checks `m` against its base on the first labelled frame and returns that frame's stack, opened with
/// labels (its own channels come after base.features.size()).
inline stacks::FrameStack expect_extends(const stacks::StackManifest& base, const stacks::StackManifest& m,
                                         const std::vector<std::string>& added) {
  EXPECT_EQ(m.features.size(), base.features.size() + added.size());
  EXPECT_TRUE(std::equal(added.begin(), added.end(), m.features.end() - long(std::min(added.size(), m.features.size()))));
  EXPECT_EQ(m.frames, base.frames);
  EXPECT_EQ(m.labelled_frames, base.labelled_frames);
  const int f = m.labelled_frames.at(0);
  stacks::FrameStack ours = stacks::FrameStack::open(m, f, true);
  const stacks::FrameStack theirs = stacks::FrameStack::open(base, f, true);
  const std::size_t W = std::size_t(m.size.width), H = std::size_t(m.size.height), cells = (H + 1) * (W + 1);
  for (std::size_t k = 0; k < base.features.size(); ++k)  // the base's tables, through the base
    EXPECT_TRUE(std::equal(ours.sat(int(k)), ours.sat(int(k)) + cells, theirs.sat(int(k)))) << base.features[k];
  EXPECT_TRUE(std::equal(ours.labels(), ours.labels() + W * H, theirs.labels()));
  return ours;
}

}  // namespace smseg::test
