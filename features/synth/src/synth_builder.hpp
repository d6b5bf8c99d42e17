#pragma once
// The building blocks of the synthetic scenes, shared by the room layouts (synth_rooms.cpp) and the
// scene API (synth_scene.cpp): the geometry builder, materials, the camera path, the walking people,
// obstacles and wall furniture, ceiling lights and the room shell. Private to the synth module.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Geometry>

#include "synth_detail.hpp"

namespace smseg::synth::build {

using detail::lin;
using detail::Rng;
using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;


constexpr double kPi = std::numbers::pi;
const Vector3d kUp(0, 1, 0);

/// Salts for the independent random streams derived from the seed.
enum Stream : std::uint64_t { kLayout = 1, kSway, kSpeed, kPeople, kObjects, kNoise };

inline Vector3d at_height(const Vector2d& p, double y) { return {p.x(), y, p.y()}; }
/// Right of a walking direction in the XZ plane (camera x for a camera looking along f, world Y up).
inline Vector2d right_of(const Vector2d& f) { return {-f.y(), f.x()}; }

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

inline Material mat(Material::Kind kind, std::array<float, 3> a, std::array<float, 3> b = {0.3f, 0.3f, 0.3f},
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

inline std::array<float, 3> pastel(Rng& r) {
  static const double kWalls[][3] = {{0.86, 0.84, 0.78}, {0.80, 0.84, 0.86}, {0.88, 0.82, 0.70},
                                     {0.78, 0.84, 0.76}, {0.90, 0.88, 0.84}, {0.84, 0.78, 0.76}};
  const auto& c = kWalls[r.index(6)];
  return lin(c[0], c[1], c[2]);
}

inline int poster_material(Builder& b, double w, double h) {
  Rng& r = b.rng();
  const double paper = r.uniform(0.85, 0.97);
  return b.material(mat(Material::Poster, lin(paper, paper, paper * r.uniform(0.9, 1.0)), {0, 0, 0},
                        lin(0.08, 0.08, 0.1), static_cast<float>(w), static_cast<float>(h)));
}

inline int door_material(Builder& b) {
  Rng& r = b.rng();
  static const double kDoors[][3] = {{0.55, 0.36, 0.20}, {0.62, 0.45, 0.28}, {0.35, 0.45, 0.60}, {0.75, 0.72, 0.65},
                                     {0.50, 0.20, 0.15}};
  const auto& c = kDoors[r.index(5)];
  Material m = mat(Material::Door, lin(c[0], c[1], c[2]), lin(0.25, 0.22, 0.2), lin(0.7, 0.7, 0.72), 0.9f, 2.05f);
  m.seed = static_cast<std::uint32_t>(r.next()) | 1u;
  if (r.chance(0.4)) m.seed &= ~1u;  // even seed: painted, odd: wood grain
  return b.material(m);
}

inline int cardboard_material(Builder& b, double h) {
  Rng& r = b.rng();
  const double k = r.uniform(0.85, 1.1);
  return b.material(mat(Material::Cardboard, lin(0.62 * k, 0.46 * k, 0.30 * k), lin(0.78, 0.68, 0.5),
                        lin(0.05, 0.05, 0.05), 0.5f, static_cast<float>(h)));
}

// ---------------------------------------------------------------------------------------------
// Camera path.

inline void finish_path(CameraPath& p) {
  p.arc.assign(p.points.size(), 0.0);
  for (std::size_t i = 1; i < p.points.size(); ++i) p.arc[i] = p.arc[i - 1] + (p.points[i] - p.points[i - 1]).norm();
}

inline double path_length(const CameraPath& p) {
  return p.arc.back() + (p.closed ? (p.points.front() - p.points.back()).norm() : 0.0);
}

inline Vector2d path_point(const CameraPath& p, double s) {
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

inline Vector2d path_tangent(const CameraPath& p, double s, double half = 0.25) {
  const Vector2d d = path_point(p, s + half) - path_point(p, s - half);
  return d.norm() > 1e-9 ? Vector2d(d.normalized()) : Vector2d(0, 1);
}

/// Curvature (1/m) of the path around arc length s, averaged over +-0.4 m.
inline double path_curvature(const CameraPath& p, double s) {
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
inline void integrate_speed(CameraPath& p, const SynthOptions& o, double s_start) {
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

inline PersonState person_state(const Person& p, double time) {
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

inline void person_quads(const Person& p, double time, std::vector<Quad>& out) {
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

inline Person make_person(Builder& b, const Vector2d& a, const Vector2d& bb) {
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
inline void choose_phase(Person& p, const Scene& sc, const SynthOptions& o, Rng& r, double min_dist) {
  const double period = 2 * (p.b - p.a).norm() / p.speed;
  const double u0 = r.uniform();
  double best = -1, best_phase = 0;
  std::vector<Vector2d> cam(o.frames);
  for (int f = 0; f < o.frames; ++f) {
    const sequence::Pose pose = camera_pose(sc, o, f);
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
inline void add_obstacle(Builder& b, const Vector2d& pos, double yaw, double max_size, Keepout& keep) {
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
inline Footprint wall_footprint(const Vector2d& A, const Vector2d& u, const Vector2d& n, double along, double w, double d,
                         double off) {
  const Vector2d p0 = A + u * along + n * off, p1 = A + u * (along + w) + n * (off + d);
  return {std::min(p0.x(), p1.x()), std::min(p0.y(), p1.y()), std::max(p0.x(), p1.x()), std::max(p0.y(), p1.y())};
}

/// Where a piece of furniture goes: against the wall from A along u (n into the room), its left edge
/// `along` metres from A, its front facing the room (yaw, axes).
struct WallSpot {
  Vector2d A, u, n;
  double along, yaw;
  Matrix3d ax;
  WallSpot(const Vector2d& a, const Vector2d& dir, const Vector2d& inward, double at)
      : A(a), u(dir), n(inward), along(at), yaw(std::atan2(inward.x(), inward.y())), ax(Builder::yaw_axes(yaw)) {}
  /// Centre of a piece of width w and depth d standing 2 cm off the wall.
  Vector2d centre(double w, double d) const { return Vector2d(A + u * (along + w / 2) + n * (0.02 + d / 2)); }
  Footprint footprint(double w, double d) const { return wall_footprint(A, u, n, along, w, d, 0.02); }
};

/// A monitor on a stand on the desk top (centre c, height h), its screen lit; returns the stand's
/// plastic (the chair's base is of it too).
inline int desk_monitor(Builder& b, const WallSpot& at, const Vector2d& c, double h, double width) {
  Rng& r = b.rng();
  Scene& sc = b.scene();
  const double mw = r.uniform(0.45, 0.6), mh = mw * 0.62;
  const Vector2d mc = c + at.u * r.uniform(-0.25, 0.25) * (width - mw) - at.n * 0.12;
  const int screen = b.material(mat(Material::Screen, lin(0.15, 0.3, 0.5), lin(0.85, 0.85, 0.9),
                                    lin(0.03, 0.03, 0.035), static_cast<float>(mw), static_cast<float>(mh)));
  sc.materials[screen].emission = 0.5f;
  const int plastic = b.material(mat(Material::Plain, lin(0.06, 0.06, 0.07)));
  b.box(sc.quads, at_height(mc, h + 0.05), at.ax, Vector3d(0.03, 0.05, 0.03), kFurniture, plastic, plastic, plastic,
        false);
  b.box(sc.quads, at_height(mc, h + 0.1 + mh / 2), at.ax, Vector3d(mw / 2, mh / 2, 0.025), kFurniture, plastic,
        plastic, screen, true);
  return plastic;
}

/// An office chair in front of the desk (centre c, depth d), turned towards it: base, post, seat, back.
inline void desk_chair(Builder& b, const WallSpot& at, const Vector2d& c, double d, int metal, int plastic) {
  Rng& r = b.rng();
  Scene& sc = b.scene();
  const Vector2d cc = c + at.n * (d / 2 + 0.3) + at.u * r.uniform(-0.2, 0.2);
  const double cyaw = at.yaw + kPi + r.uniform(-0.5, 0.5);
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
}

/// A desk with a monitor, and a chair in front.
inline bool wall_desk(Builder& b, Keepout& keep, const WallSpot& at, int wood, double& width) {
  Rng& r = b.rng();
  Scene& sc = b.scene();
  width = r.uniform(1.2, 1.6);
  const double d = 0.7, h = 0.74;
  const Footprint fp = at.footprint(width, d + 0.6);  // and room for the chair
  if (!keep.ok(fp, 0.55, 0.45, 0.05)) return false;
  keep.taken.push_back(fp);
  const Vector2d c = at.centre(width, d);
  const int metal = b.material(mat(Material::Plain, lin(0.3, 0.3, 0.32)));
  b.box(sc.quads, at_height(c, h - 0.015), at.ax, Vector3d(width / 2, 0.015, d / 2), kFurniture, wood, wood, wood, true);
  for (int side = -1; side <= 1; side += 2) {
    const Vector2d leg = c + side * at.u * (width / 2 - 0.03);
    b.box(sc.quads, at_height(leg, (h - 0.03) / 2), at.ax, Vector3d(0.02, (h - 0.03) / 2, d / 2 - 0.02), kFurniture,
          metal, metal, metal, false);
  }
  b.box(sc.quads, at_height(c - at.n * (d / 2 - 0.05), 0.45), at.ax, Vector3d(width / 2 - 0.05, 0.25, 0.01),
        kFurniture, metal, metal, metal, true);
  const int plastic = desk_monitor(b, at, c, h, width);
  desk_chair(b, at, c, d, metal, plastic);
  return true;
}

/// A filing cabinet (tall) or a sideboard with drawers, in one of four metal colours.
inline bool wall_cabinet(Builder& b, Keepout& keep, const WallSpot& at, int wood, double& width) {
  Rng& r = b.rng();
  const bool tall = r.chance(0.5);
  width = tall ? 0.5 : r.uniform(0.9, 1.3);
  const double d = tall ? 0.6 : 0.45, h = tall ? 1.3 : r.uniform(0.75, 0.9);
  const Footprint fp = at.footprint(width, d);
  if (!keep.ok(fp, 0.55, 0.45, 0.02)) return false;
  keep.taken.push_back(fp);
  static const double kMetal[][3] = {{0.7, 0.7, 0.68}, {0.55, 0.6, 0.62}, {0.8, 0.76, 0.66}, {0.35, 0.38, 0.42}};
  const auto& mc = kMetal[r.index(4)];
  const int body = b.material(mat(Material::Plain, lin(mc[0], mc[1], mc[2])));
  const int front = b.material(mat(Material::Drawers, lin(mc[0], mc[1], mc[2]), lin(0.1, 0.1, 0.1),
                                   lin(0.05, 0.05, 0.05), tall ? 0.32f : 0.25f, static_cast<float>(width)));
  b.floor_box(at.centre(width, d), 0.0, at.yaw, Vector3d(width, h, d), kFurniture, body, tall ? body : wood, front);
  return true;
}

/// Furniture against a wall: the piece's front faces the room (direction n). Returns false when the
/// piece would block the robot's path or a person's line.
inline bool wall_furniture(Builder& b, Keepout& keep, const Vector2d& A, const Vector2d& u, const Vector2d& n, double along,
                    int kind, double& width) {
  Rng& r = b.rng();
  const WallSpot at(A, u, n, along);
  const int wood = b.material(mat(Material::Wood, lin(0.62, 0.45, 0.3), lin(0.45, 0.3, 0.18)));
  if (kind == 0) return wall_desk(b, keep, at, wood, width);
  if (kind == 2) return wall_cabinet(b, keep, at, wood, width);
  if (kind == 1) {  // bookshelf: solid box whose front shows shelves and books
    width = r.uniform(0.8, 1.0);
    const double d = 0.35, h = r.uniform(1.7, 2.0);
    const Footprint fp = at.footprint(width, d);
    if (!keep.ok(fp, 0.55, 0.45, 0.02)) return false;
    keep.taken.push_back(fp);
    const int books = b.material(mat(Material::Books, lin(0.55, 0.4, 0.26), {0, 0, 0}, lin(0.04, 0.03, 0.02),
                                     static_cast<float>(width), static_cast<float>(h)));
    b.floor_box(at.centre(width, d), 0.0, at.yaw, Vector3d(width, h, d), kFurniture, wood, wood, books);
    return true;
  }
  // bench
  width = r.uniform(1.2, 1.6);
  const double d = 0.38, h = 0.45;
  const Footprint fp = at.footprint(width, d);
  if (!keep.ok(fp, 0.5, 0.4, 0.02)) return false;
  keep.taken.push_back(fp);
  b.floor_box(at.centre(width, d), 0.0, at.yaw, Vector3d(width, h, d), kFurniture, wood, wood, wood);
  return true;
}

// ---------------------------------------------------------------------------------------------
// Lights.

inline void ceiling_light(Builder& b, const Vector2d& c, const Vector2d& along, double H, float intensity, int panel) {
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

inline int light_material(Builder& b, float emission) {
  Material m = mat(Material::Light, lin(0.98, 0.98, 0.96), lin(0.6, 0.6, 0.6), {0, 0, 0}, 0.6f, 1.2f);
  m.emission = emission;
  return b.material(m);
}

// ---------------------------------------------------------------------------------------------
// The corridor.

// A room's floor (carpet with probability `carpet`, else tiles) and tiled ceiling: x in [-RX, RX],
// z in [-RZ, RZ], ceiling at height H.
inline void room_floor_and_ceiling(Builder& b, Rng& r, double carpet, double RX, double RZ, double H) {
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

// The room layouts (synth_rooms.cpp): each fills the scene, its path and its people.
void build_corridor(Scene& sc, const SynthOptions& o, Rng& r);
void build_lab(Scene& sc, const SynthOptions& o, Rng& r);
void build_tabletop(Scene& sc, const SynthOptions& o, Rng& r);
/// Moves everything by -shift in XZ so that the world origin is under the first camera position.
void shift_scene(Scene& sc, const Vector2d& shift);

}  // namespace smseg::synth::build
