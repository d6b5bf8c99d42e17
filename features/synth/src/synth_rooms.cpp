// The room layouts of the synthetic video: the corridor, the lab and the tabletop, built from the
// blocks of synth_builder.hpp (see synth.hpp for what each scene holds).
#include "synth_builder.hpp"

namespace smseg::synth::build {

namespace {

// ---------------------------------------------------------------------------------------------
// The corridor.

/// The corridor's centre line: vertices V, unit directions D of its n segments, and their total length
/// (the part behind the start included).
struct CorridorLine {
  std::vector<Vector2d> V, D;
  int n = 0;
  double total = 0;
  double length(int k) const { return (V[k + 1] - V[k]).norm(); }
};

struct CorridorSize {
  double W = 2.4, H = 2.6, h = W / 2, r_turn = 1.0, behind = 2.5, keep_right = 0.3;
};

/// Straight segments with 90-degree turns, alternating sides, long enough for the robot's travel.
CorridorLine corridor_centre_line(const SynthOptions& o, Rng& r, double behind) {
  const double travel = o.frames / o.fps * o.speed * 1.3 + 0.5;
  const double need = behind + travel + 8.0;
  CorridorLine c;
  c.V = {Vector2d(0, -behind)};
  Vector2d dir(0, 1);
  int turn = r.chance(0.5) ? 1 : -1;
  for (int k = 0; c.total < need; ++k) {
    double L = k == 0 ? behind + r.uniform(3.5, 4.5) : (k == 1 ? r.uniform(3.5, 4.5) : r.uniform(3.5, 5.5));
    L = std::round(L * 10.0) / 10.0;  // the walls are traced on a 0.1 m grid
    c.V.push_back(c.V.back() + dir * L);
    c.total += L;
    dir = turn > 0 ? right_of(dir) : Vector2d(-right_of(dir));
    turn = -turn;
  }
  c.n = static_cast<int>(c.V.size()) - 1;
  c.D.resize(c.n);
  for (int k = 0; k < c.n; ++k) c.D[k] = (c.V[k + 1] - c.V[k]).normalized();
  return c;
}

/// Points from a towards c (c itself excluded) every centimetre.
void sample_straight(std::vector<Vector2d>& centre, const Vector2d& a, const Vector2d& c) {
  const double len = (c - a).norm();
  const int steps = std::max(1, static_cast<int>(len / 0.01));
  for (int i = 0; i < steps; ++i) centre.push_back(a + (c - a) * (static_cast<double>(i) / steps));
}

/// The camera path: the centre line with arcs of radius r_turn at the corners, offset to the right.
void corridor_camera_path(CameraPath& path, const CorridorLine& c, const CorridorSize& z) {
  const auto& V = c.V;
  const auto& D = c.D;
  std::vector<Vector2d> centre;
  Vector2d cur = V[0];
  for (int i = 1; i < c.n; ++i) {
    const Vector2d t1 = V[i] - D[i - 1] * z.r_turn, t2 = V[i] + D[i] * z.r_turn;
    sample_straight(centre, cur, t1);
    const Vector2d C = V[i] - D[i - 1] * z.r_turn + D[i] * z.r_turn;
    const int steps = static_cast<int>(0.5 * kPi * z.r_turn / 0.01);
    for (int j = 0; j < steps; ++j) {
      const double phi = 0.5 * kPi * j / steps;
      centre.push_back(C + (t1 - C) * std::cos(phi) + (t2 - C) * std::sin(phi));
    }
    cur = t2;
  }
  sample_straight(centre, cur, V[c.n]);
  centre.push_back(V[c.n]);
  path.closed = false;
  path.points.resize(centre.size());
  for (std::size_t i = 0; i < centre.size(); ++i) {
    const Vector2d a = centre[i > 0 ? i - 1 : i], e = centre[std::min(i + 1, centre.size() - 1)];
    path.points[i] = centre[i] + right_of((e - a).normalized()) * z.keep_right;
  }
}

/// People walk along the left side of a segment (the first, and the second or third), back and forth.
void corridor_people(Builder& b, const SynthOptions& o, const CorridorLine& c, double behind, Keepout& keep) {
  Scene& sc = b.scene();
  Rng pr(detail::hash(o.seed, kPeople));
  std::vector<int> person_segments{0};
  if (c.n > 2) person_segments.push_back(2);
  else if (c.n > 1) person_segments.push_back(1);
  for (int k : person_segments) {
    const Vector2d left = -right_of(c.D[k]) * 0.5;
    const double L = c.length(k);
    const double start = k == 0 ? behind + 0.8 : 1.2, end = k == 0 ? L - 0.4 : L - 1.2;
    if (end - start < 1.5) continue;
    Person p = make_person(b, c.V[k] + c.D[k] * start + left, c.V[k] + c.D[k] * end + left);
    choose_phase(p, sc, o, pr, 0.6);
    keep.segments.emplace_back(p.a, p.b);
    sc.people.push_back(p);
  }
}

/// The corridor's floor plan on a grid of cell g: occupied cells of the union of its rectangles (the
/// segments, plus a dead end continuing straight on past every turn, so that the robot sees down it
/// while turning). Every coordinate is a multiple of g.
struct FloorGrid {
  double g = 0.1, ox = 1e9, oz = 1e9, ex = -1e9, ez = -1e9;
  int nx = 0, nz = 0;
  std::vector<std::uint8_t> occ;
  bool inside(int i, int j) const {
    return i >= 0 && j >= 0 && i < nx && j < nz && occ[static_cast<std::size_t>(i) * nz + j];
  }
};

std::vector<Footprint> corridor_rectangles(const CorridorLine& c, double h, double g, Rng& r) {
  std::vector<Footprint> rects;
  auto rect = [&](const Vector2d& p, const Vector2d& q) {
    rects.push_back({std::min(p.x(), q.x()) - h, std::min(p.y(), q.y()) - h, std::max(p.x(), q.x()) + h,
                     std::max(p.y(), q.y()) + h});
  };
  for (int k = 0; k < c.n; ++k) {
    rect(c.V[k], c.V[k + 1]);
    if (k + 1 < c.n) rect(c.V[k + 1], c.V[k + 1] + c.D[k] * (std::round(r.uniform(1.5, 3.0) / g) * g));
  }
  return rects;
}

FloorGrid rasterise(const std::vector<Footprint>& rects, double g) {
  FloorGrid grid;
  grid.g = g;
  for (const auto& f : rects) {
    grid.ox = std::min(grid.ox, f.x0);
    grid.oz = std::min(grid.oz, f.z0);
    grid.ex = std::max(grid.ex, f.x1);
    grid.ez = std::max(grid.ez, f.z1);
  }
  grid.nx = static_cast<int>(std::lround((grid.ex - grid.ox) / g));
  grid.nz = static_cast<int>(std::lround((grid.ez - grid.oz) / g));
  grid.occ.assign(static_cast<std::size_t>(grid.nx) * grid.nz, 0);
  for (const auto& f : rects) {
    const int i0 = static_cast<int>(std::lround((f.x0 - grid.ox) / g)), i1 = static_cast<int>(std::lround((f.x1 - grid.ox) / g));
    const int j0 = static_cast<int>(std::lround((f.z0 - grid.oz) / g)), j1 = static_cast<int>(std::lround((f.z1 - grid.oz) / g));
    for (int i = i0; i < i1; ++i)
      for (int j = j0; j < j1; ++j) grid.occ[static_cast<std::size_t>(i) * grid.nz + j] = 1;
  }
  return grid;
}

struct WallRun {
  Vector2d A, B, inward;
};

/// The walls: the boundary of the occupied cells, as maximal runs along x = const and z = const.
std::vector<WallRun> trace_walls(const FloorGrid& grid) {
  const double g = grid.g, ox = grid.ox, oz = grid.oz;
  std::vector<WallRun> runs;
  for (int i = 0; i <= grid.nx; ++i) {  // walls of constant x
    int start = -1, sign = 0;
    for (int j = 0; j <= grid.nz; ++j) {
      const int sj = j < grid.nz ? (grid.inside(i, j) != grid.inside(i - 1, j) ? (grid.inside(i, j) ? 1 : -1) : 0) : 0;
      if (sj != sign) {
        if (sign != 0) runs.push_back({{ox + i * g, oz + start * g}, {ox + i * g, oz + j * g}, {double(sign), 0.0}});
        start = j;
        sign = sj;
      }
    }
  }
  for (int j = 0; j <= grid.nz; ++j) {  // walls of constant z
    int start = -1, sign = 0;
    for (int i = 0; i <= grid.nx; ++i) {
      const int si = i < grid.nx ? (grid.inside(i, j) != grid.inside(i, j - 1) ? (grid.inside(i, j) ? 1 : -1) : 0) : 0;
      if (si != sign) {
        if (sign != 0) runs.push_back({{ox + start * g, oz + j * g}, {ox + i * g, oz + j * g}, {0.0, double(sign)}});
        start = i;
        sign = si;
      }
    }
  }
  return runs;
}

/// Floor and ceiling: one quad each over the bounding box of the grid.
void corridor_floor_and_ceiling(Builder& b, Rng& r, const FloorGrid& grid, double H) {
  const double ox = grid.ox, oz = grid.oz, ex = grid.ex, ez = grid.ez;
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
  b.quad(mid, Vector3d(0, 0, 1), Vector3d(1, 0, 0), hz, hx, kFloor, floor_mat, Vector2d(mid.z() - hz, mid.x() - hx));
  const int ceil_mat =
      b.material(mat(Material::CeilingTiles, lin(0.88, 0.88, 0.86), lin(0.7, 0.7, 0.7), {0, 0, 0}, 0.6f));
  b.quad(mid + kUp * H, Vector3d(1, 0, 0), Vector3d(0, 0, 1), hx, hz, kCeiling, ceil_mat,
         Vector2d(mid.x() - hx, mid.z() - hz));
}

/// Doors, posters and gaps along a corridor wall of length len starting at A in direction u.
void corridor_wall_decals(Builder& b, Rng& r, const Vector2d& A, const Vector2d& u, const Vector2d& inward,
                          double len) {
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
}

/// One wall run: painted or block wall, its decals, and furniture against it away from the corners.
void corridor_wall(Builder& b, Rng& r, Keepout& keep, const WallRun& w, double H) {
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
  corridor_wall_decals(b, r, A, u, inward, len);
  for (int tries = 0; tries < 3 && len > 3.0; ++tries) {
    const double along = r.uniform(0.8, len - 2.4);
    double width = 0;
    if (wall_furniture(b, keep, A, u, inward, along, r.chance(0.5) ? 2 : 3, width)) break;
  }
}

/// Ceiling lights along the centre line; now and then a dim one.
void corridor_lights(Builder& b, Rng& r, const CorridorLine& c, double H) {
  double s = 1.0;
  const double spacing = 2.8;
  for (int k = 0; k < c.n; ++k) {
    const double L = c.length(k);
    for (; s < L - 0.3; s += spacing) {
      const bool dim = r.chance(0.12);
      const int panel = light_material(b, dim ? 0.15f : 1.6f);
      ceiling_light(b, c.V[k] + c.D[k] * s, c.D[k], H, dim ? 0.15f : 0.85f, panel);
    }
    s -= L;
    if (s < 0.3) s = 0.3;
  }
}

/// Obstacles on the floor near the walls, from their own random stream.
void corridor_obstacles(Scene& sc, const SynthOptions& o, const CorridorLine& c, double h, Keepout& keep) {
  Rng orng(detail::hash(o.seed, kObjects));
  Builder ob(sc, orng);
  const int count = static_cast<int>(c.total / 2.0);
  const double max_size = 0.45, half = 0.5 * max_size * 1.15;  // 1.15: turned by up to 0.25 rad
  for (int i = 0; i < count; ++i) {
    for (int attempt = 0; attempt < 20; ++attempt) {
      const int k = orng.index(c.n);
      const double L = c.length(k);
      if (L < 3.0) continue;
      const Vector2d& V = c.V[k];
      const Vector2d& D = c.D[k];
      const double along = orng.uniform(1.3, L - 1.3);
      const int side = orng.chance(0.5) ? 1 : -1;
      const double lateral = side * (h - 0.03 - half);
      const Vector2d pos = V + D * along + right_of(D) * lateral;
      const Footprint probe{pos.x() - half, pos.y() - half, pos.x() + half, pos.y() + half};
      if (!keep.ok(probe, 0.35, 0.3, 0.05)) continue;
      add_obstacle(ob, pos, std::atan2(D.x(), D.y()) + orng.uniform(-0.25, 0.25), max_size, keep);
      break;
    }
  }
}

}  // namespace

void build_corridor(Scene& sc, const SynthOptions& o, Rng& r) {
  Builder b(sc, r);
  const CorridorSize z;
  sc.ceiling_height = z.H;
  sc.ambient = 0.3f;
  const CorridorLine c = corridor_centre_line(o, r, z.behind);
  corridor_camera_path(sc.path, c, z);
  finish_path(sc.path);
  integrate_speed(sc.path, o, z.behind);
  Keepout keep;
  keep.path = &sc.path;
  keep.ahead_clear = 0.3;
  corridor_people(b, o, c, z.behind, keep);
  const double g = 0.1;
  const FloorGrid grid = rasterise(corridor_rectangles(c, z.h, g, r), g);
  const std::vector<WallRun> runs = trace_walls(grid);
  corridor_floor_and_ceiling(b, r, grid, z.H);
  for (const WallRun& w : runs) corridor_wall(b, r, keep, w, z.H);
  corridor_lights(b, r, c, z.H);
  corridor_obstacles(sc, o, c, z.h, keep);
}

// ---------------------------------------------------------------------------------------------
// The lab.

namespace {

struct LabRoom {
  double RX = 4.5, RZ = 3.5, H = 2.8;
};

/// A wall of the lab: from A along u for len metres, n pointing into the room (the room on the left
/// of u, as the decals expect).
struct LabWall {
  Vector2d A, u, n;
  double len;
};

/// Where a wall's door is (its left edge; far off the wall when it has none).
struct DoorGap {
  double at = -10;
  /// Whether [x0, x1] along the wall keeps clear of the door and its frame.
  bool clear(double x0, double x1) const { return x1 < at - 0.15 || x0 > at + 1.05; }
};

/// Camera path: a wobbly ellipse around the middle of the room.
void lab_camera_path(CameraPath& path, Rng& r) {
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
}

/// Twelve ceiling lights on a grid; now and then a dim one.
void lab_lights(Builder& b, Rng& r, double H) {
  for (double x : {-3.0, -1.0, 1.0, 3.0})
    for (double z : {-2.0, 0.0, 2.0}) {
      const bool dim = r.chance(0.08);
      ceiling_light(b, Vector2d(x, z), Vector2d(1, 0), H, dim ? 0.2f : 0.75f, light_material(b, dim ? 0.15f : 1.6f));
    }
}

/// Two people crossing the room (and the robot's path), back and forth.
void lab_people(Builder& b, const SynthOptions& o, Keepout& keep) {
  Scene& sc = b.scene();
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
}

/// A whiteboard (theme 3's wall) where it finds room beside the door.
void lab_whiteboard(Builder& b, Rng& r, const LabWall& wd, const DoorGap& door) {
  const double bw = r.uniform(1.8, 2.4);
  for (int tries = 0; tries < 10; ++tries) {
    const double at = r.uniform(0.4, wd.len - bw - 0.4);
    if (!door.clear(at, at + bw)) continue;
    const int m = b.material(mat(Material::Whiteboard, lin(0.93, 0.93, 0.92), lin(0.6, 0.6, 0.62),
                                 lin(0.02, 0.02, 0.02), static_cast<float>(bw), 1.1f));
    b.decal(wd.A, wd.u, wd.n, at, 0.95, bw, 1.1, m);
    break;
  }
}

/// Furniture along the wall: desks (theme 0), shelves (1), cabinets (2), cabinets and benches (3).
void lab_furniture(Builder& b, Rng& r, Keepout& keep, const LabWall& wd, int theme, const DoorGap& door) {
  const int kind_of_theme[4] = {0, 1, 2, 2};
  for (double at = 0.3 + r.uniform(0, 0.5); at < wd.len - 0.5;) {
    const int kind = theme == 3 && r.chance(0.5) ? 3 : kind_of_theme[theme];
    double width = kind == 0 ? 1.6 : 1.3;
    if (at + width > wd.len - 0.3 || !door.clear(at, at + width)) {
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
}

/// Posters above furniture height (none over the shelves of theme 1).
void lab_posters(Builder& b, Rng& r, const LabWall& wd, int theme, const DoorGap& door) {
  const int posters = theme == 1 ? 0 : 1 + r.index(3);
  for (int k = 0; k < posters; ++k) {
    const double pw = r.uniform(0.45, 0.8), ph = r.uniform(0.55, 0.85);
    const double at = r.uniform(0.3, wd.len - pw - 0.3);
    if (!door.clear(at, at + pw)) continue;
    // Now and then a camera-calibration checkerboard instead of a poster (it is a vision lab).
    const int m = k == 0 && r.chance(0.3)
                      ? b.material(mat(Material::Checker, lin(0.92, 0.92, 0.9), lin(0.04, 0.04, 0.04), {0, 0, 0},
                                       static_cast<float>(pw / 8)))
                      : poster_material(b, pw, ph);
    b.decal(wd.A, wd.u, wd.n, at, 1.3 + r.uniform(0, 0.3), pw, ph, m, 0.01 + 0.002 * k);
  }
}

/// One wall with its theme: paint, maybe a door, the theme's board, furniture and posters.
void lab_wall(Builder& b, Rng& r, Keepout& keep, const LabWall& wd, int theme, double H) {
  const int paint = b.material(mat(Material::Plain, pastel(r), lin(0.2, 0.18, 0.16), {0, 0, 0}, 0.5f, 0.1f));
  b.wall(wd.A, wd.A + wd.u * wd.len, wd.n, 0.0, H, kWall, paint);
  DoorGap door;
  if (r.chance(theme == 3 ? 0.9 : 0.45)) {
    door.at = r.uniform(0.5, wd.len - 1.6);
    b.decal(wd.A, wd.u, wd.n, door.at, 0.0, 0.9, 2.05, door_material(b));
  }
  if (theme == 3) lab_whiteboard(b, r, wd, door);  // whiteboard and posters, low cabinets below
  lab_furniture(b, r, keep, wd, theme, door);
  lab_posters(b, r, wd, theme, door);
}

/// Obstacles on the floor, from their own random stream: some along the walls, some inside the loop.
void lab_obstacles(Scene& sc, const SynthOptions& o, const LabRoom& room, Keepout& keep) {
  const double RX = room.RX, RZ = room.RZ;
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

}  // namespace

void build_lab(Scene& sc, const SynthOptions& o, Rng& r) {
  Builder b(sc, r);
  const LabRoom room;
  const double RX = room.RX, RZ = room.RZ, H = room.H;
  sc.ceiling_height = H;
  sc.ambient = 0.28f;
  lab_camera_path(sc.path, r);
  finish_path(sc.path);
  integrate_speed(sc.path, o, 0.0);
  room_floor_and_ceiling(b, r, 0.55, RX, RZ, H);
  lab_lights(b, r, H);
  Keepout keep;
  keep.path = &sc.path;
  lab_people(b, o, keep);
  // Walls with themes: desks, shelves, cabinets, board.
  const LabWall walls[4] = {{{RX, RZ}, {-1, 0}, {0, -1}, 2 * RX},
                            {{RX, -RZ}, {0, 1}, {-1, 0}, 2 * RZ},
                            {{-RX, -RZ}, {1, 0}, {0, 1}, 2 * RX},
                            {{-RX, RZ}, {0, -1}, {1, 0}, 2 * RZ}};
  int themes[4] = {0, 1, 2, 3};
  for (int i = 3; i > 0; --i) std::swap(themes[i], themes[r.index(i + 1)]);
  for (int w = 0; w < 4; ++w) lab_wall(b, r, keep, walls[w], themes[w], H);
  lab_obstacles(sc, o, room, keep);
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

namespace {

struct TabletopRoom {
  double RX = 3.2, RZ = 2.8, H = 2.6;
};

/// Camera path: around the table at 1.15-1.85 m from its centre, drifting towards and away from it.
void tabletop_camera_path(CameraPath& path, Rng& r) {
  path.closed = true;
  const double ph1 = r.uniform(0, 2 * kPi), ph2 = r.uniform(0, 2 * kPi), start = r.uniform(0, 2 * kPi);
  const double sense = r.chance(0.5) ? 1.0 : -1.0;
  const int N = 1200;
  for (int i = 0; i < N; ++i) {
    const double th = start + sense * 2 * kPi * i / N;
    const double radius = 1.5 + 0.3 * std::sin(2 * th + ph1) + 0.05 * std::sin(3 * th + ph2);
    path.points.emplace_back(radius * std::cos(th), radius * std::sin(th));
  }
}

/// Posters at eye height (what the camera sees above the table) along a wall, not over the door.
void tabletop_posters(Builder& b, Rng& r, const Vector2d& A, const Vector2d& u, const Vector2d& n, double len,
                      double door_at) {
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

/// Painted walls with posters, one of them with a door.
void tabletop_walls(Builder& b, Rng& r, const TabletopRoom& room) {
  const double RX = room.RX, RZ = room.RZ;
  const Vector2d corners[4] = {{RX, RZ}, {-RX, RZ}, {-RX, -RZ}, {RX, -RZ}};  // wall w runs from corner w to w + 1
  const Vector2d inwards[4] = {{0, -1}, {1, 0}, {0, 1}, {-1, 0}};
  const int door_wall = r.index(4);
  for (int w = 0; w < 4; ++w) {
    const Vector2d A = corners[w], B = corners[(w + 1) % 4], n = inwards[w];
    const double len = (B - A).norm();
    const Vector2d u = (B - A) / len;
    const int paint = b.material(mat(Material::Plain, pastel(r), lin(0.2, 0.18, 0.16), {0, 0, 0}, 0.5f, 0.1f));
    b.wall(A, B, n, 0.0, room.H, kWall, paint);
    double door_at = -10;
    if (w == door_wall) {
      door_at = r.uniform(0.5, len - 1.6);
      b.decal(A, u, n, door_at, 0.0, 0.9, 2.05, door_material(b));
    }
    tabletop_posters(b, r, A, u, n, len, door_at);
  }
}

/// The table's top, half sizes thx (along x) and thz.
struct TableTop {
  double thx, thz;
};

/// The table: a wooden top on four legs, its long side along x.
TableTop build_table(Builder& b, Rng& r) {
  Scene& sc = b.scene();
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
  return {thx, thz};
}

struct Colour {
  const char* name;
  double r, g, b;
};

/// An object's footprint on the table: a circle.
struct Placed {
  Vector2d c;
  double radius;
};

/// A spot for an object of the given size (its footprint shrunk by 15% every 60 failed attempts),
/// inside [-lim_x, lim_x] x [-lim_z, lim_z] and 6 cm clear of the placed ones; false when none is found.
bool place_on_table(Rng& orng, Vector3d& size, double lim_x, double lim_z, std::vector<Placed>& placed, Vector2d& pos) {
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
  return ok;
}

/// The object's surface: speckled (texture 0), striped (1) or checked (2) in its colour.
Material object_material(Rng& orng, const Colour& col, int texture) {
  const std::array<float, 3> a = lin(col.r, col.g, col.b);
  Material m;
  if (texture == 0) {  // speckled: the colour with fine noise
    m = mat(Material::Fabric, a);
  } else if (texture == 1) {  // striped: the colour and a darker shade
    m = mat(Material::Fabric, a, lin(col.r * 0.45, col.g * 0.45, col.b * 0.45));
    m.scale2 = static_cast<float>(orng.uniform(0.02, 0.04));
  } else {  // checked: the colour and off-white
    m = mat(Material::Checker, a, lin(0.92, 0.9, 0.86), {0, 0, 0}, static_cast<float>(orng.uniform(0.025, 0.045)));
  }
  return m;
}

/// One object on the table: a box or a cylinder of the given colour, its quads tagged with its id.
void table_object(Builder& ob, const TableTop& table, const Colour& col, std::vector<Placed>& placed) {
  Scene& sc = ob.scene();
  Rng& orng = ob.rng();
  const double lim_x = std::min(table.thx - 0.08, 0.5), lim_z = table.thz - 0.08;
  const bool is_box = orng.chance(0.5);
  Vector3d size = is_box ? Vector3d(orng.uniform(0.1, 0.24), orng.uniform(0.08, 0.28), orng.uniform(0.1, 0.22))
                         : Vector3d(0, orng.uniform(0.1, 0.26), 0);
  if (!is_box) size.x() = size.z() = 2 * orng.uniform(0.04, 0.08);
  const double yaw = is_box ? orng.uniform(0, kPi) : 0.0;
  Vector2d pos;
  if (!place_on_table(orng, size, lim_x, lim_z, placed, pos)) return;  // no room left on the table
  const int texture = orng.index(3);
  const int mi = ob.material(object_material(orng, col, texture));
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

/// Objects on the table, from their own random stream: 3-6 boxes and cylinders of distinct colours,
/// not touching, away from the edge.
void table_objects(Scene& sc, const SynthOptions& o, const TableTop& table) {
  Rng orng(detail::hash(o.seed, kObjects));
  Builder ob(sc, orng);
  static const Colour kColours[] = {{"red", 0.85, 0.12, 0.10},   {"blue", 0.10, 0.30, 0.85},
                                    {"green", 0.12, 0.65, 0.20}, {"yellow", 0.95, 0.80, 0.10},
                                    {"orange", 0.95, 0.45, 0.08}, {"purple", 0.50, 0.15, 0.65},
                                    {"cyan", 0.10, 0.70, 0.80},  {"magenta", 0.85, 0.15, 0.55}};
  constexpr int kNumColours = 8;
  int order[kNumColours];
  for (int i = 0; i < kNumColours; ++i) order[i] = i;
  for (int i = kNumColours - 1; i > 0; --i) std::swap(order[i], order[orng.index(i + 1)]);
  const int count = 3 + orng.index(4);
  std::vector<Placed> placed;
  for (int i = 0; i < count; ++i) table_object(ob, table, kColours[order[i]], placed);
}

}  // namespace

void build_tabletop(Scene& sc, const SynthOptions& o, Rng& r) {
  Builder b(sc, r);
  const TabletopRoom room;
  sc.ceiling_height = room.H;
  sc.ambient = 0.3f;
  sc.look_at = Vector3d(0, kTableHeight + 0.1, 0);
  tabletop_camera_path(sc.path, r);
  finish_path(sc.path);
  integrate_speed(sc.path, o, 0.0);
  // Room: floor, ceiling with lights, painted walls with posters and a door.
  room_floor_and_ceiling(b, r, 0.5, room.RX, room.RZ, room.H);
  for (double x : {-1.6, 0.0, 1.6})
    for (double z : {-1.4, 1.4})
      ceiling_light(b, Vector2d(x, z), Vector2d(1, 0), room.H, 0.8f, light_material(b, 1.6f));
  tabletop_walls(b, r, room);
  table_objects(sc, o, build_table(b, r));
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


}  // namespace smseg::synth::build
