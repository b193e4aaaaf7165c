#include "clients/sim/head_world.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "clients/sim/texture_library.h"

namespace epmap::sim {

namespace {

using Eigen::Vector3d;
constexpr double kDeg = std::numbers::pi / 180.0;

// Room extent (world = head base frame).
constexpr double kFloorZ = -1.05, kCeilingZ = 1.35;
constexpr double kBackX = 2.6, kRearX = -1.0, kSideY = 1.7;
constexpr double kTableTopZ = -0.30;

Eigen::Isometry3d Pose(const Vector3d& centre, double yaw_deg, double pitch_deg = 0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = centre;
  T.linear() = (Eigen::AngleAxisd(yaw_deg * kDeg, Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch_deg * kDeg, Vector3d::UnitY()))
                   .toRotationMatrix();
  return T;
}

}  // namespace

HeadRoom BuildHeadRoom(uint64_t seed) {
  HeadRoom room;
  room.seed = seed;
  room.scene.channels = 3;
  Rng tex_rng(seed, Stream::kTextures);
  SceneBuilder b(&room.scene, Rng(seed, Stream::kWorldLayout), room.lighting);
  namespace tx = textures;

  // --- Textures (BGR). Painted walls carry some texture, a few surfaces are plain.
  const int wall_back = b.AddTexture(tx::Paint(tex_rng, 512, {196, 214, 226}, 7.0));
  const int wall_left = b.AddTexture(tx::Paint(tex_rng, 512, {190, 215, 195}, 4.0));
  const int wall_plain = b.AddTexture(tx::Paint(tex_rng, 256, {222, 206, 196}, 1.2));
  const int white_plain = b.AddTexture(tx::Paint(tex_rng, 256, {232, 234, 236}, 1.0));
  const int carpet = b.AddTexture(tx::Fabric(tex_rng, 512, {120, 105, 95}, 20.0));
  const int oak = b.AddTexture(tx::Wood(tex_rng, 1024, {120, 170, 205}, {60, 105, 150}, true));
  const int walnut = b.AddTexture(tx::Wood(tex_rng, 512, {60, 90, 125}, {25, 45, 70}));
  const int poster_tall = b.AddTexture(tx::Poster(tex_rng, 512, 1024));
  const int poster_wide = b.AddTexture(tx::Poster(tex_rng, 1024, 512));
  const int cereal_front = b.AddTexture(tx::Poster(tex_rng, 256, 512));
  const int cereal_side = b.AddTexture(tx::Poster(tex_rng, 128, 512));
  const int screen = b.AddTexture(tx::Poster(tex_rng, 512, 256));
  const int books[3] = {b.AddTexture(tx::Books(tex_rng, 1024, 256)),
                        b.AddTexture(tx::Books(tex_rng, 1024, 256)),
                        b.AddTexture(tx::Books(tex_rng, 1024, 256))};
  const int covers[3] = {b.AddTexture(tx::Paint(tex_rng, 256, {40, 40, 170}, 5.0)),
                         b.AddTexture(tx::Paint(tex_rng, 256, {150, 80, 30}, 5.0)),
                         b.AddTexture(tx::Paint(tex_rng, 256, {50, 140, 60}, 5.0))};
  const int pages = b.AddTexture(tx::Fabric(tex_rng, 256, {215, 225, 228}, 10.0));
  const int dark_plastic = b.AddTexture(tx::Paint(tex_rng, 256, {55, 55, 60}, 2.0));
  const int mug = b.AddTexture(tx::Fabric(tex_rng, 256, {40, 60, 190}, 12.0));
  room.toy_material = {b.AddTexture(tx::Toy(tex_rng, 256)), 2560.0, 1.0F};

  const Material m_back{wall_back, 400}, m_left{wall_left, 400}, m_plain_wall{wall_plain, 300};
  const Material m_white{white_plain, 300}, m_carpet{carpet, 500}, m_oak{oak, 900};
  const Material m_walnut{walnut, 700}, m_dark{dark_plastic, 800}, m_pages{pages, 1500};
  const double H = kCeilingZ - kFloorZ;

  // --- Shell: walls face inwards.
  b.AddPanel({kBackX, kSideY, kCeilingZ}, {0, -2 * kSideY, 0}, {0, 0, -H}, m_back);
  b.AddPanel({kRearX, kSideY, kCeilingZ}, {kBackX - kRearX, 0, 0}, {0, 0, -H}, m_left);
  b.AddPanel({kBackX, -kSideY, kCeilingZ}, {kRearX - kBackX, 0, 0}, {0, 0, -H}, m_plain_wall);
  b.AddPanel({kRearX, -kSideY, kCeilingZ}, {0, 2 * kSideY, 0}, {0, 0, -H}, m_plain_wall);
  b.AddPanel({kBackX, kSideY, kFloorZ}, {0, -2 * kSideY, 0}, {kRearX - kBackX, 0, 0}, m_carpet);
  b.AddPanel({kBackX, -kSideY, kCeilingZ}, {0, 2 * kSideY, 0}, {kRearX - kBackX, 0, 0}, m_white);
  // Skirting boards along the walls the head can see.
  b.AddBlock({kBackX - 0.015, -kSideY, kFloorZ}, {kBackX, kSideY, kFloorZ + 0.10},
             SameMaterial(m_white));
  b.AddBlock({kRearX, kSideY - 0.015, kFloorZ}, {kBackX, kSideY, kFloorZ + 0.10},
             SameMaterial(m_white));
  b.AddBlock({kRearX, -kSideY, kFloorZ}, {kBackX, -kSideY + 0.015, kFloorZ + 0.10},
             SameMaterial(m_white));

  // --- Posters and a framed picture, a few mm off the walls.
  b.AddPanel({kBackX - 0.004, 0.25, 0.80}, {0, -0.60, 0}, {0, 0, -0.85}, {poster_tall, 0});
  b.AddPanel({kBackX - 0.004, -0.55, 0.55}, {0, -0.80, 0}, {0, 0, -0.40}, {poster_wide, 0});
  b.AddPanel({1.9, kSideY - 0.004, 0.60}, {0.60, 0, 0}, {0, 0, -0.85}, {screen, 0});
  b.AddBlock({0.4, kSideY - 0.03, -0.1}, {1.2, kSideY, 0.45}, SameMaterial(m_walnut));
  b.AddPanel({0.45, kSideY - 0.031, 0.40}, {0.70, 0, 0}, {0, 0, -0.45}, {poster_wide, 0});

  // --- A door with its frame on the right wall.
  b.AddPanel({0.3, -kSideY + 0.004, 0.95}, {0.9, 0, 0}, {0, 0, -2.0}, {walnut, 600, 0.9F});
  b.AddBlock({0.22, -kSideY, kFloorZ}, {0.30, -kSideY + 0.025, 1.03}, SameMaterial(m_white));
  b.AddBlock({1.20, -kSideY, kFloorZ}, {1.28, -kSideY + 0.025, 1.03}, SameMaterial(m_white));
  b.AddBlock({0.22, -kSideY, 0.95}, {1.28, -kSideY + 0.025, 1.03}, SameMaterial(m_white));

  // --- Bookshelf against the back wall, left side: boards, back panel, three rows of books.
  {
    const double x0 = 2.25, x1 = 2.585, y0 = 0.55, y1 = 1.45, top = 0.75;
    const BoxMaterials wood = SameMaterial(m_walnut);
    b.AddBlock({x0, y0, kFloorZ}, {x1, y0 + 0.02, top}, wood);
    b.AddBlock({x0, y1 - 0.02, kFloorZ}, {x1, y1, top}, wood);
    b.AddBlock({x1 - 0.01, y0, kFloorZ}, {x1, y1, top}, wood);
    const double shelves[5] = {kFloorZ + 0.08, -0.55, -0.12, 0.31, top - 0.02};
    for (double z : shelves) b.AddBlock({x0, y0 + 0.02, z - 0.02}, {x1 - 0.01, y1 - 0.02, z}, wood);
    for (int row = 0; row < 3; ++row) {
      const double z = shelves[row + 1];
      BoxMaterials m = SameMaterial({dark_plastic, 800, 0.5F});
      m[1] = {books[row], 0};  // -x face, towards the head
      b.AddBlock({x0 + 0.05, y0 + 0.02, z}, {x1 - 0.02, y1 - 0.02, z + 0.36}, m);
    }
  }

  // --- Cabinet (plain) with a printer-like box on it, back right.
  b.AddBlock({1.95, -kSideY + 0.01, kFloorZ}, {kBackX - 0.01, -0.95, -0.18}, SameMaterial(m_white));
  b.AddBox(Pose({2.25, -1.3, -0.06}, 8), {0.42, 0.40, 0.24}, SameMaterial(m_dark));

  // --- Table with legs.
  const double tx0 = 0.42, tx1 = 1.22, ty = 0.75;
  b.AddBlock({tx0, -ty, kTableTopZ - 0.035}, {tx1, ty, kTableTopZ}, SameMaterial(m_oak));
  for (double lx : {tx0 + 0.03, tx1 - 0.08}) {
    for (double ly : {-ty + 0.03, ty - 0.08}) {
      b.AddBlock({lx, ly, kFloorZ}, {lx + 0.05, ly + 0.05, kTableTopZ - 0.035},
                 SameMaterial(m_oak));
    }
  }

  // --- Things on the table (z = kTableTopZ is their base).
  const auto on_table = [&](double x, double y, double height) {
    return Vector3d(x, y, kTableTopZ + height / 2);
  };
  {  // cereal box: printed front towards the head
    BoxMaterials m = SameMaterial({cereal_side, 0});
    m[1] = {cereal_front, 0};
    m[4] = m[5] = m_white;
    b.AddBox(Pose(on_table(1.0, 0.34, 0.28), -20), {0.07, 0.19, 0.28}, m);
  }
  {  // a stack of three books
    double z = kTableTopZ;
    const double thickness[3] = {0.032, 0.026, 0.038};
    const double yaw[3] = {4, -9, 13};
    for (int i = 0; i < 3; ++i) {
      BoxMaterials m = SameMaterial(m_pages);
      m[4] = m[5] = {covers[i], 900};
      m[1] = {covers[i], 900};  // the spine faces the head
      b.AddBox(Pose({0.74, -0.40, z + thickness[i] / 2}, yaw[i]), {0.17, 0.24, thickness[i]}, m);
      z += thickness[i];
    }
  }
  {  // laptop: base and a screen tilted back
    b.AddBox(Pose(on_table(1.02, -0.08, 0.02), -12), {0.23, 0.33, 0.02}, SameMaterial(m_dark));
    BoxMaterials m = SameMaterial(m_dark);
    m[1] = {screen, 0, 0.95F};
    const Eigen::Isometry3d base = Pose(on_table(1.02, -0.08, 0.02), -12);
    const Eigen::Isometry3d hinge = base * Pose({0.115, 0, 0.01}, 0, -14);
    b.AddBox(hinge * Pose({0.006, 0, 0.11}, 0), {0.012, 0.33, 0.22}, m);
  }
  b.AddBox(Pose(on_table(0.60, 0.46, 0.09), 25), {0.12, 0.12, 0.09}, SameMaterial(m_white));
  b.AddBox(Pose(on_table(0.63, 0.06, 0.10), 10), {0.08, 0.08, 0.10}, SameMaterial({mug, 1500}));
  b.AddBox(Pose(on_table(0.92, 0.62, 0.11), -5), {0.07, 0.07, 0.11}, SameMaterial(m_oak));
  b.AddBox(Pose(on_table(0.55, -0.62, 0.05), 30), {0.09, 0.14, 0.05}, SameMaterial(m_walnut));
  return room;
}

std::optional<Eigen::Isometry3d> ToyPose(uint64_t seed, double t) {
  // In each cycle: away for kAwayS, then a pass of kPassS seconds across the field of view.
  constexpr double kAwayS = 1.0, kPassS = kToyCycleS - kAwayS - 0.1;
  const double cycle_index = std::floor(t / kToyCycleS);
  const double tau = t - cycle_index * kToyCycleS - kAwayS;
  if (tau < 0 || tau >= kPassS) return std::nullopt;
  Rng rng(seed, Stream::kObjectMotion, static_cast<uint64_t>(cycle_index));
  const double side = rng.Uniform() < 0.5 ? 1.0 : -1.0;
  const double distance = rng.Uniform(0.58, 0.82);
  const double height = rng.Uniform(-0.16, -0.02);
  const SmoothSignal wiggle_d(rng, 0.10, 0.2, 0.6), wiggle_z(rng, 0.05, 0.2, 0.6),
      wiggle_b(rng, 8 * kDeg, 0.2, 0.5), spin(rng, 0.5, 0.05, 0.2);
  // Bearing from one side (65 degrees, outside the view even when the head turns) to the
  // other: fast at both ends, slow in the middle where it is seen.
  const double s = tau / kPassS;
  constexpr double kSlowMiddle = 0.3;
  const double progress =
      s + kSlowMiddle * std::sin(2 * std::numbers::pi * s) / (2 * std::numbers::pi);
  const double bearing =
      side * 65 * kDeg * (1 - 2 * progress) + std::sin(std::numbers::pi * s) * wiggle_b(t);
  const double r = std::clamp(distance + wiggle_d(t), 0.55, 0.95);
  const Vector3d eyes(0.06, 0, 0.12);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() =
      eyes + Vector3d(r * std::cos(bearing), r * std::sin(bearing), height + wiggle_z(t) - 0.12);
  T.linear() = (Eigen::AngleAxisd(1.3 * t + spin(t), Vector3d::UnitZ()) *
                Eigen::AngleAxisd(0.4 * std::sin(0.9 * t), Vector3d::UnitX()))
                   .toRotationMatrix();
  return T;
}

std::vector<Quad> ToyQuads(const HeadRoom& room, const Eigen::Isometry3d& pose) {
  std::vector<Quad> quads;
  Rng rng(room.seed, Stream::kObjectMotion, 1u << 30);  // same texture offsets every frame
  MakeBox(room.scene, room.lighting, rng, pose, Vector3d::Constant(kToyEdgeM),
          SameMaterial(room.toy_material), 1, &quads);
  return quads;
}

}  // namespace epmap::sim
