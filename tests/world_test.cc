#include "calib/sim/world.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>
#include <string>

#include "calib/core/errors.h"

namespace calib {
namespace {

// A 10 m x 10 m room centred at the origin, walls 3 m high.
World SquareRoom() {
  return World::Parse(
      "height 3\n"
      "wall -5 -5  5 -5\n"
      "wall  5 -5  5  5\n"
      "wall  5  5 -5  5\n"
      "wall -5  5 -5 -5\n",
      "room");
}

// The reference the grid must reproduce: every segment, the same formula.
struct Hit {
  double t = kNoHit;
  int segment = -1;
};

Hit BruteForce(const World& world, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
               double max_range, bool three_d) {
  Hit best;
  if (three_d && d.z() < 0.0 && o.z() >= 0.0) best.t = -o.z() / d.z();
  const auto& segments = world.segments();
  for (int i = 0; i < static_cast<int>(segments.size()); ++i) {
    const WallSegment& s = segments[i];
    const Eigen::Vector2d e = s.b - s.a, w = s.a - o.head<2>();
    const double denom = d.x() * e.y() - d.y() * e.x();
    // Grazing rays (within 1e-12 rad of the wall's direction) miss it.
    if (std::abs(denom) <= 1e-12 * d.head<2>().norm() * e.norm()) continue;
    const double t = (w.x() * e.y() - w.y() * e.x()) / denom;
    const double u = (w.x() * d.y() - w.y() * d.x()) / denom;
    if (t < 0.0 || u < 0.0 || u > 1.0 || t >= best.t) continue;
    if (three_d) {
      const double z = o.z() + t * d.z();
      if (z < 0.0 || z > s.height) continue;
    }
    best = {t, i};
  }
  if (best.t > max_range) best = {kNoHit, -1};
  return best;
}

Hit BruteForce2d(const World& world, const Eigen::Vector2d& o, double angle, double max_range) {
  return BruteForce(world, Eigen::Vector3d(o.x(), o.y(), 0.0),
                    Eigen::Vector3d(std::cos(angle), std::sin(angle), 0.0), max_range, false);
}

// Expects `body` to throw InputError at `place` with a problem containing `words`.
template <typename F>
void ExpectInputError(F body, const std::string& place, const std::string& words) {
  try {
    body();
    ADD_FAILURE() << "no InputError; expected one at " << place << " about '" << words << "'";
  } catch (const InputError& e) {
    EXPECT_EQ(e.place(), place) << e.what();
    EXPECT_NE(e.problem().find(words), std::string::npos) << e.what();
  }
}

void ExpectParseError(const std::string& text, const std::string& place, const std::string& words) {
  ExpectInputError([&] { World::Parse(text, "test.world"); }, place, words);
}

TEST(WorldParseTest, ErrorsNameTheLine) {
  const std::string ok = "# a comment\nheight 2\nwall 0 0 1 0\n";
  ExpectParseError(ok + "shelf 0 0 1 1\n", "line 4", "unknown element 'shelf'");
  ExpectParseError(ok + "wall 0 0 1\n", "line 4", "wall takes 4 numbers");
  ExpectParseError(ok + "wall 0 0 1 1 2 3\n", "line 4", "got 6");
  ExpectParseError(ok + "box 0 0 1 x1\n", "line 4", "'x1' is not a number (field 4 of box)");
  ExpectParseError(ok + "box 0 0 1 1.5.2\n", "line 4", "'1.5.2' is not a number");
  ExpectParseError(ok + "box 0 0 1 nan\n", "line 4", "is not a number");
  ExpectParseError(ok + "box 2 0 1 1\n", "line 4", "negative or zero size");
  ExpectParseError(ok + "box 0 0 1 1 -1\n", "line 4", "height must be positive");
  ExpectParseError(ok + "pillar 0 0 -0.3\n", "line 4", "radius must be positive");
  ExpectParseError(ok + "pillar 0 0\n", "line 4", "pillar takes 3 numbers");
  ExpectParseError("height 0\nwall 0 0 1 0\n", "line 1", "height must be positive");
  ExpectParseError("height\n", "line 1", "height takes 1 number");
  ExpectParseError("\n\nwall 1 1 1 1\n", "line 3", "zero length");
  ExpectParseError("# nothing\n\n", "", "no wall, box or pillar");
}

TEST(WorldParseTest, ElementsBecomeSegments) {
  const World world = World::Parse(
      "wall 0 0 1 0   # default height 3\n"
      "height 2.5\n"
      "box 0 0 2 1\n"
      "pillar 5 5 0.5 7\n",
      "test.world");
  ASSERT_EQ(world.segments().size(), 1u + 4u + 16u);
  EXPECT_DOUBLE_EQ(world.segments()[0].height, 3.0);
  for (int i = 1; i < 5; ++i) EXPECT_DOUBLE_EQ(world.segments()[i].height, 2.5);
  for (int i = 5; i < 21; ++i) {
    const WallSegment& s = world.segments()[i];
    EXPECT_DOUBLE_EQ(s.height, 7.0);
    EXPECT_NEAR((s.a - Eigen::Vector2d(5, 5)).norm(), 0.5, 1e-12);
  }
}

TEST(WorldLoadTest, BundledNamesAndMissingFiles) {
  EXPECT_GT(World::Load("warehouse").segments().size(), 100u);
  EXPECT_EQ(World::Load("corridor").segments().size(), 4u);
  EXPECT_EQ(World::Load(AGVCAL_SOURCE_DIR "/config/worlds/corridor.world").segments().size(), 4u);
  ExpectInputError([] { World::Load("wearhouse"); }, "", "bundled: corridor, warehouse");
  ExpectInputError([] { World::Load("/nonexistent/x.world"); }, "", "cannot open");
}

TEST(WorldRay2dTest, SquareRoomAnalyticDistances) {
  const World room = SquareRoom();
  const Eigen::Vector2d p(1.0, 2.0);
  EXPECT_NEAR(room.CastRay2d(p, 0.0, 30.0), 4.0, 1e-12);
  EXPECT_NEAR(room.CastRay2d(p, M_PI / 2, 30.0), 3.0, 1e-12);
  EXPECT_NEAR(room.CastRay2d(p, M_PI, 30.0), 6.0, 1e-12);
  EXPECT_NEAR(room.CastRay2d(p, -M_PI / 2, 30.0), 7.0, 1e-12);
  // Diagonals: from (1, 2) at 45 deg the top wall (y = 5) comes first, at (4, 5).
  EXPECT_NEAR(room.CastRay2d(p, M_PI / 4, 30.0), 3.0 * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(room.CastRay2d(p, -3 * M_PI / 4, 30.0), 6.0 * std::sqrt(2.0), 1e-12);
  // Into the corner: both walls meet there.
  EXPECT_NEAR(room.CastRay2d({0, 0}, M_PI / 4, 30.0), 5.0 * std::sqrt(2.0), 1e-12);
}

TEST(WorldRay2dTest, MissesReturnNoHit) {
  const World room = SquareRoom();
  EXPECT_EQ(room.CastRay2d({1, 2}, 0.0, 3.9), kNoHit);        // wall at 4 m, beyond range
  EXPECT_NEAR(room.CastRay2d({1, 2}, 0.0, 4.0), 4.0, 1e-12);  // exactly at range: a hit
  // From outside the room, looking away from it.
  EXPECT_EQ(room.CastRay2d({8, 0}, 0.0, 100.0), kNoHit);
  // From outside, looking at it: enters the grid and hits the near wall.
  EXPECT_NEAR(room.CastRay2d({-20, 1}, 0.0, 100.0), 15.0, 1e-12);
  EXPECT_NEAR(room.CastRay2d({-20, 20}, -M_PI / 4, 100.0), 15.0 * std::sqrt(2.0), 1e-9);
  // A single wall, passed beside its end.
  const World wall = World::Parse("wall 0 0 0 1\n", "test");
  EXPECT_EQ(wall.CastRay2d({-1, 1.001}, 0.0, 10.0), kNoHit);
  EXPECT_NEAR(wall.CastRay2d({-1, 0.999}, 0.0, 10.0), 1.0, 1e-12);
  // An empty world sees nothing (and the floor, in 3D).
  const World empty;
  EXPECT_EQ(empty.CastRay2d({0, 0}, 1.0, 10.0), kNoHit);
  EXPECT_NEAR(empty.CastRay3d({0, 0, 2}, Eigen::Vector3d(0.6, 0, -0.8), 10.0), 2.5, 1e-12);
}

TEST(WorldRay2dTest, GridEqualsBruteForceInWarehouse) {
  const World world = World::Load("warehouse");
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> inside_x(-24, 24), inside_y(-19, 19), outside(-60, 60),
      angle(-M_PI, M_PI), range(0.5, 60);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    // Mostly from inside the hall; some from well outside the grid.
    const Eigen::Vector2d o = i % 10 == 0 ? Eigen::Vector2d(outside(rng), outside(rng))
                                          : Eigen::Vector2d(inside_x(rng), inside_y(rng));
    const double a = angle(rng), max_range = i % 2 ? 30.0 : range(rng);
    const double expected = BruteForce2d(world, o, a, max_range).t;
    const double got = world.CastRay2d(o, a, max_range);
    if (expected == kNoHit) {
      ASSERT_EQ(got, kNoHit) << "ray " << i << " from " << o.transpose() << " at " << a;
    } else {
      ++hits;
      ASSERT_NEAR(got, expected, 1e-9) << "ray " << i << " from " << o.transpose() << " at " << a;
    }
  }
  EXPECT_GT(hits, 10000);
}

// The grid's risky cases: rays along the axes (direction components exactly
// or nearly zero) and rays aimed exactly at segment endpoints (corners).
TEST(WorldRay2dTest, GridEqualsBruteForceOnAxesAndCorners) {
  const World world = World::Load("warehouse");
  auto expect_same = [&](const Eigen::Vector2d& o, double a) {
    const double expected = BruteForce2d(world, o, a, 30.0).t;
    const double got = world.CastRay2d(o, a, 30.0);
    if (expected == kNoHit) {
      EXPECT_EQ(got, kNoHit) << "from " << o.transpose() << " at " << a;
    } else {
      EXPECT_NEAR(got, expected, 1e-9) << "from " << o.transpose() << " at " << a;
    }
  };
  for (double x = -23; x <= 23; x += 0.5) {
    for (double y = -18; y <= 18; y += 0.5) {
      for (int k = 0; k < 8; ++k) expect_same({x, y}, k * M_PI / 4);
    }
  }
  for (const WallSegment& s : world.segments()) {
    for (const Eigen::Vector2d& o : {Eigen::Vector2d(0, 0), Eigen::Vector2d(-6.5, 4.25)}) {
      const Eigen::Vector2d d = s.a - o;
      expect_same(o, std::atan2(d.y(), d.x()));
    }
  }
  // 3D rays with exactly zero horizontal components.
  for (double x = -23; x <= 23; x += 0.5) {
    for (const Eigen::Vector3d& d : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, -1, 0),
                                     Eigen::Vector3d(0, 0.8, 0.6), Eigen::Vector3d(0, 0, -1)}) {
      const Eigen::Vector3d o(x, 0.25 * x, 1.0);
      const double expected = BruteForce(world, o, d, 30.0, true).t;
      const double got = world.CastRay3d(o, d, 30.0);
      if (expected == kNoHit) {
        EXPECT_EQ(got, kNoHit) << "from " << o.transpose() << " along " << d.transpose();
      } else {
        EXPECT_NEAR(got, expected, 1e-9) << "from " << o.transpose() << " along " << d.transpose();
      }
    }
  }
}

TEST(WorldRay3dTest, GridEqualsBruteForceInWarehouse) {
  const World world = World::Load("warehouse");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> x(-24, 24), y(-19, 19), z(0.0, 10.0), u(-1, 1);
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d o(x(rng), y(rng), z(rng));
    Eigen::Vector3d d(u(rng), u(rng), 0.4 * u(rng));
    d.normalize();
    const double expected = BruteForce(world, o, d, 100.0, true).t;
    const double got = world.CastRay3d(o, d, 100.0);
    if (expected == kNoHit) {
      ASSERT_EQ(got, kNoHit) << "ray " << i;
    } else {
      ASSERT_NEAR(got, expected, 1e-9) << "ray " << i;
    }
  }
}

TEST(WorldRay3dTest, FloorWallsAndLowBoxes) {
  const World room = World::Parse(
      "height 3\n"
      "wall -5 -5  5 -5\nwall  5 -5  5  5\nwall  5  5 -5  5\nwall -5  5 -5 -5\n"
      "box 3 -1 4 1 0.3\n",
      "room");
  const double h = 2.0;
  // Floor: distance h / -dir.z.
  for (const Eigen::Vector3d& d :
       {Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0.3, -0.4, -0.5), Eigen::Vector3d(-1, -1, -1)}) {
    const Eigen::Vector3d u = d.normalized();
    const Eigen::Vector3d o(0, 0, h);
    const double t = room.CastRay3d(o, u, 100.0);
    EXPECT_NEAR(t, h / -u.z(), 1e-12) << d.transpose();
    EXPECT_NEAR((o + t * u).z(), 0.0, 1e-12);
  }
  // A wall below its height: along -x, rising from z = 1 to 1.5 at x = -5.
  const Eigen::Vector3d up = Eigen::Vector3d(-1, 0, 0.1).normalized();
  EXPECT_NEAR(room.CastRay3d({0, 0, 1}, up, 100.0), 5.0 / -up.x(), 1e-12);
  // Above the wall's top: nothing to hit (the sky).
  EXPECT_EQ(room.CastRay3d({0, 0, 2.9}, Eigen::Vector3d(-1, 0, 0.1).normalized(), 100.0), kNoHit);
  EXPECT_EQ(room.CastRay3d({0, 0, 5}, Eigen::Vector3d(0, 0, 1), 100.0), kNoHit);
  // Horizontal at 1 m: passes above the 0.3 m box and hits the wall at x = 5.
  EXPECT_NEAR(room.CastRay3d({0, 0, 1}, Eigen::Vector3d(1, 0, 0), 100.0), 5.0, 1e-12);
  // Horizontal at 0.2 m: hits the box's near face at x = 3.
  EXPECT_NEAR(room.CastRay3d({0, 0, 0.2}, Eigen::Vector3d(1, 0, 0), 100.0), 3.0, 1e-12);
  // Descending to z = 0.2 at x = 3: hits the near face.
  const Eigen::Vector3d down = Eigen::Vector3d(3, 0, -0.8).normalized();
  EXPECT_NEAR(room.CastRay3d({0, 0, 1}, down, 100.0), std::sqrt(9 + 0.64), 1e-12);
  // Descending over the near face (z = 0.4 at x = 3): tops are not modelled,
  // so the ray hits the far face at x = 4 (z = 0.2).
  const Eigen::Vector3d over = Eigen::Vector3d(3, 0, -0.6).normalized();
  EXPECT_NEAR(room.CastRay3d({0, 0, 1}, over, 100.0), 4.0 / over.x(), 1e-12);
  // Range limit applies to the floor too.
  EXPECT_EQ(room.CastRay3d({0, 0, h}, Eigen::Vector3d(0, 0, -1), 1.9), kNoHit);
}

TEST(CastRayBoxTest, OutsideInsideAndMissing) {
  const Box3 box{Eigen::Vector3d(-1, -0.5, 0), Eigen::Vector3d(1, 0.5, 0.5)};
  EXPECT_NEAR(CastRayBox(box, {-5, 0, 0.2}, {1, 0, 0}, 100.0), 4.0, 1e-12);
  EXPECT_NEAR(CastRayBox(box, {5, 0, 0.2}, {-1, 0, 0}, 100.0), 4.0, 1e-12);
  const Eigen::Vector3d diag = Eigen::Vector3d(1, 1, 0).normalized();
  EXPECT_NEAR(CastRayBox(box, {-3, -2.5, 0.2}, diag, 100.0), 2.0 * std::sqrt(2.0), 1e-12);
  // From inside: the exit face.
  EXPECT_NEAR(CastRayBox(box, {0.5, 0, 0.2}, {1, 0, 0}, 100.0), 0.5, 1e-12);
  EXPECT_NEAR(CastRayBox(box, {0, 0, 0.1}, {0, 0, -1}, 100.0), 0.1, 1e-12);
  EXPECT_NEAR(CastRayBox(box, {0, 0, 0.1}, diag, 100.0), 0.5 * std::sqrt(2.0), 1e-12);
  // Missing: pointing away, passing beside, passing above, parallel outside a slab.
  EXPECT_EQ(CastRayBox(box, {-5, 0, 0.2}, {-1, 0, 0}, 100.0), kNoHit);
  EXPECT_EQ(CastRayBox(box, {-5, 0.6, 0.2}, {1, 0, 0}, 100.0), kNoHit);
  EXPECT_EQ(CastRayBox(box, {-5, 0, 0.6}, {1, 0, 0}, 100.0), kNoHit);
  EXPECT_EQ(CastRayBox(box, {-5, -2, 0.2}, diag, 100.0), kNoHit);
  // Beyond range.
  EXPECT_EQ(CastRayBox(box, {-5, 0, 0.2}, {1, 0, 0}, 3.9), kNoHit);
}

// Well-constrained scan matching: the 3x3 information matrix of point-to-line
// residuals n . (dt + dtheta * perp(q - s)) over the scan's hits, with the
// rotation scaled by a 10 m lever arm so the three directions compare.
Eigen::Matrix3d ScanInformation(const World& world, const Eigen::Vector2d& s, int beams,
                                double max_range, int* hits) {
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  *hits = 0;
  for (int j = 0; j < beams; ++j) {
    const double a = 2.0 * M_PI * j / beams;
    const Hit hit = BruteForce2d(world, s, a, max_range);
    if (hit.segment < 0) continue;
    ++*hits;
    const WallSegment& seg = world.segments()[hit.segment];
    const Eigen::Vector2d e = (seg.b - seg.a).normalized(), n(-e.y(), e.x());
    const Eigen::Vector2d q = s + hit.t * Eigen::Vector2d(std::cos(a), std::sin(a));
    const Eigen::Vector2d r = q - s;
    const Eigen::Vector3d j3(n.x(), n.y(), n.dot(Eigen::Vector2d(-r.y(), r.x())) / 10.0);
    info += j3 * j3.transpose();
  }
  return info;
}

TEST(BundledWorldsTest, WarehouseOpenAreaIsFree) {
  const World world = World::Load("warehouse");
  // No segment enters the open area x -10..10, y -9..9 (Liang-Barsky clip).
  for (const WallSegment& s : world.segments()) {
    double t0 = 0.0, t1 = 1.0;
    const Eigen::Vector2d d = s.b - s.a;
    const double p[4] = {-d.x(), d.x(), -d.y(), d.y()};
    const double q[4] = {s.a.x() + 10, 10 - s.a.x(), s.a.y() + 9, 9 - s.a.y()};
    bool outside = false;
    for (int k = 0; k < 4 && !outside; ++k) {
      if (p[k] == 0.0) {
        outside = q[k] < 0.0;
      } else if (p[k] < 0.0) {
        t0 = std::max(t0, q[k] / p[k]);
      } else {
        t1 = std::min(t1, q[k] / p[k]);
      }
    }
    EXPECT_TRUE(outside || t0 > t1) << "segment " << s.a.transpose() << " - " << s.b.transpose();
  }
  // Rays from the origin travel at least 8 m in every direction.
  for (int j = 0; j < 3600; ++j) {
    const double a = 2.0 * M_PI * j / 3600;
    EXPECT_GE(world.CastRay2d({0, 0}, a, 100.0), 8.0) << "angle " << a;
  }
}

TEST(BundledWorldsTest, WarehouseScansAreWellConstrained) {
  const World world = World::Load("warehouse");
  for (double x = -7; x <= 7; x += 1.75) {
    for (double y = -7; y <= 7; y += 1.75) {
      int hits = 0;
      const Eigen::Matrix3d info = ScanInformation(world, {x, y}, 720, 30.0, &hits);
      // Nearly every beam sees something within a 30 m lidar's range (from the
      // edges of the area the far outer walls are just beyond it).
      EXPECT_GT(hits, 0.9 * 720) << "at " << x << ", " << y;
      const double weakest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(info).eigenvalues()(0);
      EXPECT_GT(weakest / hits, 0.05) << "at " << x << ", " << y << "\n" << info;
    }
  }
}

TEST(BundledWorldsTest, CorridorIsFeatureless) {
  const World world = World::Load("corridor");
  for (const WallSegment& s : world.segments()) {
    const bool along_x = s.a.y() == s.b.y() && std::abs(s.a.y()) == 1.25;
    const bool end_cap = s.a.x() == s.b.x() && std::abs(s.a.x()) > 7.0 + 30.0;
    EXPECT_TRUE(along_x || end_cap) << s.a.transpose() << " - " << s.b.transpose();
  }
  for (double x = -7; x <= 7; x += 3.5) {
    for (double y = -1; y <= 1; y += 0.5) {
      for (int j = 0; j < 720; ++j) {
        const double a = 2.0 * M_PI * j / 720;
        const double t = world.CastRay2d({x, y}, a, 30.0);
        if (t == kNoHit) continue;
        EXPECT_NEAR(std::abs(y + t * std::sin(a)), 1.25, 1e-9);
      }
      int hits = 0;
      const Eigen::Matrix3d info = ScanInformation(world, {x, y}, 720, 30.0, &hits);
      EXPECT_GT(hits, 600);
      EXPECT_EQ(info(0, 0), 0.0);  // nothing constrains motion along x
      EXPECT_GT(info(1, 1) / hits, 0.5);
    }
  }
}

}  // namespace
}  // namespace calib
