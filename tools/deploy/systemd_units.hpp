#pragma once
// systemd unit files for one host of a deployment: ips-<deployment>-<process>.service per
// process and ips-<deployment>.target that wants them all (docs/deployment.md). Supervision is
// systemd's: Restart= with the deployment's back-off, ordering from `after:`, and LCM_DEFAULT_URL
// in the environment. The back-off depends on the systemd version the units are written for:
//  - >= 254: RestartSec, RestartSteps and RestartMaxDelaySec (exponential, as ips-deploy run),
//    StartLimitIntervalSec=0 so that systemd never gives up;
//  - <  254 (Debian 12 has 252), which knows neither of those two keys: RestartSec=initial_s, at
//    most StartLimitBurst starts in StartLimitIntervalSec, after which systemd gives up and
//    ips-<deployment>-<process>-retry.service (OnFailure=) starts the process again max_s later.
// Pure: the deployment in, file names and texts out.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "tools/deploy/deployment.hpp"

namespace ips::deploy {

// The first systemd with RestartSteps= and RestartMaxDelaySec=.
inline constexpr int kSystemdBackoffVersion = 254;
// What the units are written for when the version cannot be found out (Debian 12's).
inline constexpr int kDefaultSystemdVersion = 252;
// Where systemd looks for an ExecStart= program given without a '/' (systemd.exec(5)).
inline constexpr const char* kSystemdSearchPath =
    "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin";

// The version in `systemctl --version`'s first line ("systemd 252 (252.38-1~deb12u1)"); 0 when
// it is not such a line.
int parse_systemctl_version(const std::string& first_line);

// A word for a unit file, in double quotes with \ and " escaped and the specifiers systemd
// expands doubled, so that it reaches the program as written: % everywhere, and $ too in
// ExecStart= (exec: true), where systemd also expands environment variables.
std::string systemd_quote(const std::string& word, bool exec);

std::string unit_name(const Deployment& d, const Process& p);        // ips-lab-uwb-twr.service
std::string retry_unit_name(const Deployment& d, const Process& p);  // ips-lab-uwb-twr-retry.service
std::string target_name(const Deployment& d);                        // ips-lab.target

// systemd < 254: starts, each initial_s after the last exit, that systemd allows within
// start_limit_interval_s before it gives up (the number the exponential back-off makes before
// its delay reaches max_s); 0 when the back-off is a fixed delay (max_s == initial_s).
struct StartLimit {
  int burst = 0;
  double interval_s = 0;
};
StartLimit start_limit(const Backoff& b);

// File name -> contents, for every unit of `host`, for systemd `systemd_version`. `resolved`
// maps each process name to its command's path (resolve_command()).
std::map<std::string, std::string> systemd_units(const Deployment& d, const Host& host,
                                                 const std::map<std::string, std::string>& resolved,
                                                 int systemd_version);

// The processes of `host` whose resolved command systemd would not find: a path that is not a
// program, or a bare name that is in no directory of kSystemdSearchPath. "name: command" each.
std::vector<std::string> commands_systemd_cannot_find(
    const Host& host, const std::map<std::string, std::string>& resolved,
    const std::function<bool(const std::string&)>& is_program);

}  // namespace ips::deploy
