#pragma once
// Small TCP helpers for the processes that talk to devices (lidar bridge) or
// emulate them (sickemu).

#include <string>

namespace agvcal_process {

// A connected TCP socket to host:port, or -1 with the reason in *error.
int ConnectTcp(const std::string& host, const std::string& port, std::string* error);

// Sends all of `text` (no SIGPIPE); false when the peer is gone.
bool SendAll(int fd, const std::string& text);

}  // namespace agvcal_process
