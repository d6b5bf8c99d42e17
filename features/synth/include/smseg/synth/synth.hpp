#pragma once
// The synthetic stereo video (`make-sequence`, the toolkit's embedded default dataset): what a small
// indoor robot with a rectified pinhole stereo rig would record while driving through a corridor or a
// cluttered lab, with a walking person, together with exact ground truth (labels and depth for every
// frame, camera poses).
//
// How it is made (the decisions, so that users of the data know what they get):
// - Geometry: one-sided rectangles ("quads") only. A quad is seen from the side its normal points to
//   (room walls face inwards, box faces outwards); the camera never enters a box. Boxes (furniture,
//   obstacles, the body parts of a person) are six quads (five when standing on the floor). Posters
//   and doors are quads 1 cm in front of their wall and carry the wall's class.
// - Rendering: one ray per pixel through the pixel centre (pixel centres at integer coordinates,
//   principal point at ((W-1)/2, (H-1)/2), fx = fy from the horizontal field of view). The ray's
//   nearest front-facing hit gives the label (its quad's class) and the depth (z along the optical
//   axis, metres, float32). Rays that hit nothing are void (black label, depth 0); the scenes are
//   closed, so there are none in practice. Per frame, quads are culled and binned into 8x8-pixel
//   tiles by their projected bounding box; `cast_ray` is the brute-force reference the tests compare
//   the fast path against.
// - Appearance: procedural textures evaluated in the quad's surface coordinates (metres) and
//   band-limited by the pixel's footprint on the surface (no shimmering far away): floor tiles,
//   carpet, painted walls with a baseboard (large plain low-texture areas), concrete blocks, ceiling
//   tiles, posters of coloured blocks and text lines, doors, bookshelves, wood, cardboard, whiteboards,
//   emissive ceiling light panels. Shading: ambient (brighter for upward normals) + ceiling point
//   lights with a smooth finite falloff, no shadows. Global illumination drifts slowly over time
//   (+-12% over ~20 s); the right camera has a slightly different gain and colour balance. Then:
//   vignetting, gamma 2.2, a small optical blur (Gaussian, sigma 0.6 px), and approximately Gaussian
//   sensor noise (read noise `noise_sigma` DN plus shot noise), per pixel and channel from a
//   counter-based hash of (seed, frame, camera, pixel), so output never depends on thread count.
// - Camera path: the left camera's centre moves at about `speed` m/s (+-25%, slower in turns) along a
//   smooth path `camera_height` above the floor, looking along the direction of travel with a little
//   sway (yaw/pitch/roll of about a degree, a few mm of bob). Corridor: a corridor 2.4 m wide and 2.6 m
//   high with 90-degree turns every 3.5-5.5 m (alternating left/right; two turns within the first ~9 m),
//   each turn a T: a dead end of 1.5-3 m continues straight on; the robot keeps 0.3 m right of the
//   centre line and turns on arcs of 1 m radius. Lab: a 9 x 7 m room, the robot driving a wobbly
//   ellipse around the middle. The right camera is `baseline` metres along the left camera's +x.
// - People: boxes for torso, head, arms and swinging legs, walking back and forth along a line at
//   ~1 m/s (corridor: one or two, along the left side of a segment; lab: two, across the room and the
//   robot's path), with a phase chosen so that they keep at least 0.6 m (corridor) / 0.8 m (lab) from
//   the camera when the candidates allow.
// - World frame (docs/design.md 3.2): Y up, origin on the floor under the first camera position; poses are
//   camera-to-world R (columns = camera x right, y down, z forward in world coordinates) and centre t.
// - Tabletop (for the point-cloud segmenters): a 6.4 x 5.6 m room (floor, walls with
//   posters and a door, ceiling with lights) with a wooden table in the middle (0.75 m high, 1.2-1.6 x
//   0.75-0.95 m top, four legs) and 3-6 objects on it, boxes and cylinders (24-sided prisms with a disc
//   lid) of distinct saturated colours, plain, striped or checked, placed from the seed without touching
//   and away from the table's edge. The stereo camera (default 1.15 m high, the table top + 0.4 m) circles
//   the table at 1.15-1.85 m from its centre, drifting towards and away from it, always looking at the
//   table (a little sway on top), at about `speed` m/s. Classes floor, wall, ceiling, table, object;
//   every object also has an instance id 1..K (instance images, see make_sequence).
// - Everything random derives from `seed` through counter-based hashing; same options and seed give
//   byte-identical files.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "smseg/sequence/sequence.hpp"

namespace smseg::options {
template <class S>
class Table;  // smseg/common/options.hpp
}

namespace smseg::synth {

/// The classes, in this order (their positions in Sequence::classes). The tabletop scene has the first
/// five, with furniture named "table" (kTable) and obstacle named "object" (kObject), and no person.
enum Class : std::uint8_t { kFloor = 0, kWall, kCeiling, kFurniture, kObstacle, kPerson, kClassCount };
inline constexpr std::uint8_t kTable = kFurniture, kObject = kObstacle;
std::vector<sequence::ClassInfo> classes();  ///< corridor and lab: names and display colours, RGB label encoding
std::vector<sequence::ClassInfo> classes(const std::string& scene);  ///< the class list of a scene
sequence::ClassInfo void_class();            ///< black (0, 0, 0), value 255
inline bool has_instances(const std::string& scene) { return scene == "tabletop"; }

struct SynthOptions {
  std::string scene = "corridor";  ///< "corridor", "lab" or "tabletop"
  std::uint64_t seed = 1;          ///< geometry, textures, people, noise all derive from it
  int frames = 300;                ///< number of frames, >= 1
  int width = 320, height = 240;   ///< image size in pixels, each in 16..4096
  int label_every = 10;            ///< the manifest marks frames 0, n, 2n, ... as labelled (>= 1)
  double fps = 12.0;               ///< frame rate (the thesis captured at about 12 Hz)
  double baseline = 0.12;          ///< stereo baseline in metres (Bumblebee2: 12 cm), (0, 1]
  /// Optical centre above the floor in metres, [0.3, 2.0]; unset: the scene's default (camera_y()).
  std::optional<double> camera_height;
  double hfov_deg = 66.0;          ///< horizontal field of view in degrees, [20, 120]
  double speed = 0.45;             ///< mean robot speed in m/s, [0, 2]
  double noise_sigma = 2.0;        ///< sensor read noise in grey levels (0..255 scale), [0, 50]
  bool progress = false;           ///< progress on stderr while writing

  /// Throws Error("", "<option>", why) for the first invalid option.
  void validate() const;
  double fx() const;  ///< focal length in pixels (fx = fy)
  /// camera_height, or the scene's default: 1.0 (corridor, lab), kTabletopCameraHeight (tabletop).
  double camera_y() const;
  double cx() const { return (width - 1) / 2.0; }
  double cy() const { return (height - 1) / 2.0; }
};

/// SynthOptions' fields, declared once (options.hpp): make-sequence's options (but --size), the
/// "synthetic" sequences of run-experiment configs, and the key a generated sequence is cached by.
const options::Table<SynthOptions>& synth_options_table();

inline constexpr double kTableHeight = 0.75;          ///< tabletop: height of the table top, metres
inline constexpr double kTabletopCameraHeight = 1.15;  ///< tabletop: default camera height (table + 0.4 m)

/// Procedural surface appearance; see synth_texture.cpp for each kind.
struct Material {
  enum Kind : std::uint8_t {
    Plain, Tiles, Blocks, CeilingTiles, Carpet, Wood, Poster, Door, Books, Cardboard, Whiteboard, Light,
    Checker, Fabric, Screen, Drawers
  };
  Kind kind = Plain;
  std::array<float, 3> a{0.5f, 0.5f, 0.5f}, b{0.3f, 0.3f, 0.3f}, c{0.1f, 0.1f, 0.1f};  ///< linear RGB
  float scale = 0.5f, scale2 = 0.0f;  ///< kind-specific sizes in metres (tile size, baseboard height ...)
  std::uint32_t seed = 0;             ///< kind-specific variation (poster layout, book colours ...)
  float emission = 0.0f;              ///< emitted radiance added to the shaded colour
};

/// A one-sided rectangle: centre + s*u + t*v for |s| <= hu, |t| <= hv; visible from the side
/// normal = u x v points to. Texture coordinates are (s + hu + tex.x, t + hv + tex.y), in metres.
/// A disc quad is the ellipse inscribed in the rectangle, (s/hu)^2 + (t/hv)^2 <= 1 (cylinder lids).
struct Quad {
  Eigen::Vector3d centre, u, v, normal;
  double hu = 0, hv = 0;
  Eigen::Vector2d tex{0, 0};
  std::uint8_t cls = kWall;
  int material = 0;           ///< index into Scene::materials
  std::uint8_t instance = 0;  ///< object id 1..K (tabletop objects), 0 for everything else
  bool disc = false;
};

struct Light {
  Eigen::Vector3d position;
  std::array<float, 3> intensity{1, 1, 1};
};

/// A person walking back and forth along the segment a -> b (world XZ, metres).
struct Person {
  Eigen::Vector2d a, b;
  double speed = 1.0;   ///< m/s
  double phase = 0.0;   ///< seconds added to the time
  double height = 1.75;
  int shirt = 0, trousers = 0, skin = 0, hair = 0;  ///< materials
};

/// The smooth 2-D path of the robot (world XZ), sampled densely, by arc length.
struct CameraPath {
  std::vector<Eigen::Vector2d> points;  ///< every ~1 cm
  std::vector<double> arc;              ///< cumulative arc length at each point
  bool closed = false;                  ///< the lab path loops
  std::vector<double> frame_arc;        ///< arc length travelled at each frame
};

/// A tabletop object (for the manifest and the tests): instance id, shape, where it stands.
struct Object {
  int id = 0;                  ///< 1..K, the value in the instance images
  std::string shape;           ///< "box" or "cylinder"
  std::string colour;          ///< colour name (its base colour)
  std::string texture;         ///< "plain", "stripes" or "checks"
  Eigen::Vector3d base{0, 0, 0};  ///< world point at the centre of its bottom face
  Eigen::Vector3d size{0, 0, 0};  ///< box: width, height, depth; cylinder: diameter, height, diameter
  double yaw = 0;              ///< radians about world Y
};

struct Scene {
  std::string name;
  std::vector<Object> objects;  ///< tabletop objects, id order
  std::vector<Material> materials;
  std::vector<Quad> quads;  ///< static geometry
  std::vector<Light> lights;
  std::vector<Person> people;
  CameraPath path;
  double ceiling_height = 2.6;
  double light_range = 7.0;  ///< a light contributes nothing beyond this distance
  double ambient = 0.3;
  double gain_phase = 0.0;   ///< phase of the slow global illumination drift
  Eigen::Vector3d look_at{0, 0, 0};  ///< tabletop: the point the camera looks at (the table's centre)
};

/// Builds the scene of opts.scene for opts.seed, including the camera path for opts.frames frames.
/// Validates opts first.
Scene build_scene(const SynthOptions& opts);

double frame_time(const SynthOptions& opts, int frame);  ///< seconds, frame / fps

/// Left-camera pose at a frame (camera-to-world; see the header comment). Right camera: t + baseline*R.col(0).
sequence::Pose camera_pose(const Scene& scene, const SynthOptions& opts, int frame);

/// Static quads plus the people's body parts at the given time.
std::vector<Quad> quads_at(const Scene& scene, double time);

struct RayHit {
  bool hit = false;
  double lambda = 0;  ///< hit point = origin + lambda * dir (dir need not be unit length)
  Eigen::Vector3d point{0, 0, 0};
  int quad = -1;  ///< index into the quad list
  std::uint8_t cls = sequence::kVoid;
};

/// Brute force: the nearest front-facing quad hit with lambda > 0 (ties: lowest index).
RayHit cast_ray(const std::vector<Quad>& quads, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir);

/// The world ray through pixel (x, y) of a camera with the given pose; lambda along it is z-depth.
Eigen::Vector3d pixel_ray(const SynthOptions& opts, const sequence::Pose& pose, double x, double y);

struct Frame {
  cv::Mat left, right;  ///< CV_8UC3 BGR
  cv::Mat labels;       ///< CV_8UC1 class positions, kVoid where nothing was hit
  cv::Mat depth;        ///< CV_32FC1 z-depth of the left camera in metres, 0 where nothing was hit
  cv::Mat instances;    ///< CV_8UC1 object id of the hit quad (1..K), 0 for non-objects and void
  sequence::Pose pose;            ///< left camera
};

/// Renders one frame (single-threaded; make_sequence parallelises over frames).
Frame render_frame(const Scene& scene, const SynthOptions& opts, int frame);

/// Renders every frame and writes the sequence into out_dir (created if missing): left/NNNNNN.png,
/// right/NNNNNN.png, labels/NNNNNN.png (RGB class colours, every frame), depth/NNNNNN.npy, for scenes
/// with objects (tabletop) instances/NNNNNN.png (8-bit, object id 1..K, 0 = no object; labelled frames
/// only), and last the manifest sequence.json. Returns the sequence as load_sequence would read it.
sequence::Sequence make_sequence(const SynthOptions& opts, const fs::path& out_dir);

/// A montage for the docs: one row per frame, columns left image | colour labels | false-colour depth
/// (turbo, near = red, 0..max_depth metres), from the files of a sequence, each panel scaled by scale.
cv::Mat make_montage(const sequence::Sequence& seq, const std::vector<int>& frames, double max_depth = 10.0,
                     double scale = 1.0);

}  // namespace smseg::synth
