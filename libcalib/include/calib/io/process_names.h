#pragma once
// Process names on HEARTBEAT (heartbeat_t.process) that another process acts on.

namespace calib {

// The group's recording marks: beats that agvcal-recording drain publishes until one is in the
// recording. A mark, not a process that stays alive.
inline constexpr const char* kGroupMarkProcess = "group";
// agvcal-solver's heartbeat.
inline constexpr const char* kSolverProcess = "solver";

}  // namespace calib
