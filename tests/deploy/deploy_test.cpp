// ips-deploy's pure parts (tools/deploy/): the deployment file and its errors, command and
// environment resolution, the systemd units (for systemd >= 254 and for 252), the restart
// back-off and policy, the run file, and the status table from HEALTH. The expected values are docs/deployment.md's: its field tables, its error
// lines, its uwb-twr unit and its back-off table.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <ips/health_t.hpp>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/time.hpp"
#include "core/yaml_fields.hpp"
#include "tools/deploy/deployment.hpp"
#include "tools/deploy/run_file.hpp"
#include "tools/deploy/status.hpp"
#include "tools/deploy/supervisor.hpp"
#include "tools/deploy/systemd_units.hpp"

namespace ips::deploy {
namespace {

using ::testing::ElementsAre;
using ::testing::EndsWith;
using ::testing::HasSubstr;
using ::testing::Not;

Deployment parse(const std::string& yaml) {
  return parse_deployment(parse_yaml_text(yaml, "test.yaml"));
}

// The ConfigError's what() for a file that must be refused; "" (and a test failure) otherwise.
std::string parse_error(const std::string& yaml) {
  try {
    parse(yaml);
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << yaml;
  return "";
}

std::vector<std::string> process_names(const Host& h) {
  std::vector<std::string> names;
  for (const Process& p : h.processes) names.push_back(p.name);
  return names;
}

// ---------------------------------------------------------------------------------------------
// The deployment file

// config/deploy/lab-3-hosts.yaml, less its comments and its top-level restart and stop_timeout_s
// (so that every default of docs/deployment.md's tables shows).
const char* kThreeHosts = R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
bin_dir: /usr/local/lib/ips-fusion/bin
user: ips
working_dir: /var/lib/ips
environment: {TZ: UTC}
hosts:
  - name: sensors
    hostname: lab-pc-1
    processes:
      - name: sim
        command: ips-sim
        args: [--scenario, lab, --duration, "86400"]
        restart: always
  - name: compute
    processes:
      - name: uwb-twr
        command: ips-uwb-twr
        args: [--log-level, info]
      - name: uwb-tdoa
        command: ips-uwb-tdoa
      - name: fuse
        command: ips-fuse
      - name: view
        command: ips-view
        args: [--bind, 0.0.0.0]
  - name: recorder
    hostname: lab-pc-3
    processes:
      - name: record
        command: ips-record
        args: [--split-minutes, "60", --site-wait, "6"]
        restart: no
        environment: {IPS_DISK: big}
)";

TEST(DeploymentFile, ThreeHostFileKeepsEveryFieldAndFillsTheDefaults) {
  const Deployment d = parse(kThreeHosts);
  EXPECT_EQ(d.name, "lab");
  EXPECT_EQ(d.lcm_url, "udpm://239.255.76.67:7667?ttl=1");
  EXPECT_EQ(d.bin_dir, "/usr/local/lib/ips-fusion/bin");
  EXPECT_EQ(d.user, "ips");
  EXPECT_EQ(d.working_dir, "/var/lib/ips");
  EXPECT_EQ(d.environment, (std::map<std::string, std::string>{{"TZ", "UTC"}}));
  ASSERT_EQ(d.hosts.size(), 3u);
  EXPECT_EQ(d.host_names(), "sensors, compute, recorder");

  const Host& sensors = d.hosts[0];
  EXPECT_EQ(sensors.name, "sensors");
  EXPECT_EQ(sensors.hostname, "lab-pc-1");
  ASSERT_EQ(sensors.processes.size(), 1u);
  const Process& sim = sensors.processes[0];
  EXPECT_EQ(sim.command, "ips-sim");
  EXPECT_THAT(sim.args, ElementsAre("--scenario", "lab", "--duration", "86400"));
  EXPECT_EQ(sim.restart, Restart::kAlways);

  const Host* compute = d.host("compute");
  ASSERT_NE(compute, nullptr);
  EXPECT_EQ(compute, &d.hosts[1]);
  EXPECT_EQ(compute->hostname, "compute");  // no hostname: the name
  EXPECT_THAT(process_names(*compute), ElementsAre("uwb-twr", "uwb-tdoa", "fuse", "view"));
  // Every default of a process (docs/deployment.md, "Each process").
  for (const Process& p : compute->processes) {
    SCOPED_TRACE(p.name);
    EXPECT_EQ(p.restart, Restart::kOnFailure);
    EXPECT_TRUE(p.after.empty());
    EXPECT_TRUE(p.environment.empty());
    EXPECT_DOUBLE_EQ(p.backoff.initial_s, 1.0);
    EXPECT_DOUBLE_EQ(p.backoff.max_s, 30.0);
    EXPECT_DOUBLE_EQ(p.backoff.reset_after_s, 60.0);
    EXPECT_DOUBLE_EQ(p.stop_timeout_s, 5.0);
  }
  EXPECT_TRUE(compute->processes[1].args.empty());

  const Host& recorder = d.hosts[2];
  EXPECT_EQ(recorder.hostname, "lab-pc-3");
  ASSERT_EQ(recorder.processes.size(), 1u);
  // A bare `no` is YAML 1.1's false, but the field is read as the text written.
  EXPECT_EQ(recorder.processes[0].restart, Restart::kNo);
  EXPECT_EQ(recorder.processes[0].environment,
            (std::map<std::string, std::string>{{"IPS_DISK", "big"}}));

  EXPECT_EQ(d.host("nowhere"), nullptr);
  EXPECT_STREQ(restart_name(Restart::kNo), "no");
  EXPECT_STREQ(restart_name(Restart::kOnFailure), "on-failure");
  EXPECT_STREQ(restart_name(Restart::kAlways), "always");
}

TEST(DeploymentFile, TopLevelRestartIsInheritedAndRestartBackoffOverridesIt) {
  const Deployment d = parse(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
restart: {initial_s: 2, max_s: 60, reset_after_s: 120}
stop_timeout_s: 8
hosts:
  - name: a
    processes:
      - {name: plain, command: ips-fuse}
      - {name: slow, command: ips-record, restart_backoff: {initial_s: 5, max_s: 300},
         stop_timeout_s: 15}
      - {name: capped, command: ips-view, restart_backoff: {max_s: 10}}
      - {name: late, command: ips-sim, restart_backoff: {initial_s: 90}}
)");
  ASSERT_EQ(d.hosts.size(), 1u);
  const std::vector<Process>& ps = d.hosts[0].processes;
  ASSERT_EQ(ps.size(), 4u);
  // Inherited whole.
  EXPECT_DOUBLE_EQ(ps[0].backoff.initial_s, 2);
  EXPECT_DOUBLE_EQ(ps[0].backoff.max_s, 60);
  EXPECT_DOUBLE_EQ(ps[0].backoff.reset_after_s, 120);
  EXPECT_DOUBLE_EQ(ps[0].stop_timeout_s, 8);
  // Given keys win; reset_after_s still from the top level.
  EXPECT_DOUBLE_EQ(ps[1].backoff.initial_s, 5);
  EXPECT_DOUBLE_EQ(ps[1].backoff.max_s, 300);
  EXPECT_DOUBLE_EQ(ps[1].backoff.reset_after_s, 120);
  EXPECT_DOUBLE_EQ(ps[1].stop_timeout_s, 15);
  // Only max_s given: initial_s from the top level.
  EXPECT_DOUBLE_EQ(ps[2].backoff.initial_s, 2);
  EXPECT_DOUBLE_EQ(ps[2].backoff.max_s, 10);
  // initial_s above the inherited max_s: "a missing max_s is at least initial_s".
  EXPECT_DOUBLE_EQ(ps[3].backoff.initial_s, 90);
  EXPECT_DOUBLE_EQ(ps[3].backoff.max_s, 90);
}

TEST(DeploymentFile, AfterStartsTheNamedProcessesFirstAndFileOrderIsKeptOtherwise) {
  const Deployment d = parse(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: compute
    processes:
      - {name: fuse, command: ips-fuse, after: [uwb-twr, uwb-tdoa]}
      - {name: view, command: ips-view}
      - {name: uwb-tdoa, command: ips-uwb-tdoa, after: [uwb-twr]}
      - {name: uwb-twr, command: ips-uwb-twr}
  - name: recorder
    processes:
      - {name: record, command: ips-record}
      - {name: logger, command: lcm-logger}
)");
  // First pass in file order: view and uwb-twr have nothing pending; the second places uwb-tdoa,
  // the third fuse.
  EXPECT_THAT(process_names(d.hosts[0]), ElementsAre("view", "uwb-twr", "uwb-tdoa", "fuse"));
  EXPECT_THAT(d.hosts[0].processes[3].after, ElementsAre("uwb-twr", "uwb-tdoa"));
  EXPECT_THAT(process_names(d.hosts[1]), ElementsAre("record", "logger"));
}

// ---------------------------------------------------------------------------------------------
// Errors: "file:line: field.path: reason" (docs/deployment.md lists the same lines)

TEST(DeploymentFileErrors, MisspeltKeyIsAnUnknownField) {
  const std::string e = parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    proceses:
      - {name: p, command: ips-sim}
)");
  EXPECT_THAT(e, HasSubstr("test.yaml:5: hosts[0].proceses: unknown field (known: name, "
                           "hostname, processes)"));
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - {name: p, command: ips-sim, colour: red}
)"),
              HasSubstr("test.yaml:6: hosts[0].processes[0].colour: unknown field"));
}

TEST(DeploymentFileErrors, DuplicateHost) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
  - name: a
    processes: [{name: q, command: ips-fuse}]
)"),
              HasSubstr("test.yaml:6: hosts[1].name: duplicate host 'a'"));
}

TEST(DeploymentFileErrors, DuplicateProcessAcrossHosts) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
  - name: b
    processes: [{name: p, command: ips-fuse}]
)"),
              HasSubstr("test.yaml:7: hosts[1].processes[0].name: duplicate process 'p' (names "
                        "are unique in the deployment)"));
}

TEST(DeploymentFileErrors, NamesOutsideLowercaseDigitsAndDashOrTooLong) {
  const std::string url = "lcm_url: \"udpm://239.255.76.67:7667?ttl=1\"\n";
  const std::string one_host =
      "hosts:\n  - name: a\n    processes: [{name: p, command: ips-sim}]\n";
  // Uppercase process name.
  EXPECT_THAT(
      parse_error("name: lab\n" + url +
                  "hosts:\n  - name: a\n    processes: [{name: Fuse, command: ips-fuse}]\n"),
      HasSubstr("test.yaml:5: hosts[0].processes[0].name: must be 1 to 32 of a-z, 0-9 and "
                "'-'"));
  // Deployment name: 32 characters pass, 33 do not.
  EXPECT_NO_THROW(parse("name: " + std::string(32, 'x') + "\n" + url + one_host));
  EXPECT_THAT(parse_error("name: " + std::string(33, 'x') + "\n" + url + one_host),
              HasSubstr("test.yaml:1: name: must be 1 to 32 of a-z, 0-9 and '-'"));
  // Host name: 63 pass, 64 do not.
  EXPECT_NO_THROW(parse("name: lab\n" + url + "hosts:\n  - name: " + std::string(63, 'h') +
                        "\n    processes: [{name: p, command: ips-sim}]\n"));
  EXPECT_THAT(parse_error("name: lab\n" + url + "hosts:\n  - name: " + std::string(64, 'h') +
                          "\n    processes: [{name: p, command: ips-sim}]\n"),
              HasSubstr("test.yaml:4: hosts[0].name: must be 1 to 63 of a-z, 0-9 and '-'"));
  // Leading '-'.
  EXPECT_THAT(
      parse_error("name: lab\n" + url +
                  "hosts:\n  - name: \"-a\"\n    processes: [{name: p, command: ips-sim}]\n"),
      HasSubstr("test.yaml:4: hosts[0].name: must be 1 to 63"));
  EXPECT_THAT(parse_error("name: \"-lab\"\n" + url + one_host),
              HasSubstr("test.yaml:1: name: must be 1 to 32"));
}

TEST(DeploymentFileErrors, AfterNamingAProcessOfAnotherHost) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - {name: p, command: ips-sim}
  - name: b
    processes:
      - {name: q, command: ips-fuse, after: [p]}
)"),
              HasSubstr("test.yaml:9: hosts[1].processes[0].after: no process 'p' on host 'b'"));
}

TEST(DeploymentFileErrors, ProcessAfterItself) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - {name: q, command: ips-fuse}
      - {name: p, command: ips-sim, after: [q, p]}
)"),
              HasSubstr("test.yaml:7: hosts[0].processes[1].after: a process cannot start after "
                        "itself"));
}

TEST(DeploymentFileErrors, AfterCycleNamesBothProcesses) {
  const std::string e = parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - {name: p, command: ips-sim, after: [q]}
      - {name: r, command: ips-view}
      - {name: q, command: ips-fuse, after: [p]}
)");
  // r is not in the circle and is not named.
  EXPECT_THAT(e, HasSubstr("test.yaml:6: hosts[0].processes: `after` goes round in a circle "
                           "among: p, q"));
  EXPECT_THAT(e, EndsWith("among: p, q"));
}

TEST(DeploymentFileErrors, RestartPolicyOutsideNoOnFailureAlways) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - name: p
        command: ips-sim
        restart: sometimes
)"),
              HasSubstr("test.yaml:8: hosts[0].processes[0].restart: must be no, on-failure or "
                        "always"));
}

TEST(DeploymentFileErrors, LcmDefaultUrlInEnvironment) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
environment: {TZ: UTC, LCM_DEFAULT_URL: "udpm://239.255.76.67:7668"}
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
)"),
              HasSubstr("test.yaml:3: environment.LCM_DEFAULT_URL: is set from lcm_url; set "
                        "lcm_url instead"));
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - {name: p, command: ips-sim, environment: {LCM_DEFAULT_URL: "memq://"}}
)"),
              HasSubstr("test.yaml:6: hosts[0].processes[0].environment.LCM_DEFAULT_URL: is set "
                        "from lcm_url"));
}

TEST(DeploymentFileErrors, EnvironmentValueWithANewline) {
  // "\n" in a double-quoted YAML scalar is a newline: it would end the unit file's line.
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - name: p
        command: ips-sim
        environment:
          NOTE: "line one\nExecStartPre=/bin/false"
)"),
              HasSubstr("test.yaml:9: hosts[0].processes[0].environment.NOTE: must not contain "
                        "control characters"));
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
environment: {"1ST": x}
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
)"),
              HasSubstr("test.yaml:3: environment.1ST: not a valid environment variable name"));
  // A list as a name (fuzz_deploy_file found it aborting ips-deploy).
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
environment: {GREETING: hi, [-c, e]: x}
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
)"),
              HasSubstr("test.yaml:3: environment: a name must be text, not a list or a map"));
}

TEST(DeploymentFileErrors, RelativeWorkingDir) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
working_dir: var/lib/ips
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
)"),
              HasSubstr("test.yaml:3: working_dir: must be absolute"));
}

TEST(DeploymentFileErrors, CommandWithASpace) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - name: p
        command: "ips-uwb-twr --log-level info"
)"),
              HasSubstr("test.yaml:7: hosts[0].processes[0].command: one program (a name or a "
                        "path, no spaces): put its arguments in args"));
}

TEST(DeploymentFileErrors, LcmUrlWithoutScheme) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "239.255.76.67:7667"
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
)"),
              HasSubstr("test.yaml:2: lcm_url: expected an LCM URL"));
}

TEST(DeploymentFileErrors, EmptyHostsList) {
  EXPECT_THAT(parse_error(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts: []
)"),
              HasSubstr("test.yaml:3: hosts: expected a list of at least one host"));
}

// Partitioned sites (issue 25 item 4): "fuse, 3 shards on hosts a, b, c".
TEST(DeploymentFile, ShardedProcessBecomesOneInstancePerShardOnItsHosts) {
  const Deployment d = parse(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - {name: twr, command: ips-uwb-twr}
  - name: b
  - name: c
sharded:
  - name: fuse
    command: ips-fuse
    args: [--log-level, warn]
    restart: always
    shards: 3
    hosts: [a, b, c]
  - name: zones
    command: ips-zones
    shards: 4
    hosts: [b, c]
  - {name: view, command: ips-view, shards: 1, hosts: [b], after: [fuse-2]}
)");
  ASSERT_EQ(d.hosts.size(), 3u);
  EXPECT_THAT(process_names(d.hosts[0]), ElementsAre("twr", "fuse-1"));
  // zones-1 and zones-3 on b (round robin over [b, c]); view-1 after fuse-2, which b runs.
  EXPECT_THAT(process_names(d.hosts[1]), ElementsAre("fuse-2", "zones-1", "zones-3", "view-1"));
  EXPECT_THAT(process_names(d.hosts[2]), ElementsAre("fuse-3", "zones-2", "zones-4"));
  const Process& f2 = d.hosts[1].processes[0];
  EXPECT_EQ(f2.command, "ips-fuse");
  EXPECT_THAT(f2.args, ElementsAre("--log-level", "warn", "--shard", "2/3"));
  EXPECT_EQ(f2.restart, Restart::kAlways);
  EXPECT_THAT(d.hosts[2].processes[2].args, ElementsAre("--shard", "4/4"));
  EXPECT_THAT(d.hosts[1].processes[3].after, ElementsAre("fuse-2"));
  EXPECT_THAT(d.hosts[1].processes[3].args, ElementsAre("--shard", "1/1"));
}

TEST(DeploymentFileErrors, ShardedProcessMistakes) {
  const std::string head = R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes:
      - {name: fuse-2, command: ips-sim}
  - name: b
sharded:
)";
  EXPECT_THAT(parse_error(head + "  - {name: fuse, command: ips-fuse, shards: 3, hosts: [a, x]}\n"),
              HasSubstr("test.yaml:9: sharded[0].hosts[1]: no host 'x' (hosts: a, b)"));
  EXPECT_THAT(parse_error(head + "  - {name: fuse, command: ips-fuse, shards: 0, hosts: [a]}\n"),
              HasSubstr("sharded[0].shards: must be in [1, 1024]"));
  EXPECT_THAT(parse_error(head + "  - {name: fuse, command: ips-fuse, hosts: [a]}\n"),
              HasSubstr("sharded[0]"));
  EXPECT_THAT(parse_error(head + "  - {name: fuse, command: ips-fuse, shards: 3, hosts: []}\n"),
              HasSubstr("sharded[0].hosts: expected a list of at least one host"));
  EXPECT_THAT(
      parse_error(head +
                  "  - {name: fuse, command: ips-fuse, shards: 2, hosts: [b], args: [--shard, 1/2]}\n"),
      HasSubstr("sharded[0].args: --shard is set by shards: (instance k of N gets --shard k/N)"));
  EXPECT_THAT(parse_error(head + "  - {name: fuse, command: ips-fuse, shards: 2, hosts: [b]}\n"),
              HasSubstr("sharded[0].name: shard 2 would be named 'fuse-2', which another process "
                        "has"));
  EXPECT_THAT(parse_error(head + "  - {name: fuse, command: ips-fuse, shards: 2, hosts: [b], "
                                 "colour: red}\n"),
              HasSubstr("sharded[0].colour: unknown field"));
  // A host with neither processes nor shards.
  EXPECT_THAT(parse_error(head + "  - {name: fuse, command: ips-fuse, shards: 1, hosts: [a]}\n"),
              HasSubstr("test.yaml:7: hosts[1]: host 'b' has no processes (and no shards)"));
  // after: names a process of each host the shards land on.
  EXPECT_THAT(parse_error(head + "  - {name: f, command: ips-fuse, shards: 2, hosts: [a, b], "
                                 "after: [fuse-2]}\n"),
              HasSubstr("sharded[0].after: no process 'fuse-2' on host 'b'"));
}

TEST(DeploymentFileErrors, BackoffOutsideItsBounds) {
  const std::string hosts = R"(hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
)";
  const std::string head = "name: lab\nlcm_url: \"udpm://239.255.76.67:7667?ttl=1\"\n";
  EXPECT_THAT(parse_error(head + "restart: {initial_s: 0}\n" + hosts),
              HasSubstr("test.yaml:3: restart.initial_s: must be in [0.1, 3600]"));
  // max_s below initial_s: the lower bound is initial_s (docs/deployment.md's error line).
  EXPECT_THAT(parse_error(head + "restart: {initial_s: 10, max_s: 5}\n" + hosts),
              HasSubstr("test.yaml:3: restart.max_s: must be in [10, 86400]"));
  EXPECT_THAT(parse_error(head + "restart: {reset_after_s: 0.5}\n" + hosts),
              HasSubstr("test.yaml:3: restart.reset_after_s: must be in [1, 86400]"));
  EXPECT_THAT(parse_error(head + R"(hosts:
  - name: a
    processes:
      - {name: p, command: ips-sim, restart_backoff: {initial_s: 0}}
)"),
              HasSubstr("test.yaml:6: hosts[0].processes[0].restart_backoff.initial_s: must be in "
                        "[0.1, 3600]"));
}

// ---------------------------------------------------------------------------------------------
// Commands and environment

TEST(ResolveCommand, PathWithSlashIsKeptAsWritten) {
  int asked = 0;
  const auto is_program = [&](const std::string&) {
    ++asked;
    return true;
  };
  EXPECT_EQ(resolve_command("/usr/bin/lcm-logger", "/opt/ips/bin", is_program),
            "/usr/bin/lcm-logger");
  EXPECT_EQ(resolve_command("./ips-sim", "/opt/ips/bin", is_program), "./ips-sim");
  EXPECT_EQ(asked, 0);
}

TEST(ResolveCommand, BareNameIsLookedUpInBinDir) {
  std::vector<std::string> asked;
  const auto only_ips_sim = [&](const std::string& path) {
    asked.push_back(path);
    return path == "/opt/ips/bin/ips-sim";
  };
  EXPECT_EQ(resolve_command("ips-sim", "/opt/ips/bin", only_ips_sim), "/opt/ips/bin/ips-sim");
  EXPECT_EQ(resolve_command("ips-sim", "/opt/ips/bin/", only_ips_sim), "/opt/ips/bin/ips-sim");
  // Not a program in bin_dir: the bare name, for the PATH or systemd's search path.
  EXPECT_EQ(resolve_command("lcm-logger", "/opt/ips/bin", only_ips_sim), "lcm-logger");
  EXPECT_THAT(asked, ElementsAre("/opt/ips/bin/ips-sim", "/opt/ips/bin/ips-sim",
                                 "/opt/ips/bin/lcm-logger"));
}

TEST(ResolveCommand, EmptyBinDirKeepsTheBareName) {
  int asked = 0;
  EXPECT_EQ(resolve_command("ips-sim", "",
                            [&](const std::string&) {
                              ++asked;
                              return true;
                            }),
            "ips-sim");
  EXPECT_EQ(asked, 0);
}

TEST(ProcessEnvironment, DeploymentThenProcessWhichWinsThenLcmUrl) {
  Deployment d;
  d.lcm_url = "udpm://239.255.76.67:7667?ttl=1";
  d.environment = {{"TZ", "UTC"}, {"IPS_MODE", "lab"}};
  Process p;
  p.environment = {{"IPS_MODE", "test"}, {"EXTRA", "1"}};
  EXPECT_EQ(process_environment(d, p), (std::map<std::string, std::string>{
                                           {"EXTRA", "1"},
                                           {"IPS_MODE", "test"},
                                           {"LCM_DEFAULT_URL", "udpm://239.255.76.67:7667?ttl=1"},
                                           {"TZ", "UTC"},
                                       }));
  EXPECT_EQ(process_environment(d, Process{}).at("IPS_MODE"), "lab");
}

// ---------------------------------------------------------------------------------------------
// systemd units (docs/deployment.md, "Production: systemd units")

TEST(SystemdQuote, EscapesBackslashQuoteAndSpecifiers) {
  EXPECT_EQ(systemd_quote("plain", true), "\"plain\"");
  EXPECT_EQ(systemd_quote(R"(C:\dir)", false), R"("C:\\dir")");
  EXPECT_EQ(systemd_quote(R"(say "hi")", false), R"("say \"hi\"")");
  // % is a specifier everywhere; $ only in ExecStart=, where variables are expanded.
  EXPECT_EQ(systemd_quote("50%", false), "\"50%%\"");
  EXPECT_EQ(systemd_quote("50%", true), "\"50%%\"");
  EXPECT_EQ(systemd_quote("$HOME", true), "\"$$HOME\"");
  EXPECT_EQ(systemd_quote("$HOME", false), "\"$HOME\"");
  EXPECT_EQ(systemd_quote("", true), "\"\"");
}

const char* kComputeHost = R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
bin_dir: /usr/local/lib/ips-fusion/bin
user: ips
working_dir: /var/lib/ips
environment: {TZ: UTC}
hosts:
  - name: compute
    hostname: lab-pc-2
    processes:
      - name: uwb-twr
        command: ips-uwb-twr
        args: [--log-level, info]
      - name: fuse
        command: ips-fuse
        args: [--note, "50% of $HOME", "a \"quoted\" \\ word"]
        restart: always
        after: [uwb-twr]
        environment: {IPS_MODE: "a \"b\" $X 5%"}
        restart_backoff: {initial_s: 2, max_s: 2}
        stop_timeout_s: 15
      - name: logger
        command: lcm-logger
        restart: "no"
  - name: other
    processes: [{name: view, command: ips-view}]
)";

std::map<std::string, std::string> compute_units(const Deployment& d, int systemd_version = 254) {
  const Host* h = d.host("compute");
  EXPECT_NE(h, nullptr);
  return systemd_units(d, *h,
                       {{"uwb-twr", "/usr/local/lib/ips-fusion/bin/ips-uwb-twr"},
                        {"fuse", "/usr/local/lib/ips-fusion/bin/ips-fuse"},
                        {"logger", "lcm-logger"}},
                       systemd_version);
}

TEST(SystemdUnits, OneServicePerProcessOfTheHostAndATarget) {
  const Deployment d = parse(kComputeHost);
  EXPECT_EQ(unit_name(d, d.hosts[0].processes[0]), "ips-lab-uwb-twr.service");
  EXPECT_EQ(target_name(d), "ips-lab.target");
  std::vector<std::string> names;
  for (const auto& [name, text] : compute_units(d)) names.push_back(name);
  EXPECT_THAT(names, ElementsAre("ips-lab-fuse.service", "ips-lab-logger.service",
                                 "ips-lab-uwb-twr.service", "ips-lab.target"));
}

TEST(SystemdUnits, UwbTwrServiceIsTheDocumentedOne) {
  // docs/deployment.md's unit for uwb-twr of config/deploy/lab-3-hosts.yaml, line for line.
  const std::string expected =
      "# Written by ips-deploy from the deployment 'lab', host 'compute', for systemd 254. "
      "Regenerate rather than edit.\n"
      "[Unit]\n"
      "Description=ips-fusion lab: uwb-twr on compute\n"
      "Wants=network-online.target\n"
      "After=network-online.target\n"
      "PartOf=ips-lab.target\n"
      "StartLimitIntervalSec=0\n"
      "\n"
      "[Service]\n"
      "Type=simple\n"
      "ExecStart=\"/usr/local/lib/ips-fusion/bin/ips-uwb-twr\" \"--log-level\" \"info\"\n"
      "Environment=\"LCM_DEFAULT_URL=udpm://239.255.76.67:7667?ttl=1\"\n"
      "Environment=\"TZ=UTC\"\n"
      "WorkingDirectory=/var/lib/ips\n"
      "User=ips\n"
      "Restart=on-failure\n"
      "RestartSec=1s\n"
      "# Exponential back-off (systemd >= 254).\n"
      "RestartSteps=5\n"
      "RestartMaxDelaySec=30s\n"
      "KillSignal=SIGINT\n"
      "TimeoutStopSec=5s\n"
      "\n"
      "[Install]\n"
      "WantedBy=ips-lab.target\n";
  EXPECT_EQ(compute_units(parse(kComputeHost)).at("ips-lab-uwb-twr.service"), expected);
}

TEST(SystemdUnits, QuotedArgumentsEnvironmentAfterAndFixedBackoff) {
  const std::string fuse = compute_units(parse(kComputeHost)).at("ips-lab-fuse.service");
  // The arguments reach the program as written: % and $ doubled, \ and " escaped.
  EXPECT_THAT(fuse, HasSubstr("\nExecStart=\"/usr/local/lib/ips-fusion/bin/ips-fuse\" "
                              "\"--note\" \"50%% of $$HOME\" \"a \\\"quoted\\\" \\\\ word\"\n"));
  // Environment=: sorted by name, the process's variable with its $ left alone.
  EXPECT_THAT(fuse, HasSubstr("\nEnvironment=\"IPS_MODE=a \\\"b\\\" $X 5%%\"\n"
                              "Environment=\"LCM_DEFAULT_URL=udpm://239.255.76.67:7667?ttl=1\"\n"
                              "Environment=\"TZ=UTC\"\n"));
  EXPECT_THAT(fuse, HasSubstr("\nAfter=network-online.target ips-lab-uwb-twr.service\n"));
  EXPECT_THAT(fuse, HasSubstr("\nRestart=always\n"));
  EXPECT_THAT(fuse, HasSubstr("\nRestartSec=2s\n"));
  // max_s == initial_s: no exponential back-off lines.
  EXPECT_THAT(fuse, Not(HasSubstr("RestartSteps")));
  EXPECT_THAT(fuse, Not(HasSubstr("RestartMaxDelaySec")));
  EXPECT_THAT(fuse, HasSubstr("\nStartLimitIntervalSec=0\n"));
  EXPECT_THAT(fuse, HasSubstr("\nKillSignal=SIGINT\n"));
  EXPECT_THAT(fuse, HasSubstr("\nTimeoutStopSec=15s\n"));

  const std::string logger = compute_units(parse(kComputeHost)).at("ips-lab-logger.service");
  EXPECT_THAT(logger, HasSubstr("\nExecStart=\"lcm-logger\"\n"));
  EXPECT_THAT(logger, HasSubstr("\nRestart=no\n"));
  EXPECT_THAT(logger, HasSubstr("\nAfter=network-online.target\n"));
}

TEST(SystemdUnits, RestartStepsAreTheDoublingsFromInitialToMax) {
  // RestartSteps = ceil(log2(max_s / initial_s)) (docs/deployment.md, "Restart and back-off").
  const auto steps_line = [](const std::string& backoff) {
    const Deployment d = parse(
        "name: lab\nlcm_url: \"udpm://239.255.76.67:7667?ttl=1\"\n"
        "hosts:\n  - name: a\n    processes:\n"
        "      - {name: p, command: ips-sim, restart_backoff: " +
        backoff + "}\n");
    const std::string unit =
        systemd_units(d, d.hosts[0], {{"p", "/bin/ips-sim"}}, 254).at("ips-lab-p.service");
    const size_t at = unit.find("RestartSteps=");
    if (at == std::string::npos) return std::string("none");
    return unit.substr(at, unit.find('\n', at) - at);
  };
  EXPECT_EQ(steps_line("{initial_s: 1, max_s: 30}"), "RestartSteps=5");   // 4.91 doublings
  EXPECT_EQ(steps_line("{initial_s: 1, max_s: 32}"), "RestartSteps=5");   // exactly 5
  EXPECT_EQ(steps_line("{initial_s: 5, max_s: 300}"), "RestartSteps=6");  // the recorder's
  EXPECT_EQ(steps_line("{initial_s: 1, max_s: 1.5}"), "RestartSteps=1");
  EXPECT_EQ(steps_line("{initial_s: 4, max_s: 4}"), "none");
}

TEST(SystemdUnits, UserAndWorkingDirectoryOnlyWhenGiven) {
  const Deployment d = parse(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes: [{name: p, command: ips-sim}]
)");
  const std::string unit =
      systemd_units(d, d.hosts[0], {{"p", "ips-sim"}}, 254).at("ips-lab-p.service");
  EXPECT_THAT(unit, Not(HasSubstr("User=")));
  EXPECT_THAT(unit, Not(HasSubstr("WorkingDirectory=")));
  // Nothing but LCM_DEFAULT_URL in the environment.
  EXPECT_THAT(unit, HasSubstr("\nEnvironment=\"LCM_DEFAULT_URL=udpm://239.255.76.67:7667?ttl=1\"\n"
                              "Restart=on-failure\n"));
}

TEST(SystemdUnits, TargetWantsEveryServiceOfTheHostInStartOrder) {
  const std::string target = compute_units(parse(kComputeHost)).at("ips-lab.target");
  EXPECT_EQ(target,
            "# Written by ips-deploy from the deployment 'lab', host 'compute', for systemd 254.\n"
            "[Unit]\n"
            "Description=ips-fusion lab on compute\n"
            "Wants=ips-lab-uwb-twr.service ips-lab-fuse.service ips-lab-logger.service\n"
            "\n"
            "[Install]\n"
            "WantedBy=multi-user.target\n");
  // The other host's process is not in it.
  EXPECT_THAT(target, Not(HasSubstr("view")));
}

TEST(SystemdVersion, FirstLineOfSystemctlVersion) {
  EXPECT_EQ(parse_systemctl_version("systemd 252 (252.38-1~deb12u1)\n"), 252);
  EXPECT_EQ(parse_systemctl_version("systemd 256 (256.7-1)"), 256);
  EXPECT_EQ(parse_systemctl_version("systemd 254"), 254);
  EXPECT_EQ(parse_systemctl_version(""), 0);
  EXPECT_EQ(parse_systemctl_version("sh: 1: systemctl: not found\n"), 0);
  EXPECT_EQ(parse_systemctl_version("systemd abc"), 0);
  EXPECT_EQ(parse_systemctl_version("systemd 25x"), 0);
  EXPECT_EQ(parse_systemctl_version("systemd 99999999999999999999"), 0);
}

TEST(SystemdUnits, AtAndAbove254EveryUnitNeverGivesUpAndThereIsNoRetryUnit) {
  for (int version : {254, 256}) {
    std::vector<std::string> names;
    for (const auto& [name, text] : compute_units(parse(kComputeHost), version)) {
      names.push_back(name);
      EXPECT_THAT(text, Not(HasSubstr("StartLimitBurst"))) << name;
      EXPECT_THAT(text, Not(HasSubstr("OnFailure"))) << name;
    }
    EXPECT_THAT(names, ElementsAre("ips-lab-fuse.service", "ips-lab-logger.service",
                                   "ips-lab-uwb-twr.service", "ips-lab.target"));
  }
}

TEST(SystemdUnits, Below254UwbTwrServiceIsTheDocumentedOne) {
  // docs/deployment.md's unit for uwb-twr on systemd 252 (Debian 12), line for line: no key
  // that systemd 252 does not know, a start limit instead of the growing delay, and the retry.
  const std::string expected =
      "# Written by ips-deploy from the deployment 'lab', host 'compute', for systemd 252. "
      "Regenerate rather than edit.\n"
      "[Unit]\n"
      "Description=ips-fusion lab: uwb-twr on compute\n"
      "Wants=network-online.target\n"
      "After=network-online.target\n"
      "PartOf=ips-lab.target\n"
      "# systemd 252 has no RestartSteps=/RestartMaxDelaySec= (>= 254): the delay does not\n"
      "# grow. Instead: at most 6 starts in 61s, each 1s after the last exit; then\n"
      "# systemd gives up and ips-lab-uwb-twr-retry.service starts it again 30s later.\n"
      "StartLimitIntervalSec=61s\n"
      "StartLimitBurst=6\n"
      "OnFailure=ips-lab-uwb-twr-retry.service\n"
      "\n"
      "[Service]\n"
      "Type=simple\n"
      "ExecStart=\"/usr/local/lib/ips-fusion/bin/ips-uwb-twr\" \"--log-level\" \"info\"\n"
      "Environment=\"LCM_DEFAULT_URL=udpm://239.255.76.67:7667?ttl=1\"\n"
      "Environment=\"TZ=UTC\"\n"
      "WorkingDirectory=/var/lib/ips\n"
      "User=ips\n"
      "Restart=on-failure\n"
      "RestartSec=1s\n"
      "KillSignal=SIGINT\n"
      "TimeoutStopSec=5s\n"
      "\n"
      "[Install]\n"
      "WantedBy=ips-lab.target\n";
  const auto units = compute_units(parse(kComputeHost), 252);
  EXPECT_EQ(units.at("ips-lab-uwb-twr.service"), expected);
  const std::string retry =
      "# Written by ips-deploy from the deployment 'lab', host 'compute', for systemd 252. "
      "Regenerate rather than edit.\n"
      "# systemd < 254 only: ips-lab-uwb-twr.service names this unit in OnFailure=, which runs "
      "once systemd\n"
      "# has given up restarting it (StartLimitBurst=): it starts it again 30 s later (max_s), "
      "so that it is not\n"
      "# left stopped for good.\n"
      "[Unit]\n"
      "Description=ips-fusion lab: uwb-twr on compute, started again after its restarts ran out\n"
      "PartOf=ips-lab.target\n"
      "\n"
      "[Service]\n"
      "Type=oneshot\n"
      "TimeoutStartSec=infinity\n"
      "ExecStart=/bin/sleep 30\n"
      "ExecStart=/bin/systemctl reset-failed ips-lab-uwb-twr.service\n"
      "ExecStart=/bin/systemctl start --no-block ips-lab-uwb-twr.service\n";
  EXPECT_EQ(units.at("ips-lab-uwb-twr-retry.service"), retry);
  // Only uwb-twr has a growing back-off and a restart policy: fuse's is fixed (2 s), logger's
  // policy is no. Neither gets a start limit (systemd never gives up on fuse) nor a retry.
  std::vector<std::string> names;
  for (const auto& [name, text] : units) {
    names.push_back(name);
    // The keys (the comment names them).
    EXPECT_THAT(text, Not(HasSubstr("\nRestartSteps="))) << name;
    EXPECT_THAT(text, Not(HasSubstr("\nRestartMaxDelaySec="))) << name;
  }
  EXPECT_THAT(names, ElementsAre("ips-lab-fuse.service", "ips-lab-logger.service",
                                 "ips-lab-uwb-twr-retry.service", "ips-lab-uwb-twr.service",
                                 "ips-lab.target"));
  for (const char* name : {"ips-lab-fuse.service", "ips-lab-logger.service"}) {
    EXPECT_THAT(units.at(name), HasSubstr("\nStartLimitIntervalSec=0\n")) << name;
    EXPECT_THAT(units.at(name), Not(HasSubstr("OnFailure="))) << name;
  }
  // The target wants the services, not the retries (OnFailure= starts those).
  EXPECT_THAT(units.at("ips-lab.target"),
              HasSubstr("\nWants=ips-lab-uwb-twr.service ips-lab-fuse.service "
                        "ips-lab-logger.service\n"));
}

TEST(SystemdUnits, Below254StartLimitIsTheExponentialBackoffsStartsAndTheirTime) {
  // burst: the starts the back-off makes before its delay reaches max_s (RestartSteps + 1);
  // interval: the time those take at the back-off's delays, plus max_s.
  const auto limit = [](double initial, double max) {
    Backoff b;
    b.initial_s = initial;
    b.max_s = max;
    const StartLimit l = start_limit(b);
    return std::to_string(l.burst) + " in " + std::to_string(static_cast<int>(l.interval_s));
  };
  EXPECT_EQ(limit(1, 30), "6 in 61");    // 1+2+4+8+16 + 30
  EXPECT_EQ(limit(1, 32), "6 in 63");    // 1+2+4+8+16 + 32
  EXPECT_EQ(limit(5, 300), "7 in 615");  // the recorder's: 5+10+20+40+80+160 + 300
  EXPECT_EQ(limit(1, 1.5), "2 in 2");    // 1 + 1.5
  EXPECT_EQ(limit(4, 4), "0 in 0");      // a fixed delay: no limit
}

TEST(SystemdUnits, CommandsSystemdCannotFind) {
  const Deployment d = parse(kComputeHost);
  const std::set<std::string> programs = {"/usr/local/lib/ips-fusion/bin/ips-fuse",
                                          "/usr/bin/lcm-logger"};
  const auto is_program = [&](const std::string& p) { return programs.count(p) > 0; };
  // uwb-twr's path is not a program; fuse's is; lcm-logger is found in systemd's search path.
  EXPECT_THAT(commands_systemd_cannot_find(d.hosts[0],
                                           {{"uwb-twr", "/usr/local/lib/ips-fusion/bin/ips-uwb-twr"},
                                            {"fuse", "/usr/local/lib/ips-fusion/bin/ips-fuse"},
                                            {"logger", "lcm-logger"}},
                                           is_program),
              ElementsAre("uwb-twr: /usr/local/lib/ips-fusion/bin/ips-uwb-twr"));
  // A bare name that is in none of its directories (bin_dir did not have it either).
  EXPECT_THAT(commands_systemd_cannot_find(d.hosts[0],
                                           {{"uwb-twr", "ips-uwb-twr"},
                                            {"fuse", "ips-fuse"},
                                            {"logger", "lcm-logger"}},
                                           is_program),
              ElementsAre("uwb-twr: ips-uwb-twr", "fuse: ips-fuse"));
}

// ---------------------------------------------------------------------------------------------
// Restart back-off and policy (ips-deploy run)

TEST(BackoffPolicy, DoublesFromInitialToMax) {
  // docs/deployment.md's table, column "ips-deploy run": 1, 2, 4, 8, 16, then 30 s.
  BackoffPolicy b(Backoff{1.0, 30.0, 60.0});
  std::vector<double> delays;
  for (int i = 0; i < 7; ++i) delays.push_back(b.next_delay(0.5));
  EXPECT_THAT(delays, ElementsAre(1.0, 2.0, 4.0, 8.0, 16.0, 30.0, 30.0));
}

TEST(BackoffPolicy, RunOfResetAfterStartsAgainFromInitial) {
  BackoffPolicy b(Backoff{1.0, 30.0, 60.0});
  EXPECT_EQ(b.next_delay(1), 1.0);
  EXPECT_EQ(b.next_delay(1), 2.0);
  EXPECT_EQ(b.next_delay(59.9), 4.0);
  EXPECT_EQ(b.next_delay(61), 1.0);  // ran longer than reset_after_s
  EXPECT_EQ(b.next_delay(1), 2.0);
  EXPECT_EQ(b.next_delay(60), 1.0);  // exactly reset_after_s counts
  // The first delay is initial_s however long the run.
  BackoffPolicy fresh(Backoff{5.0, 300.0, 60.0});
  EXPECT_EQ(fresh.next_delay(3600), 5.0);
}

TEST(ShouldRestart, PolicyTruthTable) {
  EXPECT_FALSE(should_restart(Restart::kNo, true));
  EXPECT_FALSE(should_restart(Restart::kNo, false));
  EXPECT_FALSE(should_restart(Restart::kOnFailure, true));
  EXPECT_TRUE(should_restart(Restart::kOnFailure, false));
  EXPECT_TRUE(should_restart(Restart::kAlways, true));
  EXPECT_TRUE(should_restart(Restart::kAlways, false));
}

TEST(DescribeWaitStatus, ExitStatusAndSignal) {
  EXPECT_EQ(describe_wait_status(W_EXITCODE(3, 0)), "status 3");
  EXPECT_EQ(describe_wait_status(W_EXITCODE(0, 0)), "status 0");
  // A wait status for "killed by signal N" is N itself (no core dump).
  EXPECT_EQ(describe_wait_status(SIGKILL), "signal 9 (SIGKILL)");
  EXPECT_EQ(describe_wait_status(SIGSEGV), "signal 11 (SIGSEGV)");
}

// ---------------------------------------------------------------------------------------------
// Status from HEALTH (ips-deploy status)

constexpr utime_t kNow = 1'700'000'000'000'000;  // host clock, us

const char* kStatusDeployment = R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    hostname: pc-a
    processes:
      - {name: sim, command: ips-sim}
  - name: b
    processes:
      - {name: uwb-twr, command: /opt/ips/bin/ips-uwb-twr}
      - {name: logger, command: lcm-logger}
)";

Heard heard(const std::string& host, const std::string& source, int32_t pid, double age_s,
            int8_t state = health_t::STATE_OK) {
  Heard h{};
  h.health.utime = kNow - s_to_utime(age_s);
  h.health.source = source;
  h.health.host = host;
  h.health.pid = pid;
  h.health.state = state;
  h.health.uptime_us = 0;
  h.host_utime = kNow - s_to_utime(age_s);
  return h;
}

std::vector<Heard> lab_heard() {
  std::vector<Heard> v;
  v.push_back(heard("pc-a", "ips-sim", 100, 0.5));
  v.back().health.uptime_us = 120'000'000;
  v.back().health.msgs_out = 5000;
  // uwb-twr restarted: its old pid last heard 10 s ago (in error then), the new one just now.
  v.push_back(heard("b", "ips-uwb-twr", 200, 10.0, health_t::STATE_ERROR));
  v.back().health.last_error = "old run";
  v.push_back(heard("b", "ips-uwb-twr", 201, 0.2));
  v.back().health.uptime_us = 3'500'000;
  v.back().health.msgs_in = 700;
  v.back().health.msgs_out = 70;
  v.back().health.drops = 2;
  v.back().health.kernel_drops = 30;
  v.back().health.queue_drops = 4;
  v.back().health.seq_lost = 7;
  v.push_back(heard("b", "ips-deploy", 300, 0.8));
  v.push_back(heard("c", "ips-view", 400, 1.0));
  return v;
}

TEST(CompareStatus, MatchesHeardHealthToTheDeployment) {
  const Deployment d = parse(kStatusDeployment);
  const StatusReport r = compare_status(&d, lab_heard(), kNow);
  ASSERT_EQ(r.rows.size(), 5u);

  EXPECT_EQ(r.rows[0].host, "a");  // the deployment's name, matched by hostname pc-a
  EXPECT_EQ(r.rows[0].process, "sim");
  EXPECT_EQ(r.rows[0].program, "ips-sim");
  EXPECT_EQ(r.rows[0].pid, 100);
  EXPECT_EQ(r.rows[0].state, "ok");
  EXPECT_NEAR(r.rows[0].age_s, 0.5, 1e-6);
  EXPECT_NEAR(r.rows[0].uptime_s, 120.0, 1e-9);
  EXPECT_EQ(r.rows[0].msgs_out, 5000);

  // The fresh pid; the stale one (10 s > 2.5 s) has gone and is not listed at all.
  EXPECT_EQ(r.rows[1].host, "b");
  EXPECT_EQ(r.rows[1].process, "uwb-twr");
  EXPECT_EQ(r.rows[1].program, "ips-uwb-twr");
  EXPECT_EQ(r.rows[1].pid, 201);
  EXPECT_EQ(r.rows[1].state, "ok");
  EXPECT_NEAR(r.rows[1].age_s, 0.2, 1e-6);
  EXPECT_NEAR(r.rows[1].uptime_s, 3.5, 1e-9);
  EXPECT_EQ(r.rows[1].msgs_in, 700);
  EXPECT_EQ(r.rows[1].msgs_out, 70);
  EXPECT_EQ(r.rows[1].drops, 2);
  EXPECT_EQ(r.rows[1].kernel_drops, 30);
  EXPECT_EQ(r.rows[1].queue_drops, 4);
  EXPECT_EQ(r.rows[1].seq_lost, 7);
  EXPECT_THAT(status_json(r), HasSubstr("\"kernel_drops\":30,\"queue_drops\":4,\"seq_lost\":7"));
  EXPECT_THAT(format_status(r), testing::ContainsRegex("ips-uwb-twr +201 .* 700 +70 +2 +34 +7 "));
  EXPECT_EQ(r.rows[1].last_error, "");
  for (const StatusRow& row : r.rows) EXPECT_NE(row.pid, 200);

  // lcm-logger publishes no HEALTH: listed, not expected.
  EXPECT_EQ(r.rows[2].host, "b");
  EXPECT_EQ(r.rows[2].process, "logger");
  EXPECT_EQ(r.rows[2].program, "lcm-logger");
  EXPECT_EQ(r.rows[2].pid, 0);
  EXPECT_EQ(r.rows[2].state, "no HEALTH");

  // ips-deploy itself on b: an extra row of that host, with no process.
  EXPECT_EQ(r.rows[3].host, "b");
  EXPECT_EQ(r.rows[3].process, "");
  EXPECT_EQ(r.rows[3].program, "ips-deploy");
  EXPECT_EQ(r.rows[3].pid, 300);

  // A host the deployment does not name, at the end under its hostname.
  EXPECT_EQ(r.rows[4].host, "c");
  EXPECT_EQ(r.rows[4].process, "");
  EXPECT_EQ(r.rows[4].program, "ips-view");
  EXPECT_EQ(r.rows[4].pid, 400);

  EXPECT_EQ(r.expected, 2);
  EXPECT_EQ(r.missing, 0);
  EXPECT_EQ(r.in_error, 0);
  EXPECT_TRUE(r.ok());
  EXPECT_THAT(format_status(r), HasSubstr("\n2 of 2 expected processes heard\n"));
}

TEST(CompareStatus, TwoLivePidsOfOneProgramMatchTheNewest) {
  const Deployment d = parse(kStatusDeployment);
  std::vector<Heard> v = lab_heard();
  v.push_back(heard("b", "ips-uwb-twr", 199, 1.5));  // still within stale_s
  const StatusReport r = compare_status(&d, v, kNow);
  ASSERT_EQ(r.rows.size(), 6u);
  EXPECT_EQ(r.rows[1].pid, 201);
  // The older one is listed with b's others, sorted by program then pid.
  EXPECT_EQ(r.rows[3].program, "ips-deploy");
  EXPECT_EQ(r.rows[4].host, "b");
  EXPECT_EQ(r.rows[4].process, "");
  EXPECT_EQ(r.rows[4].program, "ips-uwb-twr");
  EXPECT_EQ(r.rows[4].pid, 199);
  EXPECT_TRUE(r.ok());
}

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

TEST(CompareStatus, ProcessWithoutHealthIsMissing) {
  const Deployment d = parse(kStatusDeployment);
  std::vector<Heard> v = lab_heard();
  v.erase(v.begin());  // no ips-sim from pc-a
  const StatusReport r = compare_status(&d, v, kNow);
  ASSERT_EQ(r.rows.size(), 5u);
  EXPECT_EQ(r.rows[0].host, "a");
  EXPECT_EQ(r.rows[0].process, "sim");
  EXPECT_EQ(r.rows[0].program, "ips-sim");
  EXPECT_EQ(r.rows[0].pid, 0);
  EXPECT_EQ(r.rows[0].state, "MISSING");
  EXPECT_EQ(r.expected, 2);
  EXPECT_EQ(r.missing, 1);
  EXPECT_EQ(r.in_error, 0);
  EXPECT_FALSE(r.ok());

  const std::string text = format_status(r);
  EXPECT_THAT(text, HasSubstr("host a\n"));
  EXPECT_THAT(text, HasSubstr("\nhost b\n"));
  EXPECT_THAT(text, HasSubstr("\nhost c\n"));
  EXPECT_THAT(text, HasSubstr("\n1 of 2 expected processes heard\n"));
  EXPECT_THAT(text, Not(HasSubstr("in error")));
  const size_t at = text.find("MISSING");
  ASSERT_NE(at, std::string::npos);
  const size_t begin = text.rfind('\n', at) + 1;
  EXPECT_THAT(words(text.substr(begin, text.find('\n', at) - begin)),
              ElementsAre("sim", "ips-sim", "-", "MISSING", "-", "-", "-", "-", "-", "-", "-"));

  const std::string json = status_json(r);
  EXPECT_THAT(json, HasSubstr("\"ok\":false"));
  // JSON is YAML: yaml-cpp reads it back.
  const YAML::Node parsed = YAML::Load(json);
  EXPECT_FALSE(parsed["ok"].as<bool>());
  EXPECT_EQ(parsed["expected"].as<int>(), 2);
  EXPECT_EQ(parsed["missing"].as<int>(), 1);
  EXPECT_EQ(parsed["in_error"].as<int>(), 0);
  ASSERT_EQ(parsed["processes"].size(), 5u);
  EXPECT_EQ(parsed["processes"][0]["host"].as<std::string>(), "a");
  EXPECT_EQ(parsed["processes"][0]["process"].as<std::string>(), "sim");
  EXPECT_EQ(parsed["processes"][0]["state"].as<std::string>(), "MISSING");
  EXPECT_EQ(parsed["processes"][1]["pid"].as<int>(), 201);
  EXPECT_EQ(parsed["processes"][1]["msgs_in"].as<int>(), 700);
}

TEST(CompareStatus, ProcessInErrorIsCounted) {
  const Deployment d = parse(kStatusDeployment);
  std::vector<Heard> v = lab_heard();
  v[2].health.state = health_t::STATE_ERROR;  // the fresh uwb-twr
  v[2].health.last_error = "no SITE received";
  const StatusReport r = compare_status(&d, v, kNow);
  EXPECT_EQ(r.rows[1].state, "error");
  EXPECT_EQ(r.rows[1].last_error, "no SITE received");
  EXPECT_EQ(r.missing, 0);
  EXPECT_EQ(r.in_error, 1);
  EXPECT_FALSE(r.ok());
  const std::string text = format_status(r);
  EXPECT_THAT(text, HasSubstr("\n2 of 2 expected processes heard, 1 in error\n"));
  EXPECT_THAT(text, HasSubstr("no SITE received"));
  EXPECT_THAT(status_json(r),
              HasSubstr("\"ok\":false,\"expected\":2,\"missing\":0,\"in_error\":1"));
}

TEST(CompareStatus, TerminalEscapesFromTheBusArePrintedEscaped) {
  const Deployment d = parse(kStatusDeployment);
  std::vector<Heard> v = lab_heard();
  v.push_back(heard("c\x1b[2J", "ips-\x1b[2Jview", 500, 0.1));
  v.back().health.last_error = "bad\x1b]0;title\x07";
  const StatusReport r = compare_status(&d, v, kNow);
  const std::string text = format_status(r);
  EXPECT_EQ(text.find('\x1b'), std::string::npos);
  EXPECT_EQ(text.find('\x07'), std::string::npos);
  EXPECT_THAT(text, HasSubstr("host c\\x1b[2J\n"));
  EXPECT_THAT(text, HasSubstr("ips-\\x1b[2Jview"));
  EXPECT_THAT(text, HasSubstr("bad\\x1b]0;title\\x07"));
  // In JSON as \u escapes.
  const std::string json = status_json(r);
  EXPECT_EQ(json.find('\x1b'), std::string::npos);
  EXPECT_THAT(json, HasSubstr("\"program\":\"ips-\\u001b[2Jview\""));
}

TEST(CompareStatus, WithoutADeploymentListsEverythingHeard) {
  const StatusReport r = compare_status(nullptr, lab_heard(), kNow);
  // Live only, by host (HEALTH's), program, pid.
  ASSERT_EQ(r.rows.size(), 4u);
  std::vector<std::string> keys;
  for (const StatusRow& row : r.rows) {
    EXPECT_EQ(row.process, "");
    keys.push_back(row.host + "/" + row.program + "/" + std::to_string(row.pid));
  }
  EXPECT_THAT(keys, ElementsAre("b/ips-deploy/300", "b/ips-uwb-twr/201", "c/ips-view/400",
                                "pc-a/ips-sim/100"));
  EXPECT_EQ(r.expected, 0);
  EXPECT_EQ(r.missing, 0);
  EXPECT_TRUE(r.ok());
  EXPECT_THAT(format_status(r), HasSubstr("\n0 of 0 expected processes heard\n"));
  EXPECT_THAT(format_status(compare_status(nullptr, {}, kNow)), HasSubstr("no HEALTH heard\n"));
}

// ---------------------------------------------------------------------------------------------
// The run file, and status matching a run on this machine by pid

RunRecord compute_run() {
  RunRecord r;
  r.deployment = "lab";
  r.host = "b";
  r.hostname = "laptop";  // not the file's hostname for b ("b")
  r.supervisor_pid = 4241;
  r.pids = {{"uwb-twr", 4242}, {"logger", 0}};
  return r;
}

TEST(RunFile, WrittenAndReadBack) {
  const std::string text = format_run_file(compute_run());
  EXPECT_EQ(text,
            "ips-deploy-run 1\n"
            "deployment lab\n"
            "host b\n"
            "hostname laptop\n"
            "supervisor 4241\n"
            "process logger 0\n"
            "process uwb-twr 4242\n");
  std::string error;
  const auto r = parse_run_file(text, error);
  ASSERT_TRUE(r) << error;
  EXPECT_EQ(r->deployment, "lab");
  EXPECT_EQ(r->host, "b");
  EXPECT_EQ(r->hostname, "laptop");
  EXPECT_EQ(r->supervisor_pid, 4241);
  EXPECT_EQ(r->pids, compute_run().pids);
}

TEST(RunFile, AnythingElseIsRefusedWithAReason) {
  const auto refused = [](const std::string& text) {
    std::string error;
    EXPECT_FALSE(parse_run_file(text, error)) << text;
    return error;
  };
  EXPECT_THAT(refused(""), HasSubstr("not a run file"));
  EXPECT_THAT(refused("name: lab\n"), HasSubstr("not a run file"));
  const std::string head = "ips-deploy-run 1\ndeployment lab\nhost b\nhostname x\n";
  EXPECT_EQ(refused(head), "incomplete (deployment, host, hostname and supervisor are needed)");
  EXPECT_EQ(refused(head + "supervisor -3\n"), "line 5: not understood: 'supervisor -3'");
  EXPECT_EQ(refused(head + "supervisor 9999999999\n"), "line 5: not understood: 'supervisor 9999999999'");
  EXPECT_EQ(refused(head + "supervisor 7\nprocess uwb-twr\n"),
            "line 6: not understood: 'process uwb-twr'");
  EXPECT_EQ(refused(head + "supervisor 7\ncolour red\n"), "line 6: not understood: 'colour red'");
  EXPECT_EQ(refused(head + "supervisor 7\nprocess a\x1b[2J 5x\n"),
            "line 6: not understood: 'process a\\x1b[2J 5x'");
}

TEST(RunFile, ReadingSkipsEndedRunsAndCountsUnreadableFiles) {
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("deploy_test_runs_" + std::to_string(::getpid())))
          .string();
  std::filesystem::remove_all(dir);
  RunRecord r = compute_run();
  std::string path, error;
  // This test is no ips-deploy: a run file with its pid is an ended run (the pid reused).
  r.supervisor_pid = static_cast<int32_t>(::getpid());
  ASSERT_TRUE(write_run_file(dir, r, path, error)) << error;
  EXPECT_EQ(path, dir + "/lab-b-" + std::to_string(::getpid()) + ".run");
  EXPECT_EQ(std::filesystem::status(dir).permissions() & std::filesystem::perms::all,
            std::filesystem::perms::owner_all);
  r.supervisor_pid = 0x7ffffff0;  // no such process
  ASSERT_TRUE(write_run_file(dir, r, path, error)) << error;
  std::ofstream(dir + "/broken.run") << "garbage\n";
  std::ofstream(dir + "/notes.txt") << "not a run file, not looked at\n";
  int unreadable = 0;
  std::vector<std::string> errors;
  EXPECT_TRUE(read_run_files(dir, "lab", unreadable, errors).empty());
  EXPECT_EQ(unreadable, 1);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_THAT(errors[0], HasSubstr("broken.run: not a run file"));
  // No directory (no run yet): nothing, no error.
  unreadable = 0;
  EXPECT_TRUE(read_run_files(dir + "/none", "lab", unreadable, errors).empty());
  EXPECT_EQ(unreadable, 0);
  std::filesystem::remove_all(dir);
}

TEST(CompareStatus, ARunOnThisMachineIsMatchedByPidWhateverTheHostname) {
  // The file says b's hostname is "b"; its run is on "laptop" (ips-deploy run --host b there).
  const Deployment d = parse(kStatusDeployment);
  std::vector<Heard> v;
  v.push_back(heard("pc-a", "ips-sim", 100, 0.5));
  v.push_back(heard("laptop", "ips-uwb-twr", 4242, 0.3));
  v.push_back(heard("laptop", "ips-deploy", 4241, 0.4));
  v.push_back(heard("laptop", "ips-uwb-twr", 999, 0.1));  // started by hand: not the run's
  v.push_back(heard("laptop", "ips-view", 998, 0.1));
  // Without the run: b's uwb-twr is MISSING, everything from laptop under "laptop".
  const StatusReport without = compare_status(&d, v, kNow);
  EXPECT_EQ(without.missing, 1);
  EXPECT_TRUE(without.notes.empty());

  const StatusReport r = compare_status(&d, v, kNow, {compute_run()});
  EXPECT_EQ(r.expected, 2);
  EXPECT_EQ(r.missing, 0);
  EXPECT_TRUE(r.ok());
  std::vector<std::string> keys;
  for (const StatusRow& row : r.rows)
    keys.push_back(row.host + "/" + row.process + "/" + row.program + "/" + std::to_string(row.pid));
  EXPECT_THAT(keys, ElementsAre("a/sim/ips-sim/100",
                                // The run's pid, not the newer one started by hand.
                                "b/uwb-twr/ips-uwb-twr/4242", "b/logger/lcm-logger/0",
                                // ips-deploy itself: the run's own pid.
                                "b//ips-deploy/4241",
                                // Not the run's: under the hostname they came from.
                                "laptop//ips-uwb-twr/999", "laptop//ips-view/998"));
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_EQ(r.notes[0],
            "host b: run on this machine by ips-deploy (pid 4241) under hostname 'laptop' (the "
            "file says 'b'); its processes matched by pid");
  EXPECT_THAT(format_status(r), HasSubstr("\n" + r.notes[0] + "\n\n2 of 2 expected processes heard\n"));
  const YAML::Node json = YAML::Load(status_json(r));
  ASSERT_EQ(json["notes"].size(), 1u);
  EXPECT_EQ(json["notes"][0].as<std::string>(), r.notes[0]);
  // A run of another deployment, or of a host the file does not have, is not used.
  RunRecord other = compute_run();
  other.deployment = "other";
  EXPECT_EQ(compare_status(&d, v, kNow, {other}).missing, 1);
  other = compute_run();
  other.host = "zz";
  EXPECT_EQ(compare_status(&d, v, kNow, {other}).missing, 1);
}

TEST(CompareStatus, TwoHostsRunOnOneMachineEachGetTheirOwnPids) {
  // Both hosts run one ips-uwb-twr, both on "laptop": by program name alone either could take
  // either; by the runs' pids each gets its own.
  const Deployment d = parse(R"(name: lab
lcm_url: "udpm://239.255.76.67:7667?ttl=1"
hosts:
  - name: a
    processes: [{name: twr-a, command: ips-uwb-twr}]
  - name: b
    processes: [{name: twr-b, command: ips-uwb-twr}]
)");
  std::vector<Heard> v;
  v.push_back(heard("laptop", "ips-uwb-twr", 20, 0.1));  // b's, the newest
  v.push_back(heard("laptop", "ips-uwb-twr", 10, 0.5));  // a's
  RunRecord ra{"lab", "a", "laptop", 1, {{"twr-a", 10}}};
  RunRecord rb{"lab", "b", "laptop", 2, {{"twr-b", 20}}};
  const StatusReport r = compare_status(&d, v, kNow, {rb, ra});
  ASSERT_EQ(r.rows.size(), 2u);
  EXPECT_EQ(r.rows[0].process, "twr-a");
  EXPECT_EQ(r.rows[0].pid, 10);
  EXPECT_EQ(r.rows[1].process, "twr-b");
  EXPECT_EQ(r.rows[1].pid, 20);
  EXPECT_EQ(r.notes.size(), 2u);
  EXPECT_TRUE(r.ok());
}

}  // namespace
}  // namespace ips::deploy
