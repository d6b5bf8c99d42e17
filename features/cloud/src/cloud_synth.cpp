// Synthetic tabletop clouds (cloud_segment.hpp) and the F1 score: no PCL here.
#include <algorithm>
#include <cmath>
#include <random>

#include "smseg/common/error.hpp"
#include "smseg/cloud/cloud_segment.hpp"

namespace smseg::cloud {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Shape {
  enum Kind { Box, Sphere, Cylinder } kind;
  Eigen::Vector3d centre;  // on the table (y = 0 at the base)
  double size;             // half width (box), radius (sphere, cylinder)
  double height;           // box and cylinder height
  std::array<std::uint8_t, 3> rgb;
};

// Object k's shape, position and colour: object 0 at the centre, the others on a ring.
Shape object_shape(int k) {
  static const std::array<std::array<std::uint8_t, 3>, 8> colours = {{{200, 40, 40},
                                                                      {40, 160, 60},
                                                                      {40, 70, 200},
                                                                      {220, 200, 40},
                                                                      {170, 60, 190},
                                                                      {40, 190, 200},
                                                                      {240, 130, 30},
                                                                      {250, 250, 250}}};
  Shape s;
  s.kind = static_cast<Shape::Kind>(k % 3);
  s.size = 0.15 + 0.025 * (k % 3);
  s.height = 0.3 + 0.05 * (k % 2);
  s.rgb = colours[std::size_t(k)];
  if (k == 0) {
    s.centre = {0, 0, 0};
  } else {
    const double a = 2 * kPi * (k - 1) / 7.0;
    s.centre = {0.68 * std::cos(a), 0, 0.68 * std::sin(a)};
  }
  if (s.kind == Shape::Sphere) s.centre.y() = s.size;  // the sphere rests on the table
  return s;
}

bool under(const Shape& s, double x, double z) {  // table point hidden under the object
  const double dx = x - s.centre.x(), dz = z - s.centre.z();
  if (s.kind == Shape::Box) return std::abs(dx) <= s.size && std::abs(dz) <= s.size;
  const double r = s.kind == Shape::Sphere ? 0.3 * s.size : s.size;  // a sphere touches a small disc
  return dx * dx + dz * dz <= r * r;
}

Eigen::Vector3d sample_surface(const Shape& s, std::mt19937_64& g) {
  std::uniform_real_distribution<double> u(0, 1);
  if (s.kind == Shape::Sphere) {
    const double zc = 2 * u(g) - 1, a = 2 * kPi * u(g), r = std::sqrt(1 - zc * zc);
    return s.centre + s.size * Eigen::Vector3d(r * std::cos(a), zc, r * std::sin(a));
  }
  if (s.kind == Shape::Cylinder) {
    const double side = 2 * kPi * s.size * s.height, top = kPi * s.size * s.size;
    const double a = 2 * kPi * u(g);
    if (u(g) * (side + top) < side)
      return s.centre + Eigen::Vector3d(s.size * std::cos(a), s.height * u(g), s.size * std::sin(a));
    const double r = s.size * std::sqrt(u(g));
    return s.centre + Eigen::Vector3d(r * std::cos(a), s.height, r * std::sin(a));
  }
  // Box: 4 sides and the top, by area.
  const double w = 2 * s.size, side = w * s.height, top = w * w;
  double pick = u(g) * (4 * side + top);
  const double a = u(g) * w - s.size, b = u(g);
  if (pick >= 4 * side) return s.centre + Eigen::Vector3d(u(g) * w - s.size, s.height, u(g) * w - s.size);
  const int face = static_cast<int>(pick / side);
  switch (face) {
    case 0: return s.centre + Eigen::Vector3d(a, b * s.height, -s.size);
    case 1: return s.centre + Eigen::Vector3d(a, b * s.height, s.size);
    case 2: return s.centre + Eigen::Vector3d(-s.size, b * s.height, a);
    default: return s.centre + Eigen::Vector3d(s.size, b * s.height, a);
  }
}

std::uint8_t clamp_colour(double v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L)); }

}  // namespace

void ColouredCloud::validate(const std::string& source) const {
  if (!colours.empty() && colours.size() != points.size())
    throw Error(source, "colours", std::to_string(colours.size()) + " colours for " + std::to_string(points.size()) + " points");
  if (!labels.empty() && labels.size() != points.size())
    throw Error(source, "labels", std::to_string(labels.size()) + " labels for " + std::to_string(points.size()) + " points");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite()) throw Error(source, "points", "point " + std::to_string(i) + " is not finite");
}

void TabletopCloudOptions::validate() const {
  if (points < 100) throw Error("", "points", "at least 100 points");
  if (objects < 1 || objects > 8) throw Error("", "objects", "1..8 objects");
  if (!(object_share > 0 && object_share < 1)) throw Error("", "object_share", "must be in (0, 1)");
  if (!(noise >= 0) || !(colour_noise >= 0)) throw Error("", "noise", "must be >= 0");
}

ColouredCloud make_tabletop_cloud(const TabletopCloudOptions& opt) {
  opt.validate();
  std::mt19937_64 g(opt.seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> pn(0, opt.noise), cn(0, opt.colour_noise);
  std::vector<Shape> shapes;
  for (int k = 0; k < opt.objects; ++k) shapes.push_back(object_shape(k));
  ColouredCloud c;
  const int on_objects = static_cast<int>(std::lround(opt.points * opt.object_share));
  const int per_object = on_objects / opt.objects;
  const int on_table = opt.points - per_object * opt.objects;
  auto add = [&](const Eigen::Vector3d& p, const std::array<std::uint8_t, 3>& rgb, int label) {
    c.points.emplace_back(float(p.x() + pn(g)), float(p.y() + pn(g)), float(p.z() + pn(g)));
    c.colours.push_back({clamp_colour(rgb[0] + cn(g)), clamp_colour(rgb[1] + cn(g)), clamp_colour(rgb[2] + cn(g))});
    c.labels.push_back(label);
  };
  const std::array<std::uint8_t, 3> table_rgb{150, 110, 70};
  for (int i = 0; i < on_table;) {
    const double x = u(g), z = u(g);
    if (std::any_of(shapes.begin(), shapes.end(), [&](const Shape& s) { return under(s, x, z); })) continue;
    add({x, 0, z}, table_rgb, 0);
    ++i;
  }
  for (int k = 0; k < opt.objects; ++k)
    for (int i = 0; i < per_object; ++i) add(sample_surface(shapes[std::size_t(k)], g), shapes[std::size_t(k)].rgb, k + 1);
  return c;
}

double f1_score(std::span<const int> truth, std::span<const int> predicted, int label) {
  if (truth.size() != predicted.size()) throw Error("", "f1", "truth and prediction differ in size");
  std::int64_t tp = 0, fp = 0, fn = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    if (truth[i] < 0) continue;
    const bool t = truth[i] == label, p = predicted[i] == label;
    tp += t && p;
    fp += !t && p;
    fn += t && !p;
  }
  if (tp + fp + fn == 0) return std::nan("");
  return 2.0 * double(tp) / double(2 * tp + fp + fn);
}

}  // namespace smseg::cloud
