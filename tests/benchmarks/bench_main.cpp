// ips-bench's main: Google Benchmark's own, plus --version like every ips-* program, and the
// build in the report's context ("ips_version"), so that a saved result says which build made it.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstring>

#include "core/version.hpp"

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--version") == 0) {
      std::printf("%s\n", ips::version_line("ips-bench").c_str());
      return 0;
    }
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("ips_version", ips::version_text());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
