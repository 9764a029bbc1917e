#pragma once
// Sub-commands of the agvcal front end; each takes the full argv (argv[1] is
// the command name) and returns the exit status.

namespace agvcal_cli {

int Simulate(int argc, char** argv);
int Info(int argc, char** argv);
int Solve(int argc, char** argv);
int Import(int argc, char** argv);
int Ground(int argc, char** argv);
int Fuse(int argc, char** argv);
int Stop(int argc, char** argv);
int Recal(int argc, char** argv);
int Diagnose(int argc, char** argv);

}  // namespace agvcal_cli
