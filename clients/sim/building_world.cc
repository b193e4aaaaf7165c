#include "clients/sim/building_world.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "clients/sim/scene_builder.h"
#include "clients/sim/texture_library.h"

namespace epmap::sim {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kWallT = 0.12;      // wall thickness
constexpr double kDoorH = 2.05;      // door opening height
constexpr double kFrameW = 0.05;     // door frame (jamb) width along the wall
constexpr double kFrameOut = 0.015;  // how far frames and skirting stand off the wall
constexpr double kSkirtH = 0.08;
constexpr double kH = kCeilingHeightM;

struct Opening {
  double from, to;  // along the wall
};

// Everything the floor is furnished with; the builder adds boxes and records footprints.
class Furnisher {
 public:
  Furnisher(BuildingWorld* world, uint64_t seed)
      : world_(world),
        b_(&world->scene, Rng(seed, Stream::kWorldLayout)),
        rng_(seed, Stream::kWorldLayout, 1) {
    namespace tx = textures;
    Rng t(seed, Stream::kTextures);
    paint_corridor_ = {b_.AddTexture(tx::Paint(t, 512, {200, 215, 225}, 6.0)), 256};
    paint_room_ = {b_.AddTexture(tx::Paint(t, 512, {215, 205, 190}, 5.0)), 256};
    paint_plain_ = {b_.AddTexture(tx::Paint(t, 256, {232, 232, 230}, 1.2)), 200};
    floor_ = {b_.AddTexture(tx::Tiles(t, 1024, 10, {170, 175, 180}, {95, 100, 105})), 256};
    // Suspended ceiling: 0.6 m acoustic tiles (4 per 2.4 m texture side).
    ceiling_ = {b_.AddTexture(tx::Tiles(t, 512, 4, {228, 228, 226}, {150, 150, 150})), 512 / 2.4};
    wood_ = {b_.AddTexture(tx::Wood(t, 512, {110, 160, 200}, {55, 95, 140})), 400};
    dark_ = {b_.AddTexture(tx::Paint(t, 256, {70, 70, 75}, 3.0)), 400};
    metal_ = {b_.AddTexture(tx::Paint(t, 256, {170, 172, 175}, 2.0)), 400};
    frame_ = {b_.AddTexture(tx::Paint(t, 256, {150, 150, 150}, 2.0)), 400, 0.9F};
    plant_ = {b_.AddTexture(tx::Fabric(t, 256, {40, 120, 50}, 35.0)), 600};
    for (int i = 0; i < 3; ++i) books_[i] = b_.AddTexture(tx::Books(t, 512, 256));
    for (int i = 0; i < 24; ++i) posters_.push_back(b_.AddTexture(tx::Poster(t, 256, 512)));
  }

  // The walker's clothes and skin, drawn from a stream of their own so that the world's other
  // textures stay what they were.
  void WalkerClothes(uint64_t seed) {
    namespace tx = textures;
    Rng t(seed, Stream::kObjectMotion, 2);
    world_->walker_trousers = {b_.AddTexture(tx::Fabric(t, 256, {95, 60, 45}, 30.0)), 500};
    world_->walker_shirt = {b_.AddTexture(tx::Toy(t, 256)), 300};
    world_->walker_skin = {b_.AddTexture(tx::Paint(t, 256, {150, 175, 215}, 4.0)), 400};
  }

  void FloorAndCeiling() {
    const double W = kBuildingWidthM, D = kBuildingDepthM;
    // Floor seen from above: image up = north.
    b_.AddPanel({0, D, 0}, {W, 0, 0}, {0, -D, 0}, floor_);
    // Ceiling seen from below: image up = north, right = west.
    b_.AddPanel({W, D, kH}, {-W, 0, 0}, {0, -D, 0}, ceiling_);
  }

  // A wall along x at y (from x0 to x1) or along y at x, with door openings; `outer` walls
  // lie outside the floor (their inner face on the boundary).
  void WallAlongX(double y, double x0, double x1, std::vector<Opening> doors, const Material& m,
                  double y_offset = 0) {
    Wall(true, y + y_offset, x0, x1, std::move(doors), m);
  }
  void WallAlongY(double x, double y0, double y1, std::vector<Opening> doors, const Material& m,
                  double x_offset = 0) {
    Wall(false, x + x_offset, y0, y1, std::move(doors), m);
  }

  // Furniture, axis-aligned, footprint [x0, x1] x [y0, y1].
  // Desks and chairs stand on legs, but what a planner and the maps see of them is their
  // outline: it is listed with the furniture.
  void Desk(double x0, double y0, double x1, double y1) {
    const double top = 0.74;
    b_.AddBlock({x0, y0, top - 0.03}, {x1, y1, top}, SameMaterial(wood_));
    AddFootprint(&world_->furniture_faces, {x0, y0, 0}, {x1, y1, top});
    for (double x : {x0 + 0.03, x1 - 0.08}) {
      for (double y : {y0 + 0.03, y1 - 0.08}) {
        b_.AddBlock({x, y, 0}, {x + 0.05, y + 0.05, top - 0.03}, SameMaterial(metal_));
      }
    }
    // A monitor on the desk.
    const double cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    b_.AddBlock({cx - 0.25, cy - 0.03, top + 0.12}, {cx + 0.25, cy + 0.03, top + 0.45},
                SameMaterial(dark_));
    b_.AddBlock({cx - 0.04, cy - 0.04, top}, {cx + 0.04, cy + 0.04, top + 0.12},
                SameMaterial(dark_));
  }
  void Chair(double x, double y) {
    b_.AddBlock({x - 0.22, y - 0.22, 0.42}, {x + 0.22, y + 0.22, 0.48}, SameMaterial(dark_));
    AddFootprint(&world_->furniture_faces, {x - 0.22, y - 0.22, 0}, {x + 0.22, y + 0.22, 0.95});
    b_.AddBlock({x - 0.22, y + 0.17, 0.48}, {x + 0.22, y + 0.22, 0.95}, SameMaterial(dark_));
    b_.AddBlock({x - 0.03, y - 0.03, 0}, {x + 0.03, y + 0.03, 0.42}, SameMaterial(metal_));
  }
  void Cabinet(double x0, double y0, double x1, double y1, double height) {
    AddSolid({x0, y0, 0}, {x1, y1, height}, SameMaterial(metal_));
  }
  // A bookshelf whose open side faces `facing` (+x, -x, +y or -y as 0, 1, 2, 3).
  void Bookshelf(double x0, double y0, double x1, double y1, int facing) {
    const double height = 1.9;
    BoxMaterials m = SameMaterial(wood_);
    AddSolid({x0, y0, 0}, {x1, y1, height}, m);
    // Rows of books standing a little proud of the frame on the open side.
    const double shelf_z[4] = {0.1, 0.55, 1.0, 1.45};
    for (int row = 0; row < 4; ++row) {
      BoxMaterials books = SameMaterial(dark_);
      books[static_cast<size_t>(facing)] = {books_[row % 3], 0};
      Vector3d lo(x0, y0, shelf_z[row]), hi(x1, y1, shelf_z[row] + 0.36);
      const double proud = 0.01;
      switch (facing) {
        case 0:
          lo.x() = x1 - 0.2;
          hi.x() = x1 + proud;
          lo.y() += 0.03;
          hi.y() -= 0.03;
          break;
        case 1:
          lo.x() = x0 - proud;
          hi.x() = x0 + 0.2;
          lo.y() += 0.03;
          hi.y() -= 0.03;
          break;
        case 2:
          lo.y() = y1 - 0.2;
          hi.y() = y1 + proud;
          lo.x() += 0.03;
          hi.x() -= 0.03;
          break;
        default:
          lo.y() = y0 - proud;
          hi.y() = y0 + 0.2;
          lo.x() += 0.03;
          hi.x() -= 0.03;
          break;
      }
      b_.AddBlock(lo, hi, books);
    }
  }
  void Plant(double x, double y) {
    AddSolid({x - 0.18, y - 0.18, 0}, {x + 0.18, y + 0.18, 0.4}, SameMaterial(dark_));
    b_.AddBlock({x - 0.3, y - 0.3, 0.4}, {x + 0.3, y + 0.3, 1.3}, SameMaterial(plant_));
  }
  void Bench(double x0, double y0, double x1, double y1) {
    AddSolid({x0, y0, 0}, {x1, y1, 0.45}, SameMaterial(wood_));
  }

  // A generic office room: desks with chairs, a cabinet, a bookshelf and a plant, placed along
  // the walls so that the middle stays free.
  // `cabinet_at`: where along the north wall the cabinet starts (share of the width); rooms
  // south of corridor H have their doors in that wall and keep them clear.
  void FurnishRoom(double x0, double y0, double x1, double y1, double cabinet_at = 0.3) {
    const double w = x1 - x0, d = y1 - y0;
    Desk(x0 + 0.3, y0 + 0.35 * d, x0 + 1.0, y0 + 0.35 * d + 1.4);
    Chair(x0 + 1.25, y0 + 0.35 * d + 0.7);
    Desk(x1 - 1.0, y0 + 0.55 * d, x1 - 0.3, y0 + 0.55 * d + 1.4);
    Chair(x1 - 1.25, y0 + 0.55 * d + 0.7);
    Cabinet(x0 + cabinet_at * w, y1 - 0.5, x0 + cabinet_at * w + 0.9, y1 - 0.08, 1.8);
    Bookshelf(x0 + 0.6 * w, y0 + 0.08, x0 + 0.6 * w + 1.0, y0 + 0.4, 2);
    Plant(x1 - 0.5, y1 - 0.5);
  }

  // Posters on the solid stretches of every wall face, spaced at random.
  void Posters() {
    for (const Stretch& s : stretches_) {
      double at = s.from + rng_.Uniform(0.4, 1.5);
      while (true) {
        const double w = rng_.Uniform(0.45, 0.8), h = w * rng_.Uniform(1.2, 1.5);
        if (at + w > s.to - 0.3) break;
        if (rng_.Uniform() < 0.6) {
          const double top = rng_.Uniform(1.6, 1.95);
          const int tex = posters_[static_cast<size_t>(
              rng_.UniformInt(0, static_cast<int>(posters_.size()) - 1))];
          // Seen from the side the face looks at (forward = -normal): right = up x normal.
          const Vector3d normal(s.along_x ? 0 : s.sign, s.along_x ? s.sign : 0, 0);
          const Vector3d right = Vector3d::UnitZ().cross(normal);
          const Vector3d dir = s.along_x ? Vector3d::UnitX() : Vector3d::UnitY();
          const double sgn = right.dot(dir) > 0 ? 1.0 : -1.0;
          const double start = sgn > 0 ? at : at + w;
          Vector3d top_left =
              s.along_x ? Vector3d(start, s.plane, top) : Vector3d(s.plane, start, top);
          top_left += normal * 0.004;
          b_.AddPanel(top_left, dir * (sgn * w), {0, 0, -h}, {tex, 0});
        }
        at += w + rng_.Uniform(0.8, 3.0);
      }
    }
  }

 private:
  // A solid stretch of a wall face (for posters): the face's plane coordinate, its extent along
  // the wall and which way it faces.
  struct Stretch {
    bool along_x;
    double plane, from, to;
    double sign;  // +1: faces +y (or +x), -1: faces -y (or -x)
  };

  void AddSolid(const Vector3d& lo, const Vector3d& hi, const BoxMaterials& m) {
    b_.AddBlock(lo, hi, m);
    AddFootprint(&world_->furniture_faces, lo, hi);
  }
  static void AddFootprint(std::vector<dataset::WallSegment>* out, const Vector3d& lo,
                           const Vector3d& hi) {
    out->push_back({lo.x(), lo.y(), hi.x(), lo.y()});
    out->push_back({hi.x(), lo.y(), hi.x(), hi.y()});
    out->push_back({hi.x(), hi.y(), lo.x(), hi.y()});
    out->push_back({lo.x(), hi.y(), lo.x(), lo.y()});
  }

  // Solid segments between the openings, a lintel over each opening, frames around it, and
  // skirting boards along both faces.
  void Wall(bool along_x, double c, double from, double to, std::vector<Opening> doors,
            const Material& m) {
    std::sort(doors.begin(), doors.end(), [](auto& a, auto& b) { return a.from < b.from; });
    const auto box = [&](double a0, double a1, double c0, double c1, double z0, double z1) {
      return along_x ? std::pair(Vector3d(a0, c0, z0), Vector3d(a1, c1, z1))
                     : std::pair(Vector3d(c0, a0, z0), Vector3d(c1, a1, z1));
    };
    const double c0 = c - kWallT / 2, c1 = c + kWallT / 2;
    std::vector<std::pair<double, double>> solid;
    double at = from - kWallT / 2;  // close the corners
    for (const Opening& d : doors) {
      solid.push_back({at, d.from});
      at = d.to;
    }
    solid.push_back({at, to + kWallT / 2});
    for (const auto& [a0, a1] : solid) {
      if (a1 - a0 < 1e-6) continue;
      const auto [lo, hi] = box(a0, a1, c0, c1, 0, kH);
      b_.AddBlock(lo, hi, SameMaterial(m));
      AddFootprint(&world_->wall_faces, lo, hi);
      for (double side : {-1.0, 1.0}) {
        const double f0 = side < 0 ? c0 - kFrameOut : c1, f1 = side < 0 ? c0 : c1 + kFrameOut;
        const auto [slo, shi] = box(a0, a1, f0, f1, 0, kSkirtH);
        b_.AddBlock(slo, shi, SameMaterial(dark_));
        stretches_.push_back({along_x, side < 0 ? c0 : c1, a0, a1, side});
      }
    }
    for (const Opening& d : doors) {
      const auto [llo, lhi] = box(d.from, d.to, c0, c1, kDoorH, kH);
      b_.AddBlock(llo, lhi, SameMaterial(m));
      const double f0 = c0 - kFrameOut, f1 = c1 + kFrameOut;
      for (const auto& [a0, a1] :
           {std::pair(d.from - kFrameW, d.from), std::pair(d.to, d.to + kFrameW)}) {
        const auto [jlo, jhi] = box(a0, a1, f0, f1, 0, kDoorH + kFrameW);
        b_.AddBlock(jlo, jhi, SameMaterial(frame_));
        AddFootprint(&world_->wall_faces, jlo, jhi);
      }
      const auto [hlo, hhi] = box(d.from, d.to, f0, f1, kDoorH, kDoorH + kFrameW);
      b_.AddBlock(hlo, hhi, SameMaterial(frame_));
      // The open door leaf rests against the wall on the positive side.
      const auto [dlo, dhi] = box(d.to + kFrameW, d.to + kFrameW + (d.to - d.from), c1 + 0.02,
                                  c1 + 0.06, 0.01, kDoorH - 0.02);
      b_.AddBlock(dlo, dhi, SameMaterial(wood_));
    }
  }

  BuildingWorld* world_;
  SceneBuilder b_;
  Rng rng_;
  std::vector<Stretch> stretches_;

 public:
  Material paint_corridor_, paint_room_, paint_plain_, floor_, ceiling_, wood_, dark_, metal_,
      frame_, plant_;
  int books_[3] = {0, 0, 0};
  std::vector<int> posters_;
};

}  // namespace

BuildingWorld BuildBuilding(uint64_t seed) {
  BuildingWorld world;
  world.scene.channels = 1;
  Furnisher f(&world, seed);
  const double W = kBuildingWidthM, D = kBuildingDepthM;
  f.FloorAndCeiling();

  // Outer walls, inner faces on the boundary.
  f.WallAlongX(0, 0, W, {}, f.paint_plain_, -kWallT / 2);
  f.WallAlongX(D, 0, W, {}, f.paint_plain_, kWallT / 2);
  f.WallAlongY(0, 0, D, {}, f.paint_plain_, -kWallT / 2);
  f.WallAlongY(W, 0, D, {}, f.paint_plain_, kWallT / 2);
  // Corridor walls: corridor H at y in [13, 15.5], corridor V at x in [13, 15.5].
  f.WallAlongX(13.0, 0, 13.0, {{2.95, 3.85}, {9.5, 10.4}}, f.paint_corridor_);
  f.WallAlongX(13.0, 15.5, W, {{18.0, 18.9}, {24.0, 24.9}}, f.paint_corridor_);
  f.WallAlongX(15.5, 0, 13.0, {{3.0, 3.9}, {9.5, 10.4}}, f.paint_corridor_);
  f.WallAlongX(15.5, 15.5, W, {{24.0, 24.9}}, f.paint_corridor_);
  f.WallAlongY(13.0, 0, 13.0, {{7.0, 7.9}}, f.paint_corridor_);
  f.WallAlongY(13.0, 15.5, D, {{24.0, 24.9}}, f.paint_corridor_);
  f.WallAlongY(15.5, 0, 13.0, {{7.0, 7.9}}, f.paint_corridor_);
  f.WallAlongY(15.5, 15.5, D, {{20.55, 21.45}}, f.paint_corridor_);
  // Room dividers.
  f.WallAlongY(6.5, 0, 13.0, {}, f.paint_room_);
  f.WallAlongY(6.5, 15.5, D, {}, f.paint_room_);
  f.WallAlongY(21.75, 0, 13.0, {}, f.paint_room_);
  f.WallAlongY(21.75, 15.5, D, {}, f.paint_room_);

  // Room R1 (start, x 0-6.5, y 0-13): keep the band x 2.6-4.2 north of y 5 free.
  f.Desk(0.4, 8.0, 1.8, 8.7);
  f.Chair(1.1, 9.1);
  f.Desk(0.4, 3.0, 1.8, 3.7);
  f.Chair(1.1, 4.1);
  f.Cabinet(5.7, 9.0, 6.38, 10.0, 1.9);
  f.Bookshelf(2.0, 0.08, 3.0, 0.42, 2);
  f.Bookshelf(6.06, 4.0, 6.4, 5.2, 1);
  f.Plant(5.8, 12.3);
  f.Desk(4.6, 2.0, 5.3, 3.4);
  // Room R7 (x 15.5-21.75, y 15.5-28.5): the route loops around a desk island.
  f.Desk(17.6, 22.3, 18.9, 23.0);
  f.Desk(17.6, 23.4, 18.9, 24.1);
  f.Chair(18.25, 22.0);
  f.Cabinet(21.25, 17.0, 21.68, 18.0, 1.6);
  f.Bookshelf(17.0, 28.08, 18.0, 28.42, 3);
  f.Bookshelf(15.58, 23.8, 15.92, 25.0, 0);
  f.Desk(18.0, 15.6, 19.4, 16.3);
  f.Plant(21.2, 27.9);
  f.Plant(16.0, 27.9);
  // The other rooms, seen through their doors.
  f.FurnishRoom(6.56, 0.06, 12.94, 12.94);
  f.FurnishRoom(15.56, 0.06, 21.69, 12.94, 0.05);  // door at x 18.0-18.9
  f.FurnishRoom(21.81, 0.06, 27.94, 12.94, 0.05);  // door at x 24.0-24.9
  f.FurnishRoom(0.06, 15.56, 6.44, 28.44);
  f.FurnishRoom(6.56, 15.56, 12.94, 28.44);
  f.FurnishRoom(21.81, 15.56, 27.94, 28.44);
  // Corridors: benches, plants and cabinets against the walls (the middle stays free).
  f.Bench(7.0, 13.07, 8.6, 13.5);
  f.Plant(0.5, 15.0);
  f.Plant(27.5, 13.5);
  f.Bench(20.0, 15.0, 21.6, 15.43);
  f.Cabinet(15.0, 10.0, 15.43, 11.0, 1.4);
  f.Plant(13.5, 3.0);
  f.Cabinet(13.07, 18.0, 13.5, 19.2, 1.2);
  f.Plant(15.0, 27.9);
  f.Posters();
  f.WalkerClothes(seed);
  return world;
}

std::vector<Eigen::Vector2d> BuildingRoute(const std::string& name) {
  if (name == "corridors") {
    return {{3.4, 6.5},   {3.4, 14.25}, {14.25, 14.25}, {14.25, 21.0}, {19.5, 21.0},
            {19.5, 25.5}, {17.0, 25.5}, {17.0, 21.0},   {14.25, 21.0}, {14.25, 6.6}};
  }
  if (name == "rooms") {
    // Corridor H's centre line is y = 14.25; its doors are at x = 3.4 (R1, R5), 9.95 (R2, R6),
    // 18.45 (R3) and 24.45 (R4, R8). The robot stands 1.75 m inside each room (y = 11.25 or
    // 17.25), clear of the furniture, and looks around there.
    constexpr double kMid = 14.25, kSouth = 13.0 - 1.75, kNorth = 15.5 + 1.75;
    return {{3.4, 6.5},    {3.4, kMid},     {3.4, kNorth},   {3.4, kMid},
            {9.95, kMid},  {9.95, kNorth},  {9.95, kMid},    {9.95, kSouth},
            {9.95, kMid},  {18.45, kMid},   {18.45, kSouth}, {18.45, kMid},
            {24.45, kMid}, {24.45, kSouth}, {24.45, kMid},   {24.45, kNorth}};
  }
  throw std::invalid_argument("unknown building route '" + name + "' (corridors or rooms)");
}

Eigen::Isometry3d WalkerPose(double t) {
  constexpr double kEastX = 12.5, kWestX = 4.5, kY = 15.0, kSpeed = 1.1, kPauseS = 1.5;
  constexpr double kLegS = (kEastX - kWestX) / kSpeed;
  constexpr double kCycleS = 2 * (kLegS + kPauseS);
  const double tau = t - kCycleS * std::floor(t / kCycleS);
  double x = kEastX, yaw = std::numbers::pi;  // walking west
  if (tau < kLegS) {
    x = kEastX - kSpeed * tau;
  } else if (tau < kLegS + kPauseS) {
    x = kWestX;
    yaw = std::numbers::pi * (1 - (tau - kLegS) / kPauseS);  // turning round
  } else if (tau < 2 * kLegS + kPauseS) {
    x = kWestX + kSpeed * (tau - kLegS - kPauseS);
    yaw = 0;
  } else {
    yaw = std::numbers::pi * (tau - 2 * kLegS - kPauseS) / kPauseS;
  }
  // A sway from foot to foot (two steps a second) while walking.
  const bool walking = tau < kLegS || (tau >= kLegS + kPauseS && tau < 2 * kLegS + kPauseS);
  const double sway = walking ? 0.03 * std::sin(2 * std::numbers::pi * t) : 0.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Vector3d(x, kY, 0) + T.linear() * Vector3d(0, sway, 0);
  return T;
}

std::vector<Quad> WalkerQuads(const BuildingWorld& world, const Eigen::Isometry3d& pose) {
  std::vector<Quad> quads;
  Rng rng(1, Stream::kObjectMotion, 3);  // the same texture offsets every frame
  const Lighting lighting;               // the world's (SceneBuilder's default)
  const auto box = [&](double z0, double z1, double width, double depth, const Material& m) {
    Eigen::Isometry3d at = pose;
    at.translate(Vector3d(0, 0, (z0 + z1) / 2));
    MakeBox(world.scene, lighting, rng, at, Vector3d(depth, width, z1 - z0), SameMaterial(m), 1,
            &quads);
  };
  box(0.0, 0.86, 0.34, 0.22, world.walker_trousers);
  box(0.86, 1.50, 0.46, 0.26, world.walker_shirt);
  box(1.51, kWalkerHeightM, 0.19, 0.22, world.walker_skin);
  return quads;
}

}  // namespace epmap::sim
