// Scene construction for the synthetic stereo video: options, classes, the robot's path and poses,
// the walking people at a time, and the brute-force ray caster (see synth.hpp). The layouts are in
// synth_rooms.cpp, their building blocks in synth_builder.hpp.
#include "synth_builder.hpp"

#include "smseg/common/options.hpp"

namespace smseg::synth {

using namespace build;


// -------------------------------------------------------------------------------------------------

std::vector<sequence::ClassInfo> classes() {
  // Colours follow the thesis figures: floor light blue, wall dark blue, ceiling green, furniture red,
  // obstacle salmon; person yellow.
  return {{"floor", 0, {120, 190, 250}},  {"wall", 1, {30, 50, 160}},     {"ceiling", 2, {40, 170, 60}},
          {"furniture", 3, {210, 30, 30}}, {"obstacle", 4, {250, 140, 120}}, {"person", 5, {250, 220, 30}}};
}

sequence::ClassInfo void_class() { return {"void", 255, {0, 0, 0}}; }

std::vector<sequence::ClassInfo> classes(const std::string& scene) {
  if (scene != "tabletop") return classes();
  // Floor, wall and ceiling as in the other scenes; the table red like furniture, objects orange.
  return {{"floor", 0, {120, 190, 250}}, {"wall", 1, {30, 50, 160}},   {"ceiling", 2, {40, 170, 60}},
          {"table", 3, {210, 30, 30}},   {"object", 4, {255, 160, 0}}};
}

namespace {

std::string scene_name(const std::string& name, const std::string& field) {
  if (name != "corridor" && name != "lab" && name != "tabletop")
    throw Error("", field, "is \"" + name + "\", expected \"corridor\", \"lab\" or \"tabletop\"");
  return name;
}

}  // namespace

const options::Table<SynthOptions>& synth_options_table() {
  using O = SynthOptions;
  using options::kCommandLine;
  static const options::Table<O> table = [] {
    // Files: run-experiment's key of a generated sequence (its cache folder's name).
    options::Table<O> t("make_sequence", kCommandLine | options::kConfig | options::kFile);
    t.named("scene", "--scene",
            "corridor, lab, or tabletop (a table with 3-6 objects in a room, the camera circling it; also writes "
            "instance images)",
            [](auto& o) -> auto& { return o.scene; }, "corridor | lab | tabletop", &scene_name, &options::as_written);
    t.number("seed", "--seed", "random seed for layout, textures, people and noise",
             [](auto& o) -> auto& { return o.seed; }, std::uint64_t{0},
             std::numeric_limits<std::uint64_t>::max());
    t.number("frames", "--frames", "number of frames", [](auto& o) -> auto& { return o.frames; }, 1, 100000);
    // The command line gives both as --size WIDTHxHEIGHT.
    t.number("width", "", "image width in pixels", [](auto& o) -> auto& { return o.width; }, 16, 4096)
        .only(options::kConfig | options::kFile);
    t.number("height", "", "image height in pixels", [](auto& o) -> auto& { return o.height; }, 16, 4096)
        .only(options::kConfig | options::kFile);
    t.number("label_every", "--label-every",
             "mark every Nth frame as labelled in the manifest; label images are written for every frame",
             [](auto& o) -> auto& { return o.label_every; }, 1, 100000);
    t.number("fps", "--fps", "frame rate in Hz (12, as in the thesis)", [](auto& o) -> auto& { return o.fps; }, 1e-3,
             240.0);
    t.number("baseline", "--baseline", "stereo baseline in metres", [](auto& o) -> auto& { return o.baseline; }, 1e-3,
             1.0);
    t.optional_number("camera_height", "--camera-height",
                      "camera height above the floor in metres (default 1.0; tabletop 1.15, the table top + 0.4)",
                      [](auto& o) -> auto& { return o.camera_height; }, 0.3, 2.0)
        .written_as([](const O& o) { return nlohmann::json(o.camera_y()); });
    t.number("hfov_deg", "--hfov", "horizontal field of view in degrees", [](auto& o) -> auto& { return o.hfov_deg; },
             20.0, 120.0);
    t.number("speed", "--speed", "mean robot speed in m/s", [](auto& o) -> auto& { return o.speed; }, 0.0, 2.0);
    t.number("noise_sigma", "--noise", "sensor read noise, grey levels of 255",
             [](auto& o) -> auto& { return o.noise_sigma; }, 0.0, 50.0);
    return t;
  }();
  return table;
}

void SynthOptions::validate() const {
  auto fail = [](const char* option, const std::string& why) { throw Error("", option, why); };
  auto finite = [](double v) { return std::isfinite(v); };
  if (scene != "corridor" && scene != "lab" && scene != "tabletop")
    fail("scene", "is \"" + scene + "\", expected \"corridor\", \"lab\" or \"tabletop\"");
  if (frames < 1 || frames > 100000) fail("frames", "must be in 1..100000, got " + std::to_string(frames));
  if (width < 16 || width > 4096) fail("width", "must be in 16..4096, got " + std::to_string(width));
  if (height < 16 || height > 4096) fail("height", "must be in 16..4096, got " + std::to_string(height));
  if (label_every < 1) fail("label_every", "must be at least 1, got " + std::to_string(label_every));
  if (!finite(fps) || fps <= 0 || fps > 240) fail("fps", "must be in (0, 240], got " + std::to_string(fps));
  if (!finite(baseline) || baseline <= 0 || baseline > 1)
    fail("baseline", "must be in (0, 1] metres, got " + std::to_string(baseline));
  if (camera_height && (!finite(*camera_height) || *camera_height < 0.3 || *camera_height > 2.0))
    fail("camera_height", "must be in [0.3, 2.0] metres, got " + std::to_string(*camera_height));
  if (!finite(hfov_deg) || hfov_deg < 20 || hfov_deg > 120)
    fail("hfov_deg", "must be in [20, 120] degrees, got " + std::to_string(hfov_deg));
  if (!finite(speed) || speed < 0 || speed > 2) fail("speed", "must be in [0, 2] m/s, got " + std::to_string(speed));
  if (!finite(noise_sigma) || noise_sigma < 0 || noise_sigma > 50)
    fail("noise_sigma", "must be in [0, 50], got " + std::to_string(noise_sigma));
}

double SynthOptions::fx() const { return (width / 2.0) / std::tan(hfov_deg * kPi / 360.0); }

double SynthOptions::camera_y() const {
  if (camera_height) return *camera_height;
  return scene == "tabletop" ? kTabletopCameraHeight : 1.0;
}

double frame_time(const SynthOptions& opts, int frame) { return frame / opts.fps; }

sequence::Pose camera_pose(const Scene& scene, const SynthOptions& o, int frame) {
  const CameraPath& p = scene.path;
  if (frame < 0 || frame >= static_cast<int>(p.frame_arc.size()))
    throw Error("", "frame", "frame " + std::to_string(frame) + " is outside the scene's " +
                                 std::to_string(p.frame_arc.size()) + " frames");
  const double t = frame_time(o, frame);
  const double s = p.frame_arc[frame];
  Rng r(detail::hash(o.seed, kSway));
  double ph[8];
  for (double& v : ph) v = r.uniform(0, 2 * kPi);
  const Vector2d f2 = path_tangent(p, s);
  const Vector2d pos = path_point(p, s) + right_of(f2) * (0.05 * std::sin(2 * kPi * t / 8.9 + ph[0]));
  const double deg = kPi / 180;
  const double yaw = (1.0 * std::sin(2 * kPi * t / 3.3 + ph[1]) + 0.4 * std::sin(2 * kPi * t / 1.7 + ph[2])) * deg;
  const double pitch = (0.6 * std::sin(2 * kPi * t / 2.3 + ph[3]) + 0.2 * std::sin(2 * kPi * t / 0.97 + ph[4])) * deg;
  const double roll = 0.5 * std::sin(2 * kPi * t / 3.7 + ph[5]) * deg;
  const double y = o.camera_y() + 0.004 * std::sin(2 * kPi * t / 0.83 + ph[6]);
  Matrix3d R0;
  if (scene.name == "tabletop") {  // look at the table (a point drifting 10 cm around its centre)
    const Vector3d target = scene.look_at + Vector3d(0.1 * std::sin(2 * kPi * t / 6.1 + ph[7]), 0,
                                                     0.1 * std::cos(2 * kPi * t / 7.7 + ph[7]));
    const Vector3d f = (target - at_height(pos, y)).normalized();
    const Vector3d right = f.cross(kUp).normalized();
    R0.col(0) = right;
    R0.col(1) = f.cross(right);  // down
    R0.col(2) = f;
  } else {  // look along the direction of travel
    R0.col(0) = Vector3d(-f2.y(), 0, f2.x());  // right
    R0.col(1) = Vector3d(0, -1, 0);            // down
    R0.col(2) = Vector3d(f2.x(), 0, f2.y());   // forward
  }
  const Matrix3d R = R0 * Eigen::AngleAxisd(yaw, Vector3d::UnitY()).toRotationMatrix() *
                     Eigen::AngleAxisd(pitch, Vector3d::UnitX()).toRotationMatrix() *
                     Eigen::AngleAxisd(roll, Vector3d::UnitZ()).toRotationMatrix();
  sequence::Pose pose;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) pose.R[3 * i + j] = R(i, j);
  pose.t = {pos.x(), y, pos.y()};
  return pose;
}

Scene build_scene(const SynthOptions& opts) {
  opts.validate();
  Scene sc;
  sc.name = opts.scene;
  Rng r(detail::hash(opts.seed, kLayout));
  sc.gain_phase = r.uniform(0, 2 * kPi);
  if (opts.scene == "corridor") {
    build_corridor(sc, opts, r);
  } else if (opts.scene == "lab") {
    build_lab(sc, opts, r);
  } else {
    build_tabletop(sc, opts, r);
  }
  const sequence::Pose p0 = camera_pose(sc, opts, 0);
  shift_scene(sc, Vector2d(p0.t[0], p0.t[2]));
  return sc;
}

std::vector<Quad> quads_at(const Scene& scene, double time) {
  std::vector<Quad> out = scene.quads;
  out.reserve(out.size() + 42 * scene.people.size());
  for (const auto& p : scene.people) person_quads(p, time, out);
  return out;
}

RayHit cast_ray(const std::vector<Quad>& quads, const Vector3d& origin, const Vector3d& dir) {
  RayHit h;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < quads.size(); ++i)
    if (detail::intersect(quads[i], origin, dir, best)) h.quad = static_cast<int>(i);
  if (h.quad >= 0) {
    h.hit = true;
    h.lambda = best;
    h.point = origin + best * dir;
    h.cls = quads[h.quad].cls;
  }
  return h;
}

Vector3d pixel_ray(const SynthOptions& opts, const sequence::Pose& pose, double x, double y) {
  return detail::ray_direction(pose, opts.fx(), opts.cx(), opts.cy(), x, y);
}

}  // namespace smseg::synth
