// The PCL part of cloud.hpp, in its own library so that only the tools that write clouds link PCL.
#include <unistd.h>

#include <atomic>

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "smseg/cloud/cloud_io.hpp"
#include "smseg/common/output.hpp"
#include "pcl_write.hpp"

namespace smseg::cloud {

namespace pcl_write {

void check_extension(const fs::path& path) {
  const std::string ext = path.extension().string();
  if (ext != ".pcd" && ext != ".ply") throw Error(path.string(), "", "a point cloud file must end in .pcd or .ply");
}

void save_atomic(const fs::path& path, const pcl::PointCloud<pcl::PointXYZRGBL>& pc) {
  check_extension(path);
  const std::string ext = path.extension().string();
  std::error_code ec;
  if (path.has_parent_path()) fs::create_directories(path.parent_path(), ec);
  const fs::path tmp = temporary_beside(path, ext);  // PCL picks the format by the extension
  // PCL warns on stderr about an empty cloud (a front end that kept no point), a valid file for us.
  const auto pcl_level = pcl::console::getVerbosityLevel();
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  const int rc =
      ext == ".pcd" ? pcl::io::savePCDFileBinary(tmp.string(), pc) : pcl::io::savePLYFileBinary(tmp.string(), pc);
  pcl::console::setVerbosityLevel(pcl_level);
  if (rc != 0) {
    fs::remove(tmp, ec);
    throw Error(path.string(), "", "PCL could not write the point cloud");
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    const std::string why = fs::is_directory(path) ? "is a folder, expected a file" : "cannot be replaced: " + ec.message();
    fs::remove(tmp, ec);  // (overwrites ec: the reason is taken first)
    throw Error(path.string(), "", why);
  }
}

}  // namespace pcl_write

void write_cloud(const fs::path& path, const std::vector<stacks::CloudPoint>& cloud, const sequence::Sequence& seq) {
  pcl_write::check_extension(path);
  pcl::PointCloud<pcl::PointXYZRGBL> pc;
  pc.reserve(cloud.size());
  for (const auto& c : cloud) {
    pcl::PointXYZRGBL p;
    p.x = c.position.x();
    p.y = c.position.y();
    p.z = c.position.z();
    std::array<std::uint8_t, 3> rgb{170, 170, 170};
    if (c.label >= 0 && c.label < static_cast<int>(seq.classes.size())) rgb = seq.classes[c.label].rgb;
    p.r = rgb[0];
    p.g = rgb[1];
    p.b = rgb[2];
    p.label = c.label >= 0 ? static_cast<std::uint32_t>(c.label) : 255u;
    pc.push_back(p);
  }
  pc.width = static_cast<std::uint32_t>(pc.size());
  pc.height = 1;
  pcl_write::save_atomic(path, pc);
}

}  // namespace smseg::cloud
