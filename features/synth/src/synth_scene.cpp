// Scene construction for the synthetic stereo video: options, classes, the corridor and lab layouts,
// the robot's path and poses, the walking people, and the brute-force ray caster (see synth.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Geometry>

#include "synth_detail.hpp"

namespace smseg::features::synth {

using detail::lin;
using detail::Rng;
using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {

constexpr double kPi = std::numbers::pi;
const Vector3d kUp(0, 1, 0);

/// Salts for the independent random streams derived from the seed.
enum Stream : std::uint64_t { kLayout = 1, kSway, kSpeed, kPeople, kObjects, kNoise };

Vector3d at_height(const Vector2d& p, double y) { return {p.x(), y, p.y()}; }
/// Right of a walking direction in the XZ plane (camera x for a camera looking along f, world Y up).
Vector2d right_of(const Vector2d& f) { return {-f.y(), f.x()}; }

// ---------------------------------------------------------------------------------------------
// Building geometry.

struct Footprint {  // axis-aligned box on the floor (XZ), for placement tests
  double x0, z0, x1, z1;
  bool overlaps(const Footprint& o, double margin) const {
    return x0 - margin < o.x1 && o.x0 < x1 + margin && z0 - margin < o.z1 && o.z0 < z1 + margin;
  }
  double distance(const Vector2d& p) const {
    const double dx = std::max({x0 - p.x(), 0.0, p.x() - x1});
    const double dz = std::max({z0 - p.y(), 0.0, p.y() - z1});
    return std::hypot(dx, dz);
  }
};

class Builder {
 public:
  Builder(Scene& scene, Rng& rng) : sc_(scene), rng_(rng) {}
  Scene& scene() { return sc_; }
  Rng& rng() { return rng_; }

  int material(const Material& m) {
    sc_.materials.push_back(m);
    sc_.materials.back().seed = static_cast<std::uint32_t>(rng_.next());
    if (m.seed != 0) sc_.materials.back().seed = m.seed;
    return static_cast<int>(sc_.materials.size()) - 1;
  }

  void quad(const Vector3d& centre, const Vector3d& u, const Vector3d& v, double hu, double hv, std::uint8_t cls,
            int mat, const Vector2d& tex = Vector2d::Zero()) {
    Quad q;
    q.centre = centre;
    q.u = u.normalized();
    q.v = v.normalized();
    q.normal = q.u.cross(q.v).normalized();
    q.hu = hu;
    q.hv = hv;
    q.tex = tex;
    q.cls = cls;
    q.material = mat;
    sc_.quads.push_back(q);
  }

  /// An oriented box: centre, axes (columns, right-handed), half sizes; materials for the faces
  /// (front = +z axis, top = +y). bottom=false leaves out the -y face (boxes standing on the floor).
  static void box(std::vector<Quad>& out, const Vector3d& c, const Matrix3d& ax, const Vector3d& h, std::uint8_t cls,
           int side, int top, int front, bool bottom) {
    const Vector3d ex = ax.col(0), ey = ax.col(1), ez = ax.col(2);
    auto face = [&](const Vector3d& centre, const Vector3d& u, const Vector3d& v, double hu, double hv, int mat) {
      Quad q;
      q.centre = centre;
      q.u = u;
      q.v = v;
      q.normal = u.cross(v);
      q.hu = hu;
      q.hv = hv;
      q.cls = cls;
      q.material = mat;
      out.push_back(q);
    };
    face(c + ez * h.z(), ex, ey, h.x(), h.y(), front);
    face(c - ez * h.z(), -ex, ey, h.x(), h.y(), side);
    face(c + ex * h.x(), -ez, ey, h.z(), h.y(), side);
    face(c - ex * h.x(), ez, ey, h.z(), h.y(), side);
    face(c + ey * h.y(), ez, ex, h.z(), h.x(), top);
    if (bottom) face(c - ey * h.y(), ex, ez, h.x(), h.z(), side);
  }

  /// A box standing on the floor (or on something at height y0) turned by yaw about Y; size is
  /// (width along local x, height, depth along local z); the front (+z) faces direction yaw.
  Footprint floor_box(const Vector2d& base, double y0, double yaw, const Vector3d& size, std::uint8_t cls, int side,
                      int top, int front) {
    const Matrix3d ax = yaw_axes(yaw);
    const Vector3d h = size / 2;
    box(sc_.quads, at_height(base, y0 + h.y()), ax, h, cls, side, top, front, y0 > 0.01);
    // Footprint of the turned box.
    const double ex = std::abs(std::cos(yaw)) * h.x() + std::abs(std::sin(yaw)) * h.z();
    const double ez = std::abs(std::sin(yaw)) * h.x() + std::abs(std::cos(yaw)) * h.z();
    return {base.x() - ex, base.y() - ez, base.x() + ex, base.y() + ez};
  }

  static Matrix3d yaw_axes(double yaw) {
    Matrix3d ax;
    ax.col(0) = Vector3d(std::cos(yaw), 0, -std::sin(yaw));
    ax.col(1) = kUp;
    ax.col(2) = Vector3d(std::sin(yaw), 0, std::cos(yaw));
    return ax;
  }

  /// A vertical wall from A to B (XZ) between heights y0 and y1, seen from the side `inward`.
  void wall(Vector2d A, Vector2d B, const Vector2d& inward, double y0, double y1, std::uint8_t cls, int mat,
            double tex_s = 0.0) {
    Vector2d u = (B - A).normalized();
    if (right_of(u).dot(inward) < 0) {  // the normal u x up is right_of(u) in XZ; it must point inwards
      std::swap(A, B);
      u = -u;
    }
    const double len = (B - A).norm();
    quad(at_height((A + B) / 2, (y0 + y1) / 2), at_height(u, 0), kUp, len / 2, (y1 - y0) / 2, cls, mat,
         Vector2d(tex_s, y0));
  }

  /// A flat rectangle on a wall: wall line starts at A with direction u (XZ) and inward normal n;
  /// left edge at `along`, bottom at y0, size w x h, `off` metres in front of the wall.
  void decal(const Vector2d& A, const Vector2d& u, const Vector2d& n, double along, double y0, double w, double h,
             int mat, double off = 0.01) {
    const Vector2d c = A + u * (along + w / 2) + n * off;
    Vector3d u3 = at_height(u, 0);
    if (u3.cross(kUp).dot(at_height(n, 0)) < 0) u3 = -u3;
    quad(at_height(c, y0 + h / 2), u3, kUp, w / 2, h / 2, kWall, mat);
  }

 private:
  Scene& sc_;
  Rng& rng_;
};

// ---------------------------------------------------------------------------------------------
// Materials.

Material mat(Material::Kind kind, std::array<float, 3> a, std::array<float, 3> b = {0.3f, 0.3f, 0.3f},
             std::array<float, 3> c = {0.05f, 0.05f, 0.05f}, float scale = 0.5f, float scale2 = 0.0f) {
  Material m;
  m.kind = kind;
  m.a = a;
  m.b = b;
  m.c = c;
  m.scale = scale;
  m.scale2 = scale2;
  return m;
}

std::array<float, 3> pastel(Rng& r) {
  static const double kWalls[][3] = {{0.86, 0.84, 0.78}, {0.80, 0.84, 0.86}, {0.88, 0.82, 0.70},
                                     {0.78, 0.84, 0.76}, {0.90, 0.88, 0.84}, {0.84, 0.78, 0.76}};
  const auto& c = kWalls[r.index(6)];
  return lin(c[0], c[1], c[2]);
}

int poster_material(Builder& b, double w, double h) {
  Rng& r = b.rng();
  const double paper = r.uniform(0.85, 0.97);
  return b.material(mat(Material::Poster, lin(paper, paper, paper * r.uniform(0.9, 1.0)), {0, 0, 0},
                        lin(0.08, 0.08, 0.1), static_cast<float>(w), static_cast<float>(h)));
}

int door_material(Builder& b) {
  Rng& r = b.rng();
  static const double kDoors[][3] = {{0.55, 0.36, 0.20}, {0.62, 0.45, 0.28}, {0.35, 0.45, 0.60}, {0.75, 0.72, 0.65},
                                     {0.50, 0.20, 0.15}};
  const auto& c = kDoors[r.index(5)];
  Material m = mat(Material::Door, lin(c[0], c[1], c[2]), lin(0.25, 0.22, 0.2), lin(0.7, 0.7, 0.72), 0.9f, 2.05f);
  m.seed = static_cast<std::uint32_t>(r.next()) | 1u;
  if (r.chance(0.4)) m.seed &= ~1u;  // even seed: painted, odd: wood grain
  return b.material(m);
}

int cardboard_material(Builder& b, double h) {
  Rng& r = b.rng();
  const double k = r.uniform(0.85, 1.1);
  return b.material(mat(Material::Cardboard, lin(0.62 * k, 0.46 * k, 0.30 * k), lin(0.78, 0.68, 0.5),
                        lin(0.05, 0.05, 0.05), 0.5f, static_cast<float>(h)));
}

// ---------------------------------------------------------------------------------------------
// Camera path.

void finish_path(CameraPath& p) {
  p.arc.assign(p.points.size(), 0.0);
  for (std::size_t i = 1; i < p.points.size(); ++i) p.arc[i] = p.arc[i - 1] + (p.points[i] - p.points[i - 1]).norm();
}

double path_length(const CameraPath& p) {
  return p.arc.back() + (p.closed ? (p.points.front() - p.points.back()).norm() : 0.0);
}

Vector2d path_point(const CameraPath& p, double s) {
  const double total = path_length(p);
  if (p.closed) {
    s = std::fmod(s, total);
    if (s < 0) s += total;
    if (s >= p.arc.back()) {  // on the closing segment
      const double seg = total - p.arc.back();
      const double w = seg > 0 ? (s - p.arc.back()) / seg : 0.0;
      return p.points.back() + w * (p.points.front() - p.points.back());
    }
  } else {
    s = std::clamp(s, 0.0, p.arc.back());
  }
  auto it = std::upper_bound(p.arc.begin(), p.arc.end(), s);
  std::size_t i = static_cast<std::size_t>(it - p.arc.begin());
  if (i == 0) return p.points.front();
  if (i >= p.points.size()) return p.points.back();
  const double seg = p.arc[i] - p.arc[i - 1];
  const double w = seg > 0 ? (s - p.arc[i - 1]) / seg : 0.0;
  return p.points[i - 1] + w * (p.points[i] - p.points[i - 1]);
}

Vector2d path_tangent(const CameraPath& p, double s, double half = 0.25) {
  const Vector2d d = path_point(p, s + half) - path_point(p, s - half);
  return d.norm() > 1e-9 ? Vector2d(d.normalized()) : Vector2d(0, 1);
}

/// Curvature (1/m) of the path around arc length s, averaged over +-0.4 m.
double path_curvature(const CameraPath& p, double s) {
  double sum = 0;
  const int n = 5;
  for (int k = -n; k <= n; ++k) {
    const double sk = s + 0.08 * k;
    const Vector2d a = path_tangent(p, sk - 0.15, 0.1), b = path_tangent(p, sk + 0.15, 0.1);
    const double cross = a.x() * b.y() - a.y() * b.x();
    sum += std::abs(std::atan2(cross, a.dot(b))) / 0.3;
  }
  return sum / (2 * n + 1);
}

/// Arc length at every frame: the robot's speed varies smoothly (+-25%) and slows down in turns.
void integrate_speed(CameraPath& p, const SynthOptions& o, double s_start) {
  Rng r(detail::hash(o.seed, kSpeed));
  const double ph1 = r.uniform(0, 2 * kPi), ph2 = r.uniform(0, 2 * kPi);
  auto v = [&](double t, double s) {
    const double k = 1.0 + 0.2 * std::sin(2 * kPi * t / 7.3 + ph1) + 0.06 * std::sin(2 * kPi * t / 2.9 + ph2);
    const double turn = 1.0 - 0.35 * std::clamp(path_curvature(p, s) * 0.9, 0.0, 1.0);
    return o.speed * k * turn;
  };
  p.frame_arc.resize(o.frames);
  const double dt = 1.0 / o.fps;
  const int sub = 4;
  double s = s_start;
  for (int f = 0; f < o.frames; ++f) {
    p.frame_arc[f] = s;
    for (int k = 0; k < sub; ++k) s += v((f + (k + 0.5) / sub) * dt, s) * dt / sub;
  }
}

// ---------------------------------------------------------------------------------------------
// People.

struct PersonState {
  Vector2d pos, forward;
  double walked = 0;
};

PersonState person_state(const Person& p, double time) {
  const Vector2d ab = p.b - p.a;
  const double len = std::max(ab.norm(), 1e-6);
  const double walked = p.speed * (time + p.phase);
  double m = std::fmod(walked, 2 * len);
  if (m < 0) m += 2 * len;
  PersonState st;
  st.walked = walked;
  if (m < len) {
    st.pos = p.a + ab * (m / len);
    st.forward = ab / len;
  } else {
    st.pos = p.b - ab * ((m - len) / len);
    st.forward = -ab / len;
  }
  return st;
}

void person_quads(const Person& p, double time, std::vector<Quad>& out) {
  const PersonState st = person_state(p, time);
  const double s = p.height / 1.75;
  const double yaw = std::atan2(st.forward.x(), st.forward.y());
  const Matrix3d ax = Builder::yaw_axes(yaw);
  const Vector3d ex = ax.col(0);
  const double cycle = 2 * kPi * st.walked / 1.3;  // one stride cycle per 1.3 m
  const double swing = 0.42 * std::sin(cycle);
  const double bob = 0.02 * s * std::abs(std::cos(cycle));
  const Vector3d base = at_height(st.pos, bob);
  auto limb = [&](const Vector3d& joint, double angle, const Vector3d& half, int material) {
    const Matrix3d la = Eigen::AngleAxisd(angle, ex).toRotationMatrix() * ax;
    Builder::box(out, joint + la * Vector3d(0, -half.y(), 0), la, half, kPerson, material, material, material, true);
  };
  const double leg = 0.88 * s;
  limb(base + kUp * leg + ex * (0.1 * s), swing, Vector3d(0.075, 0.44, 0.085) * s, p.trousers);
  limb(base + kUp * leg - ex * (0.1 * s), -swing, Vector3d(0.075, 0.44, 0.085) * s, p.trousers);
  Builder::box(out, base + kUp * (1.165 * s), ax, Vector3d(0.19, 0.29, 0.11) * s, kPerson, p.shirt, p.shirt, p.shirt, true);
  limb(base + kUp * (1.42 * s) + ex * (0.245 * s), -0.7 * swing, Vector3d(0.045, 0.3, 0.05) * s, p.shirt);
  limb(base + kUp * (1.42 * s) - ex * (0.245 * s), 0.7 * swing, Vector3d(0.045, 0.3, 0.05) * s, p.shirt);
  Builder::box(out, base + kUp * (1.635 * s), ax, Vector3d(0.085, 0.115, 0.1) * s, kPerson, p.skin, p.skin, p.skin, true);
  Builder::box(out, base + kUp * (1.735 * s) - ax.col(2) * (0.01 * s), ax, Vector3d(0.092, 0.025, 0.105) * s, kPerson,
        p.hair, p.hair, p.hair, true);
}

Person make_person(Builder& b, const Vector2d& a, const Vector2d& bb) {
  Rng& r = b.rng();
  Person p;
  p.a = a;
  p.b = bb;
  p.speed = r.uniform(0.9, 1.2);
  p.height = r.uniform(1.62, 1.86);
  static const double kShirts[][3] = {{0.7, 0.1, 0.1}, {0.15, 0.3, 0.65}, {0.9, 0.9, 0.88}, {0.2, 0.5, 0.25},
                                      {0.85, 0.6, 0.1}, {0.3, 0.3, 0.32}, {0.55, 0.25, 0.55}};
  const auto& c = kShirts[r.index(7)];
  Material shirt = mat(Material::Fabric, lin(c[0], c[1], c[2]), lin(c[0] * 0.4, c[1] * 0.4, c[2] * 0.4));
  shirt.scale2 = r.chance(0.4) ? static_cast<float>(r.uniform(0.03, 0.08)) : 0.0f;
  p.shirt = b.material(shirt);
  static const double kTrousers[][3] = {{0.12, 0.15, 0.3}, {0.08, 0.08, 0.09}, {0.55, 0.48, 0.35}, {0.3, 0.3, 0.32}};
  const auto& t = kTrousers[r.index(4)];
  p.trousers = b.material(mat(Material::Fabric, lin(t[0], t[1], t[2])));
  static const double kSkin[][3] = {{0.92, 0.75, 0.62}, {0.75, 0.55, 0.4}, {0.45, 0.3, 0.2}, {0.85, 0.65, 0.5}};
  const auto& k = kSkin[r.index(4)];
  p.skin = b.material(mat(Material::Plain, lin(k[0], k[1], k[2])));
  static const double kHair[][3] = {{0.08, 0.06, 0.05}, {0.3, 0.2, 0.1}, {0.6, 0.5, 0.3}, {0.5, 0.5, 0.5}};
  const auto& h = kHair[r.index(4)];
  p.hair = b.material(mat(Material::Fabric, lin(h[0], h[1], h[2])));
  return p;
}

/// Chooses the person's phase so that they never come closer than min_dist to the camera (or as far as
/// the candidates allow).
void choose_phase(Person& p, const Scene& sc, const SynthOptions& o, Rng& r, double min_dist) {
  const double period = 2 * (p.b - p.a).norm() / p.speed;
  const double u0 = r.uniform();
  double best = -1, best_phase = 0;
  std::vector<Vector2d> cam(o.frames);
  for (int f = 0; f < o.frames; ++f) {
    const Pose pose = camera_pose(sc, o, f);
    cam[f] = Vector2d(pose.t[0], pose.t[2]);
  }
  for (int j = 0; j < 48; ++j) {
    const double frac = std::fmod(u0 + 0.6180339887 * j, 1.0);
    p.phase = frac * period;
    double closest = std::numeric_limits<double>::infinity();
    for (int f = 0; f < o.frames && closest > best; ++f)
      closest = std::min(closest, (person_state(p, frame_time(o, f)).pos - cam[f]).norm());
    if (closest > best) {
      best = closest;
      best_phase = p.phase;
    }
    if (best >= min_dist) break;
  }
  p.phase = best_phase;
}

// ---------------------------------------------------------------------------------------------
// Placement tests.

struct Keepout {
  const CameraPath* path = nullptr;
  std::vector<std::pair<Vector2d, Vector2d>> segments;  // people's walking lines
  std::vector<Footprint> taken;
  double ahead_clear = 0.4;  ///< clearance from the floor 1.7-2.4 m ahead of the robot

  double path_distance(const Footprint& f) const {
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < path->points.size(); i += 4) d = std::min(d, f.distance(path->points[i]));
    return d;
  }
  bool ok(const Footprint& f, double cam_clear, double person_clear, double margin) const {
    for (const auto& t : taken)
      if (f.overlaps(t, margin)) return false;
    for (const auto& [a, b] : segments) {
      // Distance from the footprint to the segment, sampled.
      for (int k = 0; k <= 40; ++k) {
        const Vector2d p = a + (b - a) * (k / 40.0);
        if (f.distance(p) < person_clear) return false;
      }
    }
    return path_distance(f) >= cam_clear && ahead_distance(f) >= ahead_clear;
  }
  /// Distance to the floor points 1.7-2.4 m ahead of the robot (what the bottom of the image sees).
  double ahead_distance(const Footprint& f) const {
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < path->points.size(); i += 8) {
      const Vector2d t = path_tangent(*path, path->arc[i]);
      for (double ahead : {1.7, 2.05, 2.4}) d = std::min(d, f.distance(path->points[i] + t * ahead));
    }
    return d;
  }
};

/// A box or a bin standing at pos, no wider or deeper than max_size.
void add_obstacle(Builder& b, const Vector2d& pos, double yaw, double max_size, Keepout& keep) {
  Rng& r = b.rng();
  const double kind = r.uniform();
  Footprint fp{};
  if (kind < 0.65) {  // cardboard box, sometimes with a second one on top
    const Vector3d size(r.uniform(0.3, std::min(0.6, max_size)), r.uniform(0.25, 0.55),
                        r.uniform(0.3, std::min(0.5, max_size)));
    const int m = cardboard_material(b, size.y());
    fp = b.floor_box(pos, 0.0, yaw, size, kObstacle, m, m, m);
    if (r.chance(0.35)) {
      const Vector3d s2(size.x() * r.uniform(0.6, 0.9), r.uniform(0.2, 0.4), size.z() * r.uniform(0.6, 0.9));
      const int m2 = cardboard_material(b, s2.y());
      b.floor_box(pos, size.y(), yaw + r.uniform(-0.3, 0.3), s2, kObstacle, m2, m2, m2);
    }
  } else {  // waste bin / recycling bin
    static const double kBins[][3] = {{0.15, 0.3, 0.6}, {0.3, 0.3, 0.32}, {0.2, 0.5, 0.25}, {0.7, 0.7, 0.68}};
    const auto& c = kBins[r.index(4)];
    const Vector3d size(r.uniform(0.3, std::min(0.45, max_size)), r.uniform(0.45, 0.7),
                        r.uniform(0.3, std::min(0.45, max_size)));
    const int side = b.material(mat(Material::Plain, lin(c[0], c[1], c[2])));
    const int top = b.material(mat(Material::Plain, lin(c[0] * 0.25, c[1] * 0.25, c[2] * 0.25)));
    fp = b.floor_box(pos, 0.0, yaw, size, kObstacle, side, top, side);
  }
  keep.taken.push_back(fp);
}

/// Footprint of a box of width w (along the wall) and depth d standing against a wall.
Footprint wall_footprint(const Vector2d& A, const Vector2d& u, const Vector2d& n, double along, double w, double d,
                         double off) {
  const Vector2d p0 = A + u * along + n * off, p1 = A + u * (along + w) + n * (off + d);
  return {std::min(p0.x(), p1.x()), std::min(p0.y(), p1.y()), std::max(p0.x(), p1.x()), std::max(p0.y(), p1.y())};
}

/// Furniture against a wall: the piece's front faces the room (direction n). Returns false when the
/// piece would block the robot's path or a person's line.
bool wall_furniture(Builder& b, Keepout& keep, const Vector2d& A, const Vector2d& u, const Vector2d& n, double along,
                    int kind, double& width) {
  Rng& r = b.rng();
  const double yaw = std::atan2(n.x(), n.y());
  const Matrix3d ax = Builder::yaw_axes(yaw);
  Scene& sc = b.scene();
  auto centre_at = [&](double w, double d) { return Vector2d(A + u * (along + w / 2) + n * (0.02 + d / 2)); };
  const int wood = b.material(mat(Material::Wood, lin(0.62, 0.45, 0.3), lin(0.45, 0.3, 0.18)));
  if (kind == 0) {  // desk with a monitor, and a chair in front
    width = r.uniform(1.2, 1.6);
    const double d = 0.7, h = 0.74;
    const Footprint fp = wall_footprint(A, u, n, along, width, d + 0.6, 0.02);
    if (!keep.ok(fp, 0.55, 0.45, 0.05)) return false;
    keep.taken.push_back(fp);
    const Vector2d c = centre_at(width, d);
    const int metal = b.material(mat(Material::Plain, lin(0.3, 0.3, 0.32)));
    b.box(sc.quads, at_height(c, h - 0.015), ax, Vector3d(width / 2, 0.015, d / 2), kFurniture, wood, wood, wood, true);
    for (int side = -1; side <= 1; side += 2) {
      const Vector2d leg = c + side * u * (width / 2 - 0.03);
      b.box(sc.quads, at_height(leg, (h - 0.03) / 2), ax, Vector3d(0.02, (h - 0.03) / 2, d / 2 - 0.02), kFurniture,
            metal, metal, metal, false);
    }
    b.box(sc.quads, at_height(c - n * (d / 2 - 0.05), 0.45), ax, Vector3d(width / 2 - 0.05, 0.25, 0.01), kFurniture,
          metal, metal, metal, true);
    // Monitor on a stand.
    const double mw = r.uniform(0.45, 0.6), mh = mw * 0.62;
    const Vector2d mc = c + u * r.uniform(-0.25, 0.25) * (width - mw) - n * 0.12;
    const int screen = b.material(mat(Material::Screen, lin(0.15, 0.3, 0.5), lin(0.85, 0.85, 0.9),
                                      lin(0.03, 0.03, 0.035), static_cast<float>(mw), static_cast<float>(mh)));
    sc.materials[screen].emission = 0.5f;
    const int plastic = b.material(mat(Material::Plain, lin(0.06, 0.06, 0.07)));
    b.box(sc.quads, at_height(mc, h + 0.05), ax, Vector3d(0.03, 0.05, 0.03), kFurniture, plastic, plastic, plastic,
          false);
    b.box(sc.quads, at_height(mc, h + 0.1 + mh / 2), ax, Vector3d(mw / 2, mh / 2, 0.025), kFurniture, plastic, plastic,
          screen, true);
    // Chair: base, post, seat, back.
    const Vector2d cc = c + n * (d / 2 + 0.3) + u * r.uniform(-0.2, 0.2);
    const double cyaw = yaw + kPi + r.uniform(-0.5, 0.5);
    const Matrix3d cax = Builder::yaw_axes(cyaw);
    static const double kFabric[][3] = {{0.1, 0.1, 0.12}, {0.15, 0.2, 0.45}, {0.45, 0.1, 0.1}, {0.25, 0.25, 0.25}};
    const auto& fc = kFabric[r.index(4)];
    const int fabric = b.material(mat(Material::Fabric, lin(fc[0], fc[1], fc[2])));
    b.box(sc.quads, at_height(cc, 0.04), cax, Vector3d(0.28, 0.04, 0.04), kFurniture, plastic, plastic, plastic, false);
    b.box(sc.quads, at_height(cc, 0.04), cax, Vector3d(0.04, 0.04, 0.28), kFurniture, plastic, plastic, plastic, false);
    b.box(sc.quads, at_height(cc, 0.25), cax, Vector3d(0.03, 0.17, 0.03), kFurniture, metal, metal, metal, false);
    b.box(sc.quads, at_height(cc, 0.46), cax, Vector3d(0.23, 0.04, 0.23), kFurniture, fabric, fabric, fabric, true);
    const Vector2d back = cc - Vector2d(cax(0, 2), cax(2, 2)) * 0.22;
    b.box(sc.quads, at_height(back, 0.78), cax, Vector3d(0.21, 0.24, 0.03), kFurniture, fabric, fabric, fabric, true);
  } else if (kind == 1) {  // bookshelf: solid box whose front shows shelves and books
    width = r.uniform(0.8, 1.0);
    const double d = 0.35, h = r.uniform(1.7, 2.0);
    const Footprint fp = wall_footprint(A, u, n, along, width, d, 0.02);
    if (!keep.ok(fp, 0.55, 0.45, 0.02)) return false;
    keep.taken.push_back(fp);
    const int books = b.material(mat(Material::Books, lin(0.55, 0.4, 0.26), {0, 0, 0}, lin(0.04, 0.03, 0.02),
                                     static_cast<float>(width), static_cast<float>(h)));
    b.floor_box(centre_at(width, d), 0.0, yaw, Vector3d(width, h, d), kFurniture, wood, wood, books);
  } else if (kind == 2) {  // filing cabinet or sideboard with drawers
    const bool tall = r.chance(0.5);
    width = tall ? 0.5 : r.uniform(0.9, 1.3);
    const double d = tall ? 0.6 : 0.45, h = tall ? 1.3 : r.uniform(0.75, 0.9);
    const Footprint fp = wall_footprint(A, u, n, along, width, d, 0.02);
    if (!keep.ok(fp, 0.55, 0.45, 0.02)) return false;
    keep.taken.push_back(fp);
    static const double kMetal[][3] = {{0.7, 0.7, 0.68}, {0.55, 0.6, 0.62}, {0.8, 0.76, 0.66}, {0.35, 0.38, 0.42}};
    const auto& mc = kMetal[r.index(4)];
    const int body = b.material(mat(Material::Plain, lin(mc[0], mc[1], mc[2])));
    const int front = b.material(mat(Material::Drawers, lin(mc[0], mc[1], mc[2]), lin(0.1, 0.1, 0.1),
                                     lin(0.05, 0.05, 0.05), tall ? 0.32f : 0.25f, static_cast<float>(width)));
    b.floor_box(centre_at(width, d), 0.0, yaw, Vector3d(width, h, d), kFurniture, body, tall ? body : wood, front);
  } else {  // bench
    width = r.uniform(1.2, 1.6);
    const double d = 0.38, h = 0.45;
    const Footprint fp = wall_footprint(A, u, n, along, width, d, 0.02);
    if (!keep.ok(fp, 0.5, 0.4, 0.02)) return false;
    keep.taken.push_back(fp);
    b.floor_box(centre_at(width, d), 0.0, yaw, Vector3d(width, h, d), kFurniture, wood, wood, wood);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Lights.

void ceiling_light(Builder& b, const Vector2d& c, const Vector2d& along, double H, float intensity, int panel) {
  b.quad(at_height(c, H - 0.004), at_height(right_of(along), 0), at_height(along, 0), 0.3, 0.6, kCeiling, panel);
  // quad normal = u x v must point down: right x along in this frame is -Y.
  Quad& q = b.scene().quads.back();
  if (q.normal.y() > 0) {
    q.u = -q.u;
    q.normal = q.u.cross(q.v);
  }
  Light l;
  l.position = at_height(c, H - 0.25);
  l.intensity = {intensity, intensity * 0.98f, intensity * 0.93f};
  b.scene().lights.push_back(l);
}

int light_material(Builder& b, float emission) {
  Material m = mat(Material::Light, lin(0.98, 0.98, 0.96), lin(0.6, 0.6, 0.6), {0, 0, 0}, 0.6f, 1.2f);
  m.emission = emission;
  return b.material(m);
}

// ---------------------------------------------------------------------------------------------
// The corridor.

// A room's floor (carpet with probability `carpet`, else tiles) and tiled ceiling: x in [-RX, RX],
// z in [-RZ, RZ], ceiling at height H.
void room_floor_and_ceiling(Builder& b, Rng& r, double carpet, double RX, double RZ, double H) {
  int floor_mat;
  if (r.chance(carpet)) {
    static const double kCarpet[][3] = {{0.35, 0.38, 0.45}, {0.45, 0.4, 0.35}, {0.3, 0.4, 0.35}};
    const auto& c = kCarpet[r.index(3)];
    floor_mat = b.material(mat(Material::Carpet, lin(c[0], c[1], c[2]), lin(c[0] * 0.7, c[1] * 0.7, c[2] * 0.7),
                               {0, 0, 0}, 0.5f));
  } else {
    floor_mat = b.material(mat(Material::Tiles, lin(0.75, 0.74, 0.7), lin(0.55, 0.58, 0.6), lin(0.4, 0.4, 0.38), 0.3f));
  }
  b.quad(Vector3d(0, 0, 0), Vector3d(0, 0, 1), Vector3d(1, 0, 0), RZ, RX, kFloor, floor_mat, Vector2d(-RZ, -RX));
  const int ceil_mat = b.material(mat(Material::CeilingTiles, lin(0.9, 0.9, 0.88), lin(0.72, 0.72, 0.72), {0, 0, 0}, 0.6f));
  b.quad(Vector3d(0, H, 0), Vector3d(1, 0, 0), Vector3d(0, 0, 1), RX, RZ, kCeiling, ceil_mat, Vector2d(-RX, -RZ));
}

void build_corridor(Scene& sc, const SynthOptions& o, Rng& r) {
  Builder b(sc, r);
  const double W = 2.4, H = 2.6, h = W / 2, r_turn = 1.0, behind = 2.5, keep_right = 0.3;
  sc.ceiling_height = H;
  sc.ambient = 0.3f;

  // Centre line: straight segments with 90-degree turns, alternating sides.
  const double travel = o.frames / o.fps * o.speed * 1.3 + 0.5;
  const double need = behind + travel + 8.0;
  std::vector<Vector2d> V{Vector2d(0, -behind)};
  Vector2d dir(0, 1);
  int turn = r.chance(0.5) ? 1 : -1;
  double total = 0;
  for (int k = 0; total < need; ++k) {
    double L = k == 0 ? behind + r.uniform(3.5, 4.5) : (k == 1 ? r.uniform(3.5, 4.5) : r.uniform(3.5, 5.5));
    L = std::round(L * 10.0) / 10.0;  // the walls are traced on a 0.1 m grid
    V.push_back(V.back() + dir * L);
    total += L;
    dir = turn > 0 ? right_of(dir) : Vector2d(-right_of(dir));
    turn = -turn;
  }
  const int n = static_cast<int>(V.size()) - 1;  // segments
  std::vector<Vector2d> D(n);
  for (int k = 0; k < n; ++k) D[k] = (V[k + 1] - V[k]).normalized();

  // Camera path: the centre line with arcs at the corners, offset to the right.
  std::vector<Vector2d> centre;
  auto straight = [&](const Vector2d& a, const Vector2d& c) {
    const double len = (c - a).norm();
    const int steps = std::max(1, static_cast<int>(len / 0.01));
    for (int i = 0; i < steps; ++i) centre.push_back(a + (c - a) * (static_cast<double>(i) / steps));
  };
  Vector2d cur = V[0];
  for (int i = 1; i < n; ++i) {
    const Vector2d t1 = V[i] - D[i - 1] * r_turn, t2 = V[i] + D[i] * r_turn;
    straight(cur, t1);
    const Vector2d C = V[i] - D[i - 1] * r_turn + D[i] * r_turn;
    const int steps = static_cast<int>(0.5 * kPi * r_turn / 0.01);
    for (int j = 0; j < steps; ++j) {
      const double phi = 0.5 * kPi * j / steps;
      centre.push_back(C + (t1 - C) * std::cos(phi) + (t2 - C) * std::sin(phi));
    }
    cur = t2;
  }
  straight(cur, V[n]);
  centre.push_back(V[n]);
  CameraPath& path = sc.path;
  path.closed = false;
  path.points.resize(centre.size());
  for (std::size_t i = 0; i < centre.size(); ++i) {
    const Vector2d a = centre[i > 0 ? i - 1 : i], c = centre[std::min(i + 1, centre.size() - 1)];
    path.points[i] = centre[i] + right_of((c - a).normalized()) * keep_right;
  }
  finish_path(path);
  integrate_speed(path, o, behind);

  // People walk along the left side of a segment, back and forth.
  Keepout keep;
  keep.path = &path;
  keep.ahead_clear = 0.3;
  Rng pr(detail::hash(o.seed, kPeople));
  std::vector<int> person_segments{0};
  if (n > 2) person_segments.push_back(2);
  else if (n > 1) person_segments.push_back(1);
  for (int k : person_segments) {
    const Vector2d left = -right_of(D[k]) * 0.5;
    const double L = (V[k + 1] - V[k]).norm();
    const double start = k == 0 ? behind + 0.8 : 1.2, end = k == 0 ? L - 0.4 : L - 1.2;
    if (end - start < 1.5) continue;
    Person p = make_person(b, V[k] + D[k] * start + left, V[k] + D[k] * end + left);
    choose_phase(p, sc, o, pr, 0.6);
    keep.segments.emplace_back(p.a, p.b);
    sc.people.push_back(p);
  }

  // Walls: the boundary of the union of the corridor's rectangles (the segments, plus a dead end
  // continuing straight on past every turn, so that the robot sees down it while turning), traced on a
  // 0.1 m grid (every coordinate is a multiple of it).
  const double g = 0.1;
  std::vector<Footprint> rects;
  auto rect = [&](const Vector2d& p, const Vector2d& q) {
    rects.push_back({std::min(p.x(), q.x()) - h, std::min(p.y(), q.y()) - h, std::max(p.x(), q.x()) + h,
                     std::max(p.y(), q.y()) + h});
  };
  for (int k = 0; k < n; ++k) {
    rect(V[k], V[k + 1]);
    if (k + 1 < n) rect(V[k + 1], V[k + 1] + D[k] * (std::round(r.uniform(1.5, 3.0) / g) * g));
  }
  double ox = 1e9, oz = 1e9, ex = -1e9, ez = -1e9;
  for (const auto& f : rects) {
    ox = std::min(ox, f.x0);
    oz = std::min(oz, f.z0);
    ex = std::max(ex, f.x1);
    ez = std::max(ez, f.z1);
  }
  const int nx = static_cast<int>(std::lround((ex - ox) / g)), nz = static_cast<int>(std::lround((ez - oz) / g));
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(nx) * nz, 0);
  for (const auto& f : rects) {
    const int i0 = static_cast<int>(std::lround((f.x0 - ox) / g)), i1 = static_cast<int>(std::lround((f.x1 - ox) / g));
    const int j0 = static_cast<int>(std::lround((f.z0 - oz) / g)), j1 = static_cast<int>(std::lround((f.z1 - oz) / g));
    for (int i = i0; i < i1; ++i)
      for (int j = j0; j < j1; ++j) occ[static_cast<std::size_t>(i) * nz + j] = 1;
  }
  auto inside = [&](int i, int j) { return i >= 0 && j >= 0 && i < nx && j < nz && occ[static_cast<std::size_t>(i) * nz + j]; };
  struct WallRun {
    Vector2d A, B, inward;
  };
  std::vector<WallRun> runs;
  for (int i = 0; i <= nx; ++i) {  // walls of constant x
    int start = -1, sign = 0;
    for (int j = 0; j <= nz; ++j) {
      const int sj = j < nz ? (inside(i, j) != inside(i - 1, j) ? (inside(i, j) ? 1 : -1) : 0) : 0;
      if (sj != sign) {
        if (sign != 0) runs.push_back({{ox + i * g, oz + start * g}, {ox + i * g, oz + j * g}, {double(sign), 0.0}});
        start = j;
        sign = sj;
      }
    }
  }
  for (int j = 0; j <= nz; ++j) {  // walls of constant z
    int start = -1, sign = 0;
    for (int i = 0; i <= nx; ++i) {
      const int si = i < nx ? (inside(i, j) != inside(i, j - 1) ? (inside(i, j) ? 1 : -1) : 0) : 0;
      if (si != sign) {
        if (sign != 0) runs.push_back({{ox + start * g, oz + j * g}, {ox + i * g, oz + j * g}, {0.0, double(sign)}});
        start = i;
        sign = si;
      }
    }
  }
  // Floor and ceiling: one quad each over the bounding box.
  {
    const Vector3d mid((ox + ex) / 2, 0, (oz + ez) / 2);
    const double hx = (ex - ox) / 2 + 0.1, hz = (ez - oz) / 2 + 0.1;
    int floor_mat;
    if (r.chance(0.6)) {
      const double grey = r.uniform(0.6, 0.75);
      floor_mat = b.material(mat(Material::Tiles, lin(grey, grey, grey * 0.97),
                                 lin(grey * 0.75, grey * 0.72, grey * 0.68), lin(0.35, 0.35, 0.33),
                                 static_cast<float>(r.chance(0.5) ? 0.3 : 0.5)));
    } else {
      floor_mat = b.material(mat(Material::Carpet, lin(0.42, 0.42, 0.45), lin(0.3, 0.3, 0.34), {0, 0, 0}, 0.5f));
    }
    b.quad(mid, Vector3d(0, 0, 1), Vector3d(1, 0, 0), hz, hx, kFloor, floor_mat,
           Vector2d(mid.z() - hz, mid.x() - hx));
    const int ceil_mat =
        b.material(mat(Material::CeilingTiles, lin(0.88, 0.88, 0.86), lin(0.7, 0.7, 0.7), {0, 0, 0}, 0.6f));
    b.quad(mid + kUp * H, Vector3d(1, 0, 0), Vector3d(0, 0, 1), hx, hz, kCeiling, ceil_mat,
           Vector2d(mid.x() - hx, mid.z() - hz));
  }
  for (const WallRun& w : runs) {
    const Vector2d& inward = w.inward;
    const double len = (w.B - w.A).norm();
    int wall_mat;
    if (r.chance(0.6)) {
      wall_mat = b.material(mat(Material::Plain, pastel(r), lin(0.2, 0.18, 0.16), {0, 0, 0}, 0.5f, 0.1f));
    } else {
      const auto c = pastel(r);
      wall_mat = b.material(mat(Material::Blocks, c, {0, 0, 0}, {c[0] * 0.7f, c[1] * 0.7f, c[2] * 0.7f}, 0.4f, 0.2f));
    }
    b.wall(w.A, w.B, inward, 0.0, H, kWall, wall_mat);
    const Vector2d A = w.A, u = (w.B - w.A) / len;
    for (double a = 0.6 + r.uniform(0, 1.0); a < len - 0.6;) {
      const double what = r.uniform();
      if (what < 0.3 && a + 0.9 < len - 0.4) {
        b.decal(A, u, inward, a, 0.0, 0.9, 2.05, door_material(b));
        a += 0.9;
      } else if (what < 0.75) {
        const double pw = r.uniform(0.45, 0.8), ph = r.uniform(0.6, 1.0);
        if (a + pw > len - 0.4) break;
        b.decal(A, u, inward, a, 1.45 - ph / 2 + r.uniform(-0.1, 0.15), pw, ph, poster_material(b, pw, ph));
        a += pw;
      } else if (what < 0.85) {
        const double pw = 1.2, ph = 0.9;
        if (a + pw > len - 0.4) break;
        b.decal(A, u, inward, a, 1.0, pw, ph, poster_material(b, pw, ph));
        a += pw;
      } else {
        a += 1.0;
      }
      a += r.uniform(0.4, 1.6);
    }
    // Furniture against the wall, away from the corners.
    for (int tries = 0; tries < 3 && len > 3.0; ++tries) {
      const double along = r.uniform(0.8, len - 2.4);
      double width = 0;
      if (wall_furniture(b, keep, A, u, inward, along, r.chance(0.5) ? 2 : 3, width)) break;
    }
  }

  // Ceiling lights along the centre line; now and then a dim one.
  {
    double s = 1.0;
    const double spacing = 2.8;
    for (int k = 0; k < n; ++k) {
      const double L = (V[k + 1] - V[k]).norm();
      for (; s < L - 0.3; s += spacing) {
        const bool dim = r.chance(0.12);
        const int panel = light_material(b, dim ? 0.15f : 1.6f);
        ceiling_light(b, V[k] + D[k] * s, D[k], H, dim ? 0.15f : 0.85f, panel);
      }
      s -= L;
      if (s < 0.3) s = 0.3;
    }
  }

  // Obstacles on the floor near the walls.
  Rng orng(detail::hash(o.seed, kObjects));
  Builder ob(sc, orng);
  const int count = static_cast<int>(total / 2.0);
  const double max_size = 0.45, half = 0.5 * max_size * 1.15;  // 1.15: turned by up to 0.25 rad
  for (int i = 0; i < count; ++i) {
    for (int attempt = 0; attempt < 20; ++attempt) {
      const int k = orng.index(n);
      const double L = (V[k + 1] - V[k]).norm();
      if (L < 3.0) continue;
      const double along = orng.uniform(1.3, L - 1.3);
      const int side = orng.chance(0.5) ? 1 : -1;
      const double lateral = side * (h - 0.03 - half);
      const Vector2d pos = V[k] + D[k] * along + right_of(D[k]) * lateral;
      const Footprint probe{pos.x() - half, pos.y() - half, pos.x() + half, pos.y() + half};
      if (!keep.ok(probe, 0.35, 0.3, 0.05)) continue;
      add_obstacle(ob, pos, std::atan2(D[k].x(), D[k].y()) + orng.uniform(-0.25, 0.25), max_size, keep);
      break;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The lab.

void build_lab(Scene& sc, const SynthOptions& o, Rng& r) {
  Builder b(sc, r);
  const double RX = 4.5, RZ = 3.5, H = 2.8;
  sc.ceiling_height = H;
  sc.ambient = 0.28f;

  // Camera path: a wobbly ellipse around the middle of the room.
  CameraPath& path = sc.path;
  path.closed = true;
  const double a = 2.0, bz = 1.3;
  const double ph1 = r.uniform(0, 2 * kPi), ph2 = r.uniform(0, 2 * kPi), start = r.uniform(0, 2 * kPi);
  const double sense = r.chance(0.5) ? 1.0 : -1.0;
  const int N = 1400;
  for (int i = 0; i < N; ++i) {
    const double th = start + sense * 2 * kPi * i / N;
    path.points.emplace_back(a * std::cos(th) * (1 + 0.06 * std::sin(2 * th + ph1)),
                             bz * std::sin(th) * (1 + 0.06 * std::sin(3 * th + ph2)));
  }
  finish_path(path);
  integrate_speed(path, o, 0.0);

  // Room.
  room_floor_and_ceiling(b, r, 0.55, RX, RZ, H);
  for (double x : {-3.0, -1.0, 1.0, 3.0})
    for (double z : {-2.0, 0.0, 2.0}) {
      const bool dim = r.chance(0.08);
      ceiling_light(b, Vector2d(x, z), Vector2d(1, 0), H, dim ? 0.2f : 0.75f, light_material(b, dim ? 0.15f : 1.6f));
    }

  // Two people crossing the room (and the robot's path), back and forth.
  Keepout keep;
  keep.path = &path;
  Rng pr(detail::hash(o.seed, kPeople));
  const double ang0 = pr.uniform(0, kPi);
  for (int k = 0; k < 2; ++k) {
    const double ang = ang0 + k * (0.5 * kPi + pr.uniform(-0.4, 0.4));
    const Vector2d pa(2.6 * std::cos(ang), 1.75 * std::sin(ang));
    Person p = make_person(b, pa, -pa + Vector2d(pr.uniform(-0.4, 0.4), pr.uniform(-0.3, 0.3)));
    choose_phase(p, sc, o, pr, 0.8);
    keep.segments.emplace_back(p.a, p.b);
    sc.people.push_back(p);
  }

  // Walls with themes: desks, shelves, cabinets, board.
  struct WallDef {
    Vector2d A, u, n;
    double len;
  };
  const WallDef walls[4] = {{{RX, RZ}, {-1, 0}, {0, -1}, 2 * RX},
                            {{RX, -RZ}, {0, 1}, {-1, 0}, 2 * RZ},
                            {{-RX, -RZ}, {1, 0}, {0, 1}, 2 * RX},
                            {{-RX, RZ}, {0, -1}, {1, 0}, 2 * RZ}};
  int themes[4] = {0, 1, 2, 3};
  for (int i = 3; i > 0; --i) std::swap(themes[i], themes[r.index(i + 1)]);
  for (int w = 0; w < 4; ++w) {
    const WallDef& wd = walls[w];
    // Check that (u, n) matches the decal convention (room on the left of u).
    const int paint = b.material(mat(Material::Plain, pastel(r), lin(0.2, 0.18, 0.16), {0, 0, 0}, 0.5f, 0.1f));
    b.wall(wd.A, wd.A + wd.u * wd.len, wd.n, 0.0, H, kWall, paint);
    const int theme = themes[w];
    double door_at = -10;
    if (r.chance(theme == 3 ? 0.9 : 0.45)) {
      door_at = r.uniform(0.5, wd.len - 1.6);
      b.decal(wd.A, wd.u, wd.n, door_at, 0.0, 0.9, 2.05, door_material(b));
    }
    auto free_span = [&](double x0, double x1) { return x1 < door_at - 0.15 || x0 > door_at + 1.05; };
    if (theme == 3) {  // whiteboard and posters, low cabinets below
      const double bw = r.uniform(1.8, 2.4);
      for (int tries = 0; tries < 10; ++tries) {
        const double at = r.uniform(0.4, wd.len - bw - 0.4);
        if (!free_span(at, at + bw)) continue;
        const int m = b.material(mat(Material::Whiteboard, lin(0.93, 0.93, 0.92), lin(0.6, 0.6, 0.62),
                                     lin(0.02, 0.02, 0.02), static_cast<float>(bw), 1.1f));
        b.decal(wd.A, wd.u, wd.n, at, 0.95, bw, 1.1, m);
        break;
      }
    }
    // Furniture along the wall.
    const int kind_of_theme[4] = {0, 1, 2, 2};
    for (double at = 0.3 + r.uniform(0, 0.5); at < wd.len - 0.5;) {
      const int kind = theme == 3 && r.chance(0.5) ? 3 : kind_of_theme[theme];
      double width = kind == 0 ? 1.6 : 1.3;
      if (at + width > wd.len - 0.3 || !free_span(at, at + width)) {
        at += 0.3;
        continue;
      }
      if (theme == 3 && r.chance(0.5)) {
        at += 1.0;
        continue;
      }
      if (!wall_furniture(b, keep, wd.A, wd.u, wd.n, at, kind, width)) width = 0.6;
      at += width + (theme == 1 ? r.uniform(0.0, 0.25) : r.uniform(0.15, 0.8));
    }
    // Posters above furniture height.
    const int posters = theme == 1 ? 0 : 1 + r.index(3);
    for (int k = 0; k < posters; ++k) {
      const double pw = r.uniform(0.45, 0.8), ph = r.uniform(0.55, 0.85);
      const double at = r.uniform(0.3, wd.len - pw - 0.3);
      if (!free_span(at, at + pw)) continue;
      // Now and then a camera-calibration checkerboard instead of a poster (it is a vision lab).
      const int m = k == 0 && r.chance(0.3)
                        ? b.material(mat(Material::Checker, lin(0.92, 0.92, 0.9), lin(0.04, 0.04, 0.04), {0, 0, 0},
                                         static_cast<float>(pw / 8)))
                        : poster_material(b, pw, ph);
      b.decal(wd.A, wd.u, wd.n, at, 1.3 + r.uniform(0, 0.3), pw, ph, m, 0.01 + 0.002 * k);
    }
  }

  // Obstacles on the floor: some along the walls, some inside the robot's loop.
  Rng orng(detail::hash(o.seed, kObjects));
  Builder ob(sc, orng);
  const int count = 10 + orng.index(5);
  for (int i = 0; i < count; ++i) {
    for (int attempt = 0; attempt < 40; ++attempt) {
      const Vector2d pos(orng.uniform(-RX + 0.4, RX - 0.4), orng.uniform(-RZ + 0.4, RZ - 0.4));
      const double max_size = 0.6, half = 0.5 * max_size * std::sqrt(2.0);  // any turn
      const Footprint probe{pos.x() - half, pos.y() - half, pos.x() + half, pos.y() + half};
      if (!keep.ok(probe, 0.45, 0.35, 0.1)) continue;
      add_obstacle(ob, pos, orng.uniform(0, 2 * kPi), max_size, keep);
      break;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The tabletop: a room with a table in the middle, objects on it, the camera circling the table.

/// An upright cylinder standing at base (its bottom centre): a prism of `sides` faces whose edges lie on
/// the circle of radius r, and a disc lid of radius r.
void cylinder(std::vector<Quad>& out, const Vector3d& base, double r, double height, int sides, std::uint8_t cls,
              int side_mat, int top_mat) {
  const double half_w = r * std::sin(kPi / sides), apothem = r * std::cos(kPi / sides);
  for (int i = 0; i < sides; ++i) {
    const double th = 2 * kPi * (i + 0.5) / sides;
    const Vector3d n(std::cos(th), 0, std::sin(th));
    Quad q;
    q.centre = base + n * apothem + kUp * (height / 2);
    q.u = Vector3d(std::sin(th), 0, -std::cos(th));  // u x up = n: the face looks outwards
    q.v = kUp;
    q.normal = q.u.cross(q.v);
    q.hu = half_w;
    q.hv = height / 2;
    q.tex = Vector2d(2 * half_w * i, 0);  // the texture wraps around continuously
    q.cls = cls;
    q.material = side_mat;
    out.push_back(q);
  }
  Quad lid;
  lid.centre = base + kUp * height;
  lid.u = Vector3d(0, 0, 1);
  lid.v = Vector3d(1, 0, 0);
  lid.normal = lid.u.cross(lid.v);  // up
  lid.hu = lid.hv = r;
  lid.cls = cls;
  lid.material = top_mat;
  lid.disc = true;
  out.push_back(lid);
}

void build_tabletop(Scene& sc, const SynthOptions& o, Rng& r) {
  Builder b(sc, r);
  const double RX = 3.2, RZ = 2.8, H = 2.6;
  sc.ceiling_height = H;
  sc.ambient = 0.3f;
  sc.look_at = Vector3d(0, kTableHeight + 0.1, 0);

  // Camera path: around the table at 1.15-1.85 m from its centre, drifting towards and away from it.
  CameraPath& path = sc.path;
  path.closed = true;
  const double ph1 = r.uniform(0, 2 * kPi), ph2 = r.uniform(0, 2 * kPi), start = r.uniform(0, 2 * kPi);
  const double sense = r.chance(0.5) ? 1.0 : -1.0;
  const int N = 1200;
  for (int i = 0; i < N; ++i) {
    const double th = start + sense * 2 * kPi * i / N;
    const double radius = 1.5 + 0.3 * std::sin(2 * th + ph1) + 0.05 * std::sin(3 * th + ph2);
    path.points.emplace_back(radius * std::cos(th), radius * std::sin(th));
  }
  finish_path(path);
  integrate_speed(path, o, 0.0);

  // Room: floor, ceiling with lights, painted walls with posters and a door.
  room_floor_and_ceiling(b, r, 0.5, RX, RZ, H);
  for (double x : {-1.6, 0.0, 1.6})
    for (double z : {-1.4, 1.4}) ceiling_light(b, Vector2d(x, z), Vector2d(1, 0), H, 0.8f, light_material(b, 1.6f));
  const Vector2d corners[4] = {{RX, RZ}, {-RX, RZ}, {-RX, -RZ}, {RX, -RZ}};  // wall w runs from corner w to w + 1
  const Vector2d inwards[4] = {{0, -1}, {1, 0}, {0, 1}, {-1, 0}};
  const int door_wall = r.index(4);
  for (int w = 0; w < 4; ++w) {
    const Vector2d A = corners[w], B = corners[(w + 1) % 4], n = inwards[w];
    const double len = (B - A).norm();
    const Vector2d u = (B - A) / len;
    const int paint = b.material(mat(Material::Plain, pastel(r), lin(0.2, 0.18, 0.16), {0, 0, 0}, 0.5f, 0.1f));
    b.wall(A, B, n, 0.0, H, kWall, paint);
    double door_at = -10;
    if (w == door_wall) {
      door_at = r.uniform(0.5, len - 1.6);
      b.decal(A, u, n, door_at, 0.0, 0.9, 2.05, door_material(b));
    }
    // Posters at eye height (what the camera sees above the table), not over the door.
    for (double at = 0.3 + r.uniform(0, 0.4); at < len - 0.9;) {
      const double pw = r.uniform(0.45, 0.85), ph = r.uniform(0.55, 0.9);
      if (at + pw > len - 0.3) break;
      if (at + pw > door_at - 0.15 && at < door_at + 1.05) {
        at = door_at + 1.05 + r.uniform(0.1, 0.4);
        continue;
      }
      const int m = r.chance(0.2) ? b.material(mat(Material::Checker, lin(0.92, 0.92, 0.9), lin(0.04, 0.04, 0.04),
                                                   {0, 0, 0}, static_cast<float>(pw / 8)))
                                  : poster_material(b, pw, ph);
      b.decal(A, u, n, at, 0.9 + r.uniform(0, 0.35), pw, ph, m);
      at += pw + r.uniform(0.25, 0.9);
    }
  }

  // The table: a wooden top on four legs, its long side along x.
  const double thx = r.uniform(0.6, 0.8), thz = r.uniform(0.375, 0.475), top = 0.04, leg = 0.025;
  const double k = r.uniform(0.85, 1.15);
  const int wood = r.chance(0.5) ? b.material(mat(Material::Wood, lin(0.62 * k, 0.45 * k, 0.3 * k),
                                                  lin(0.45 * k, 0.3 * k, 0.18 * k)))
                                 : b.material(mat(Material::Wood, lin(0.8 * k, 0.68 * k, 0.5 * k),
                                                  lin(0.66 * k, 0.52 * k, 0.36 * k)));
  const int legs = b.material(mat(Material::Plain, lin(0.25, 0.25, 0.27)));
  const Matrix3d ax = Matrix3d::Identity();
  Builder::box(sc.quads, Vector3d(0, kTableHeight - top / 2, 0), ax, Vector3d(thx, top / 2, thz), kTable, wood, wood,
               wood, true);
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sz = -1; sz <= 1; sz += 2)
      Builder::box(sc.quads, Vector3d(sx * (thx - 0.06), (kTableHeight - top) / 2, sz * (thz - 0.06)), ax,
                   Vector3d(leg, (kTableHeight - top) / 2, leg), kTable, legs, legs, legs, false);

  // Objects on the table: 3-6 boxes and cylinders of distinct colours, not touching, away from the edge.
  Rng orng(detail::hash(o.seed, kObjects));
  Builder ob(sc, orng);
  struct Colour {
    const char* name;
    double r, g, b;
  };
  static const Colour kColours[] = {{"red", 0.85, 0.12, 0.10},   {"blue", 0.10, 0.30, 0.85},
                                    {"green", 0.12, 0.65, 0.20}, {"yellow", 0.95, 0.80, 0.10},
                                    {"orange", 0.95, 0.45, 0.08}, {"purple", 0.50, 0.15, 0.65},
                                    {"cyan", 0.10, 0.70, 0.80},  {"magenta", 0.85, 0.15, 0.55}};
  constexpr int kNumColours = 8;
  int order[kNumColours];
  for (int i = 0; i < kNumColours; ++i) order[i] = i;
  for (int i = kNumColours - 1; i > 0; --i) std::swap(order[i], order[orng.index(i + 1)]);
  const int count = 3 + orng.index(4);
  const double lim_x = std::min(thx - 0.08, 0.5), lim_z = thz - 0.08;
  struct Placed {
    Vector2d c;
    double radius;
  };
  std::vector<Placed> placed;
  for (int i = 0; i < count; ++i) {
    const bool is_box = orng.chance(0.5);
    Vector3d size = is_box ? Vector3d(orng.uniform(0.1, 0.24), orng.uniform(0.08, 0.28), orng.uniform(0.1, 0.22))
                           : Vector3d(0, orng.uniform(0.1, 0.26), 0);
    if (!is_box) size.x() = size.z() = 2 * orng.uniform(0.04, 0.08);
    const double yaw = is_box ? orng.uniform(0, kPi) : 0.0;
    Vector2d pos;
    bool ok = false;
    for (int attempt = 0; attempt < 300 && !ok; ++attempt) {
      if (attempt > 0 && attempt % 60 == 0) size = Vector3d(size.x() * 0.85, size.y(), size.z() * 0.85);
      const double radius = 0.5 * std::hypot(size.x(), size.z());
      if (lim_x - radius <= 0 || lim_z - radius <= 0) continue;
      pos = Vector2d(orng.uniform(-lim_x + radius, lim_x - radius), orng.uniform(-lim_z + radius, lim_z - radius));
      ok = std::all_of(placed.begin(), placed.end(),
                       [&](const Placed& p) { return (p.c - pos).norm() >= p.radius + radius + 0.06; });
      if (ok) placed.push_back({pos, radius});
    }
    if (!ok) continue;  // no room left on the table
    const Colour& col = kColours[order[i]];
    const std::array<float, 3> a = lin(col.r, col.g, col.b);
    const int texture = orng.index(3);
    Material m;
    if (texture == 0) {  // speckled: the colour with fine noise
      m = mat(Material::Fabric, a);
    } else if (texture == 1) {  // striped: the colour and a darker shade
      m = mat(Material::Fabric, a, lin(col.r * 0.45, col.g * 0.45, col.b * 0.45));
      m.scale2 = static_cast<float>(orng.uniform(0.02, 0.04));
    } else {  // checked: the colour and off-white
      m = mat(Material::Checker, a, lin(0.92, 0.9, 0.86), {0, 0, 0}, static_cast<float>(orng.uniform(0.025, 0.045)));
    }
    const int mi = ob.material(m);
    const std::size_t first = sc.quads.size();
    if (is_box) {
      ob.floor_box(pos, kTableHeight, yaw, size, kObject, mi, mi, mi);
    } else {
      cylinder(sc.quads, at_height(pos, kTableHeight), size.x() / 2, size.y(), 24, kObject, mi, mi);
    }
    Object obj;
    obj.id = static_cast<int>(sc.objects.size()) + 1;
    for (std::size_t q = first; q < sc.quads.size(); ++q) sc.quads[q].instance = static_cast<std::uint8_t>(obj.id);
    obj.shape = is_box ? "box" : "cylinder";
    obj.colour = col.name;
    obj.texture = texture == 0 ? "speckled" : texture == 1 ? "striped" : "checked";
    obj.base = at_height(pos, kTableHeight);
    obj.size = size;
    obj.yaw = yaw;
    sc.objects.push_back(obj);
  }
}

/// Moves everything by -shift in XZ so that the world origin is under the first camera position.
void shift_scene(Scene& sc, const Vector2d& shift) {
  const Vector3d d(shift.x(), 0, shift.y());
  for (auto& q : sc.quads) q.centre -= d;
  for (auto& l : sc.lights) l.position -= d;
  for (auto& p : sc.people) {
    p.a -= shift;
    p.b -= shift;
  }
  for (auto& p : sc.path.points) p -= shift;
  for (auto& ob : sc.objects) ob.base -= d;
  sc.look_at -= d;
}

}  // namespace

// -------------------------------------------------------------------------------------------------

std::vector<ClassInfo> classes() {
  // Colours follow the thesis figures: floor light blue, wall dark blue, ceiling green, furniture red,
  // obstacle salmon; person yellow.
  return {{"floor", 0, {120, 190, 250}},  {"wall", 1, {30, 50, 160}},     {"ceiling", 2, {40, 170, 60}},
          {"furniture", 3, {210, 30, 30}}, {"obstacle", 4, {250, 140, 120}}, {"person", 5, {250, 220, 30}}};
}

ClassInfo void_class() { return {"void", 255, {0, 0, 0}}; }

std::vector<ClassInfo> classes(const std::string& scene) {
  if (scene != "tabletop") return classes();
  // Floor, wall and ceiling as in the other scenes; the table red like furniture, objects orange.
  return {{"floor", 0, {120, 190, 250}}, {"wall", 1, {30, 50, 160}},   {"ceiling", 2, {40, 170, 60}},
          {"table", 3, {210, 30, 30}},   {"object", 4, {255, 160, 0}}};
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

Pose camera_pose(const Scene& scene, const SynthOptions& o, int frame) {
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
  Pose pose;
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
  const Pose p0 = camera_pose(sc, opts, 0);
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

Vector3d pixel_ray(const SynthOptions& opts, const Pose& pose, double x, double y) {
  return detail::ray_direction(pose, opts.fx(), opts.cx(), opts.cy(), x, y);
}

}  // namespace smseg::features::synth
