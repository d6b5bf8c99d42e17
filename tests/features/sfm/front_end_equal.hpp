#pragma once
// Two front-end results are the same poses and the same tracks, bit for bit (the thread-count tests).
#include <gtest/gtest.h>

#include "smseg/frontend/motion.hpp"

inline void expect_same_front_end(const smseg::frontend::FrontEndResult& one,
                                  const smseg::frontend::FrontEndResult& many) {
  ASSERT_EQ(one.poses.size(), many.poses.size());
  for (std::size_t i = 0; i < one.poses.size(); ++i) {
    EXPECT_EQ(one.poses[i].R, many.poses[i].R) << i;
    EXPECT_EQ(one.poses[i].t, many.poses[i].t) << i;
  }
  ASSERT_EQ(one.tracks.size(), many.tracks.size());
  for (std::size_t k = 0; k < one.tracks.size(); ++k) {
    EXPECT_EQ(one.tracks[k].frames, many.tracks[k].frames);
    EXPECT_EQ(one.tracks[k].points, many.tracks[k].points);
  }
}
