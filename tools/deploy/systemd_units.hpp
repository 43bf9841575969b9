#pragma once
// systemd unit files for one host of a deployment: ips-<deployment>-<process>.service per
// process and ips-<deployment>.target that wants them all (docs/deployment.md). Supervision is
// systemd's: Restart= with the deployment's back-off (RestartSec, and RestartSteps /
// RestartMaxDelaySec, which systemd >= 254 uses to back off exponentially and older systemd
// ignores with a warning), StartLimitIntervalSec=0 so that it never gives up, ordering from
// `after:`, and LCM_DEFAULT_URL in the environment. Pure: the deployment in, file names and texts
// out.
#include <map>
#include <string>

#include "tools/deploy/deployment.hpp"

namespace ips::deploy {

// A word for a unit file, in double quotes with \ and " escaped and the specifiers systemd
// expands doubled, so that it reaches the program as written: % everywhere, and $ too in
// ExecStart= (exec: true), where systemd also expands environment variables.
std::string systemd_quote(const std::string& word, bool exec);

std::string unit_name(const Deployment& d, const Process& p);  // ips-lab-uwb-twr.service
std::string target_name(const Deployment& d);                  // ips-lab.target

// File name -> contents, for every unit of `host`. `resolved` maps each process name to its
// command's path (resolve_command()).
std::map<std::string, std::string> systemd_units(const Deployment& d, const Host& host,
                                                 const std::map<std::string, std::string>& resolved);

}  // namespace ips::deploy
