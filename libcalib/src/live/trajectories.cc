// The excitation trajectories of each drive type (TrajectoryNames, MakeTrajectory in
// calib/live/commander.h), scaled to the robot's limits.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calib/core/errors.h"
#include "calib/core/units.h"
#include "calib/live/commander.h"
#include "live/segment_motion.h"

namespace calib {

namespace {

TrajectorySegment Seg(std::string description, double speed, double omega,
                      std::vector<double> steer, double distance, double angle,
                      double pause_s = 0.5) {
  TrajectorySegment s;
  s.description = std::move(description);
  s.speed = speed;
  s.omega = omega;
  s.steer = std::move(steer);
  s.distance = distance;
  s.angle = angle;
  s.pause_s = pause_s;
  return s;
}

const char* Dir(double sign) { return sign > 0 ? "forward" : "reverse"; }

// --- differential

void AddStraightDiff(std::vector<TrajectorySegment>* out, double speed, double distance) {
  out->push_back(Seg(Formatted("straight, forward %.1f m at %.2f m/s", distance, speed), speed, 0.0, {},
                     distance, 0.0));
  out->push_back(Seg(Formatted("straight, reverse %.1f m at %.2f m/s", distance, speed), -speed, 0.0, {},
                     distance, 0.0));
}

void AddUmbmark(const Limits& lim, std::vector<TrajectorySegment>* out) {
  const double side = 2.5;
  const double turn_rate = 0.6 * lim.max_omega;
  for (double sense : {1.0, -1.0}) {
    const char* name = sense > 0 ? "CCW" : "CW";
    for (int k = 1; k <= 4; ++k) {
      out->push_back(Seg(std::string("umbmark ") + name + Formatted(" side %d/4: forward %.1f m", k, side),
                         lim.max_speed, 0.0, {}, side, 0.0));
      out->push_back(Seg(std::string("umbmark ") + name + Formatted(" corner %d/4: turn %+.0f deg", k,
                                                               sense * 90.0),
                         0.0, sense * turn_rate, {}, 0.0, M_PI / 2));
    }
  }
}

void AddTurns(const Limits& lim, std::vector<TrajectorySegment>* out) {
  for (double fraction : {1.0, 0.4}) {
    const double turns = fraction >= 1.0 ? 2.0 : 1.0;
    for (double sense : {1.0, -1.0}) {
      const double rate = sense * fraction * lim.max_omega;
      out->push_back(Seg(Formatted("turn in place %+.0f turn(s) at %+.2f rad/s", sense * turns, rate), 0.0,
                         rate, {}, 0.0, turns * 2.0 * M_PI));
    }
  }
}

void AddFigure8(const Limits& lim, std::vector<TrajectorySegment>* out, double radius) {
  const double speed = std::min(lim.max_speed, lim.max_omega * radius);
  for (double first : {1.0, -1.0}) {
    for (double sense : {first, -first}) {
      out->push_back(Seg(std::string("figure-eight loop ") + (sense > 0 ? "left" : "right") +
                             Formatted(", radius %.1f m", radius),
                         speed, sense * speed / radius, {}, 0.0, 2.0 * M_PI));
    }
  }
}

// The IMU calibration (docs/imu.md): a straight run of the distance the user will measure,
// turns in place of several whole turns both ways, back along the straight; long pauses
// at rest show the gyro's bias.
void AddImuCalibration(const RobotDescription& robot, std::vector<TrajectorySegment>* out) {
  const Limits& lim = robot.limits;
  const double distance = robot.imu && robot.imu->distance ? *robot.imu->distance : 3.0;
  const double still = 10.0;
  out->push_back(Seg(Formatted("straight, forward %.2f m (measure it)", distance), lim.max_speed, 0.0, {},
                     distance, 0.0, still));
  out->push_back(Seg("turn in place +2 turns", 0.0, lim.max_omega, {}, 0.0, 4 * M_PI, still));
  out->push_back(Seg(Formatted("straight, reverse %.2f m", distance), -lim.max_speed, 0.0, {}, distance,
                     0.0, still));
  out->push_back(Seg("turn in place -2 turns", 0.0, -lim.max_omega, {}, 0.0, 4 * M_PI, still));
}

Trajectory MakeDifferential(const RobotDescription& robot, const std::string& name) {
  const Limits& lim = robot.limits;
  Trajectory t;
  t.name = name;
  auto& s = t.segments;
  if (name == "default") {
    AddUmbmark(lim, &s);
    AddTurns(lim, &s);
    AddFigure8(lim, &s, 1.2);
    AddStraightDiff(&s, 0.5 * lim.max_speed, 3.0);
  } else if (name == "umbmark") {
    AddUmbmark(lim, &s);
  } else if (name == "turns") {
    AddTurns(lim, &s);
  } else if (name == "figure8") {
    AddFigure8(lim, &s, 1.2);
  } else if (name == "demo") {
    AddStraightDiff(&s, lim.max_speed, 1.5);
    s.push_back(Seg("turn in place +90 deg", 0.0, 0.6 * lim.max_omega, {}, 0.0, M_PI / 2));
    s.push_back(Seg("turn in place -90 deg", 0.0, -0.6 * lim.max_omega, {}, 0.0, M_PI / 2));
    const double v = std::min(lim.max_speed, lim.max_omega);  // radius 1 m
    s.push_back(Seg("arc left, forward 90 deg, radius 1 m", v, v, {}, 0.0, M_PI / 2));
    s.push_back(Seg("arc left, reverse 90 deg, radius 1 m", -v, -v, {}, 0.0, M_PI / 2));
  } else if (name == "straight") {
    AddStraightDiff(&s, lim.max_speed, 3.0);
    AddStraightDiff(&s, 0.5 * lim.max_speed, 3.0);
  } else if (name == "imu") {
    AddImuCalibration(robot, &s);
  }
  return t;
}

// --- tricycle

// Steering angles of the arcs, scaled down to fit max_steer.
std::vector<double> ArcAngles(const Limits& lim, std::vector<double> angles) {
  const double largest = *std::max_element(angles.begin(), angles.end());
  const double scale = std::min(1.0, 0.95 * lim.max_steer / largest);
  for (double& a : angles) a *= scale;
  return angles;
}

void AddArcThereAndBack(std::vector<TrajectorySegment>* out, const Limits& lim, double steer,
                        double distance) {
  for (double sign : {1.0, -1.0}) {
    out->push_back(Seg(Formatted("arc, steer %+.2f rad, ", steer) + Dir(sign) + Formatted(" %.1f m", distance),
                       sign * lim.max_speed, 0.0, {steer}, distance, 0.0));
  }
}

void AddStraightSteered(std::vector<TrajectorySegment>* out, size_t roles, double speed,
                        double distance) {
  for (double sign : {1.0, -1.0}) {
    out->push_back(Seg(std::string("straight, ") + Dir(sign) +
                           Formatted(" %.1f m at %.2f m/s", distance, speed),
                       sign * speed, 0.0, std::vector<double>(roles, 0.0), distance, 0.0));
  }
}

// Normal work rather than excitation (recalibration during operation, docs/recalibration.md):
// pallet runs from a dock at the start to four racks, north-east, south-east (driving out
// forward), north-west and south-west (driving out in reverse): straight 2 m, a 90-degree
// corner, 2.5 m down the rack aisle, a stop to pick up, then the same way back, which retraces
// the way out, so `laps` rounds keep the robot on its route without any feedback.
void AddRoute(std::vector<TrajectorySegment>* out, const Limits& lim, int laps) {
  const double a = ArcAngles(lim, {0.7})[0];
  const double v = lim.max_speed;
  for (int lap = 1; lap <= laps; ++lap) {
    for (const char* rack : {"north-east", "south-east", "north-west", "south-west"}) {
      const double way = rack[6] == 'e' ? 1.0 : -1.0;              // forward out to the east
      const double side = rack[0] == 'n' ? 1.0 : -1.0;  // steering that reaches the rack, either way
      const std::string run = Formatted("lap %d, ", lap) + "rack " + rack + ": ";
      for (double dir : {way, -way}) {
        const std::string how = dir > 0 ? "forward " : "reverse ";
        std::vector<TrajectorySegment> legs{
            Seg(run + how + "2.0 m", dir * v, 0.0, {0.0}, 2.0, 0.0),
            Seg(run + how + "corner 90 deg", dir * v, 0.0, {side * a}, 0.0, M_PI / 2),
            Seg(run + how + "aisle 2.5 m", dir * v, 0.0, {0.0}, 2.5, 0.0, 2.0 /* pick-up */)};
        if (dir != way) std::reverse(legs.begin(), legs.end());
        out->insert(out->end(), legs.begin(), legs.end());
      }
    }
  }
}

Trajectory MakeTricycle(const Limits& lim, const std::string& name) {
  Trajectory t;
  t.name = name;
  auto& s = t.segments;
  if (name == "default") {
    for (double a : ArcAngles(lim, {0.2, 0.4, 0.7, 1.0})) {
      AddArcThereAndBack(&s, lim, a, 3.0);
      AddArcThereAndBack(&s, lim, -a, 3.0);
    }
    AddStraightSteered(&s, 1, lim.max_speed, 4.0);
    AddStraightSteered(&s, 1, 0.5 * lim.max_speed, 4.0);
  } else if (name == "demo") {
    const double a = ArcAngles(lim, {0.4})[0];
    AddArcThereAndBack(&s, lim, a, 1.2);
    AddArcThereAndBack(&s, lim, -a, 1.2);
    AddStraightSteered(&s, 1, lim.max_speed, 1.5);
  } else if (name == "straight") {
    AddStraightSteered(&s, 1, lim.max_speed, 3.0);
    AddStraightSteered(&s, 1, 0.5 * lim.max_speed, 3.0);
  } else if (name == "route") {
    AddRoute(&s, lim, 3);
  }
  return t;
}

// --- dual steer

// The three-segment run: a1 at +steer, straight, a1 at -steer (a2 at zero), each `leg` m of
// a1 travel, then the same back in reverse so the robot returns to its start.
void AddThreeSegment(std::vector<TrajectorySegment>* out, const Limits& lim, double steer,
                     double leg) {
  const std::vector<std::vector<double>> forward{{steer, 0.0}, {0.0, 0.0}, {-steer, 0.0}};
  const char* names[3] = {"first turn", "straight", "second turn"};
  for (int k = 0; k < 3; ++k) {
    out->push_back(Seg(Formatted("three-segment run %+.2f rad: ", steer) + names[k] +
                           Formatted(", a1 %+.2f, a2 0, forward %.1f m", forward[k][0], leg),
                       lim.max_speed, 0.0, forward[k], leg, 0.0));
  }
  for (int k = 2; k >= 0; --k) {
    out->push_back(Seg(Formatted("three-segment run %+.2f rad back: ", steer) + names[k] +
                           Formatted(", a1 %+.2f, a2 0, reverse %.1f m", forward[k][0], leg),
                       -lim.max_speed, 0.0, forward[k], leg, 0.0));
  }
}

void AddBothSteered(std::vector<TrajectorySegment>* out, const Limits& lim, const char* what,
                    double a1, double a2, double distance) {
  for (double sign : {1.0, -1.0}) {
    out->push_back(Seg(std::string(what) + Formatted(", a1 %+.2f, a2 %+.2f, ", a1, a2) + Dir(sign) +
                           Formatted(" %.1f m", distance),
                       sign * lim.max_speed, 0.0, {a1, a2}, distance, 0.0));
  }
}

Trajectory MakeDualSteer(const RobotDescription& robot, const std::string& name) {
  const Limits& lim = robot.limits;
  Trajectory t;
  t.name = name;
  auto& s = t.segments;
  const std::vector<double> angles = ArcAngles(lim, {0.5, 1.0});
  if (name == "default") {
    for (double a : angles) {
      AddThreeSegment(&s, lim, a, 1.8);
      AddThreeSegment(&s, lim, -a, 1.8);
    }
    const double c = ArcAngles(lim, {0.4})[0];
    // Crab runs: both wheels alike (a pure translation unless the wheels line up with it).
    AddBothSteered(&s, lim, "crab", c, c, 2.0);
    AddBothSteered(&s, lim, "crab", -c, -c, 2.0);
    AddBothSteered(&s, lim, "counter-steer", c, -c, 2.0);
    AddBothSteered(&s, lim, "counter-steer", -c, c, 2.0);
    AddStraightSteered(&s, 2, lim.max_speed, 4.0);
  } else if (name == "three_segment") {
    AddThreeSegment(&s, lim, angles[0], 1.8);
    AddThreeSegment(&s, lim, -angles[0], 1.8);
  } else if (name == "demo") {
    AddThreeSegment(&s, lim, angles[0], 1.0);
  } else if (name == "straight") {
    AddStraightSteered(&s, 2, lim.max_speed, 3.0);
    AddStraightSteered(&s, 2, 0.5 * lim.max_speed, 3.0);
  }
  // Drop motions the geometry cannot realise (e.g. a crab angle along the line of the wheels).
  std::vector<TrajectorySegment> kept;
  for (const auto& seg : s) {
    const double x1 = robot.param("b"), y2 = -robot.param("a");
    const Row r1 = RollingConstraint(x1, 0.0, seg.steer[0]);
    const Row r2 = RollingConstraint(0.0, y2, seg.steer[1]);
    const double cx = r1.b * r2.c - r1.c * r2.b, cy = r1.c * r2.a - r1.a * r2.c,
                 cw = r1.a * r2.b - r1.b * r2.a;
    const double scale = std::hypot(r1.a, r1.b, r1.c) * std::hypot(r2.a, r2.b, r2.c);
    if (std::hypot(cx, cy, cw) >= 0.05 * scale) kept.push_back(seg);
  }
  s = kept;
  return t;
}

}  // namespace

std::vector<std::string> TrajectoryNames(DriveType type) {
  switch (type) {
    case DriveType::kDifferential:
      return {"default", "umbmark", "turns", "figure8", "demo", "straight", "imu"};
    case DriveType::kTricycle:
      return {"default", "demo", "straight", "route"};
    case DriveType::kDualSteer:
      return {"default", "three_segment", "demo", "straight"};
  }
  return {};
}

Trajectory MakeTrajectory(const RobotDescription& robot, const std::string& name) {
  const auto names = TrajectoryNames(robot.drive);
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string known;
    for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
    throw InputError("trajectory '" + name + "'", "",
                     std::string("unknown for a ") + DriveTypeName(robot.drive) +
                         " drive; known: " + known);
  }
  switch (robot.drive) {
    case DriveType::kDifferential: return MakeDifferential(robot, name);
    case DriveType::kTricycle: return MakeTricycle(robot.limits, name);
    case DriveType::kDualSteer: return MakeDualSteer(robot, name);
  }
  throw std::logic_error("unknown drive type");
}

}  // namespace calib
