#pragma once
// Writing labelled PCL clouds, shared by cloud_io.cpp and cloud_segment.cpp (internal to smseg_cloud).
#include <filesystem>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace smseg::cloud::pcl_write {

/// Error naming `path` unless it ends in .pcd or .ply.
void check_extension(const std::filesystem::path& path);

/// Writes `pc` as binary PCD or PLY (by the extension) to a temporary file beside `path`, then renames
/// it over `path`: an interrupted write never leaves a half-written cloud. Error naming `path` on failure.
void save_atomic(const std::filesystem::path& path, const pcl::PointCloud<pcl::PointXYZRGBL>& pc);

}  // namespace smseg::cloud::pcl_write
