#pragma once
// The tracked cloud of the stacks stage (smseg/stacks/track_cloud.hpp) written as a point-cloud file
// with PCL, for PCL viewers and CloudCompare (docs/design.md 3.2). In this module because it links PCL (and the
// VTK it drags along), which the stages below must not need.

#include <vector>

#include "smseg/common/io.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/stacks/track_cloud.hpp"

namespace smseg::cloud {

/// Writes the cloud with PCL (pcl::PointXYZRGBL: the class colour and the class position as label,
/// 255 = none), binary PCD for ".pcd", binary PLY for ".ply"; atomic. Error naming the file otherwise.
void write_cloud(const fs::path& path, const std::vector<stacks::CloudPoint>& cloud, const sequence::Sequence& seq);

}  // namespace smseg::cloud
