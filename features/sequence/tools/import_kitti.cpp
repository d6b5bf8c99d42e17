// import-kitti: a rectified KITTI stereo slice -> one stereo sequence manifest (images not copied).
#include <iostream>

#include "smseg/common/cli.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/options.hpp"
#include "smseg/sequence/kitti.hpp"

int main(int argc, char** argv) {
  using namespace smseg::sequence;
  CLI::App app{"Import a rectified KITTI stereo slice as a stereo sequence (sequence.json in OUT; the images\n"
               "are referred to where they are, not copied). Layouts: KITTI odometry's own (image_0/, image_1/,\n"
               "calib.txt with P0/P1, optional times.txt and poses.txt) or ../shared/data/kitti-stereo's\n"
               "(image_l/, image_r/, calib.txt, poses.txt). Ground-truth poses become the sequence's ground truth\n"
               "(world Y up, origin on the ground under the first camera). No labels: the class list is\n"
               "CamVid's 11 road classes unless --classes names another.",
               "import-kitti"};
  std::string dir, out;
  KittiImportOptions opt;
  std::string poses, classes;
  app.add_option("DIR", dir, "the slice's folder, e.g. ../shared/data/kitti-stereo/seq1")->required();
  app.add_option("-o,--out", out, "output folder for sequence.json")->required();
  app.add_option("--poses", poses, "ground-truth poses file (default: DIR/poses.txt if present)");
  app.add_option("--camera-height", opt.camera_height, "camera height above the road in metres")->capture_default_str()
      ->check(smseg::options::in_range(0.001, 10000.0));
  app.add_option("--fps", opt.fps, "frame rate when DIR has no times.txt")->capture_default_str()
      ->check(smseg::options::in_range(0.001, 1000.0));
  app.add_option("--name", opt.name, "sequence name (default: the folder's name)");
  app.add_option("--classes", classes, "class table in CamVid's classes.csv form (index,name,r,g,b with a Void row)");
  double disparity_offset = 0;
  app.add_option("--disparity-offset", disparity_offset,
                 "pixels added to every disparity: the right images' offset against the left ones (cx_right - "
                 "cx_left; default: from calib.txt, P1 cx - P0 cx, 0 for KITTI's own files; "
                 "experiments/kitti/self_calibrate_offset.py estimates it from the sequence's own tracks)")
      ->check(smseg::options::in_range(-1000.0, 1000.0));
  return smseg::run_tool(app, argc, argv, [&] {
    if (app.count("--disparity-offset")) opt.disparity_offset = disparity_offset;
    opt.poses = poses;
    opt.classes = classes;
    const smseg::OutputLock one_writer(out, {dir, poses, classes});
    const Sequence seq = import_kitti(dir, out, opt);
    std::cout << seq.name << ": " << seq.frame_count() << " stereo frames of " << seq.size.width << "x" << seq.size.height
              << ", fx " << *seq.calibration.fx << " px, baseline " << *seq.calibration.baseline << " m, disparity offset "
              << seq.calibration.disparity_offset << " px, "
              << (seq.gt_poses.empty() ? "no ground-truth poses" : "ground-truth poses") << " -> " << out << "/sequence.json\n";
    return 0;
  });
}
