// SPDX-License-Identifier: Apache-2.0
// scanprep-server: the gRPC service. Stops gracefully on SIGINT/SIGTERM.
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include <malloc.h>
#include <pthread.h>
// GCC says __SANITIZE_ADDRESS__, clang __has_feature(address_sanitizer).
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SCANPREP_LEAK_CHECK_AT_EXIT
#endif
#endif
#ifdef __SANITIZE_ADDRESS__
#define SCANPREP_LEAK_CHECK_AT_EXIT
#endif
#ifdef SCANPREP_LEAK_CHECK_AT_EXIT
#include <sanitizer/lsan_interface.h>
#endif

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/flags/usage_config.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/synchronization/notification.h"
#include "absl/time/time.h"
#include "core/base/status_macros.h"
#include "core/pipeline/plan_cost.h"
#include "server/admission/memory_reservation.h"
#include "server/job/presets_file.h"
#include "server/job/time_budget_config.h"
#include "server/scanprep_server.h"
#include "server/transport/transport_security.h"

ABSL_FLAG(std::string, listen, "0.0.0.0:50051", "HOST:PORT to listen on (port 0 = any free port)");
ABSL_FLAG(std::string, tls_cert, "", "PEM certificate chain of the gRPC port (TLS)");
ABSL_FLAG(std::string, tls_key, "", "PEM private key of --tls_cert");
ABSL_FLAG(std::string, tls_client_ca, "",
          "PEM CA bundle: clients must present a certificate it signed (mutual TLS)");
ABSL_FLAG(absl::Duration, tls_reload_interval, absl::Minutes(1),
          "how often the three TLS files are read again: a renewed certificate is served without "
          "a restart (at least 1s)");
ABSL_FLAG(bool, plaintext, false,
          "serve the gRPC port unencrypted and unauthenticated; without it the server needs the "
          "TLS flags and refuses to start");
ABSL_FLAG(uint64_t, max_points_per_job, 0,
          "largest job in points; larger jobs end with RESOURCE_EXHAUSTED. 0 = 20,000,000 or the "
          "largest job whose estimated memory fits --memory_capacity, whichever is smaller; a "
          "larger explicit value than fits is refused at startup");
ABSL_FLAG(double, max_plan_cost, 3,
          "the most work a job's stages and parameters may ask for, as a multiple of the default "
          "plan's (estimated at the header); costlier jobs, and presets, are refused. Each costly "
          "parameter alone at the edge of its range is within 3. 0 = no limit");
ABSL_FLAG(uint64_t, max_chunk_points, 65'536,
          "largest request chunk in points; larger chunks end the call with RESOURCE_EXHAUSTED");
ABSL_FLAG(uint32_t, max_message_bytes, 64 << 20,
          "largest request message gRPC accepts: a stream's chunk, or a whole ProcessUnary job "
          "(about 5 M points with packed xyz at the default); at most 1 GiB");
ABSL_FLAG(uint64_t, max_bytes_per_call, uint64_t{1} << 30,
          "serialized size of all request messages of one call; beyond it the call ends with "
          "RESOURCE_EXHAUSTED");
ABSL_FLAG(uint32_t, max_scans_per_job, 1'000,
          "scans one job header may declare; more end the call with RESOURCE_EXHAUSTED");
ABSL_FLAG(int, max_calls_per_peer, 0,
          "opt-in cap: Process calls one client host (see --trusted_proxies) may have in "
          "progress, queued included; more end at once with RESOURCE_EXHAUSTED (PEER_LIMIT). "
          "0 = no cap: one host may use every slot and queue place, and hosts that contend take "
          "turns in the queue");
ABSL_FLAG(std::string, trusted_proxies, "",
          "comma-separated CIDR ranges (IPv4 or IPv6, e.g. 10.0.0.0/8,fd00::/8) of proxies whose "
          "x-forwarded-for names the client host: from the right, the first address that is not "
          "itself a trusted proxy. Empty = the direct peer is the client host");
ABSL_FLAG(std::string, log_format, "text",
          "the log (stderr) and the startup lines (stdout): text, or json (one object a line, "
          "for a log collector)");
ABSL_FLAG(std::string, metrics_listen, ":9464",
          "[HOST]:PORT of the Prometheus /metrics endpoint: without HOST, --listen's host (so a "
          "server on loopback keeps its metrics there too); port 0 = any free port; empty = off");
ABSL_FLAG(int, max_sensors, 64,
          "ScanHeader.sensor_id values besides --sensor_allowlist's that hold their own `sensor` "
          "label in the scanprep_sensor_* metrics at once: a new sensor takes the label of the "
          "least recently reported one, whose series go (scanprep_sensor_labels_evicted_total). "
          "0 = only the allow-listed sensors have labels, the others share sensor=\"other\"");
ABSL_FLAG(std::string, sensor_allowlist, "",
          "comma-separated sensor ids that always have their own `sensor` label, never evicted "
          "and not counted in --max_sensors (the plant's own sensors, so that no client's ids "
          "can push them out)");
ABSL_FLAG(int, max_sensor_pairs, 256,
          "sensor pairs that hold their own `sensor_pair` label at once, by recency like "
          "--max_sensors, whatever the scans per job (pairs of two allow-listed sensors are not "
          "counted); the others share sensor_pair=\"other\"");
ABSL_FLAG(double, sensor_tolerance_mm, 0.05,
          "a sensor pair's |residual median| or misalignment translation (mm) beyond which "
          "ScanprepSensorPairMisaligned fires; exported as scanprep_sensor_tolerance_mm");
ABSL_FLAG(double, sensor_rotation_tolerance_deg, 0.05,
          "a sensor pair's misalignment rotation (degrees) beyond which "
          "ScanprepSensorPairMisaligned fires; exported as "
          "scanprep_sensor_rotation_tolerance_degrees");
ABSL_FLAG(int, max_concurrent_jobs, 4,
          "jobs holding a slot (processing, downloading) at once; a call takes one after its "
          "upload, and waits for it");
ABSL_FLAG(int, max_queued_jobs, 8,
          "calls beyond --max_concurrent_jobs that may be admitted, uploading or waiting for a "
          "slot; beyond that a call ends at once with RESOURCE_EXHAUSTED");
ABSL_FLAG(uint64_t, memory_capacity, 0,
          "bytes the admitted jobs may reserve together, uploads their data, running jobs their "
          "estimate (docs/server.md, \"Admission control\"); a call waits until it fits, a job "
          "that never can is "
          "refused. 0 = the container's memory limit (cgroup) minus 128 MiB for the server, else "
          "half the RAM");
ABSL_FLAG(bool, memory_guard, true,
          "end a job in processing with RESOURCE_EXHAUSTED (MEMORY_RESERVATION_EXCEEDED) once the "
          "server's resident memory above its idle baseline exceeds the running jobs' "
          "reservations by a quarter of a 64 MiB margin (docs/server.md, \"Memory guard\"); "
          "off in sanitizer builds, whose own memory is resident");
ABSL_FLAG(uint64_t, test_bytes_per_point, 0,
          "TEST HOOK, not for production: the per-point memory estimate in bytes in place of the "
          "measured 416, so a test can send an ordinary job that takes more than its reservation "
          "(0 = 416)");
ABSL_FLAG(int, threads, 0, "threads of the shared processing arena (0 = hardware concurrency)");
ABSL_FLAG(double, default_budget_seconds, 0,
          "total time budget for jobs that state none (0 = no budget); reported and counted in "
          "scanprep_job_budget_total, never enforced; overrides 'total' in --budget_config");
ABSL_FLAG(std::string, stage_budgets, "",
          "default per-stage budgets, e.g. \"outliers=0.2,smoothing=0.5\" (seconds); override "
          "--budget_config entries; a job's own stage budgets override these");
ABSL_FLAG(std::string, budget_config, "",
          "file of default budgets, one 'stage seconds' per line ('total seconds' for the whole "
          "pipeline, '#' comments)");
ABSL_FLAG(std::string, presets_file, "",
          "file of parameter presets per scanner model, one '[name]' section each with "
          "'parameter = value' lines; validated at startup; jobs name one in options.preset");
ABSL_FLAG(absl::Duration, header_timeout, absl::Seconds(10),
          "a Process call whose header has not arrived this long after it started is cancelled");
ABSL_FLAG(absl::Duration, idle_timeout, absl::Seconds(30),
          "a Process call whose next upload message has not arrived this long after the previous "
          "one, or whose client has not read a response this long after it was written, is "
          "cancelled (time waiting for memory or a slot does not count)");
ABSL_FLAG(double, min_upload_rate, 64 * 1024,
          "bytes per second a Process upload must keep up with from its admission on, after a "
          "first --idle_timeout, judged over a sliding window of twice --idle_timeout; a slower "
          "one is cancelled (0 = no minimum)");
ABSL_FLAG(double, min_download_rate, 64 * 1024,
          "result bytes per second a Process client must read from the download's start, after a "
          "first --idle_timeout, judged over a sliding window of twice --idle_timeout; a slower "
          "one is cancelled (0 = no minimum)");
ABSL_FLAG(absl::Duration, max_connection_age, absl::InfiniteDuration(),
          "a client connection older than this is sent GOAWAY, so the client reconnects and "
          "re-resolves DNS, reaching replicas added since (e.g. 300s behind an autoscaler; "
          "inf = never)");
ABSL_FLAG(absl::Duration, max_connection_age_grace, absl::InfiniteDuration(),
          "how long calls in progress on a connection past --max_connection_age may still run "
          "(at least the longest job's time; inf = until they end)");
ABSL_FLAG(absl::Duration, keepalive_time, absl::Hours(2),
          "idle time after which the server pings a client to check the connection is alive");
ABSL_FLAG(absl::Duration, keepalive_timeout, absl::Seconds(20),
          "how long the server waits for a keepalive ping's answer before closing the connection");
ABSL_FLAG(absl::Duration, grace_period, absl::Seconds(10),
          "on SIGINT/SIGTERM, how long in-flight calls may run before they are cancelled");

namespace scanprep::server {
namespace {

// What scanprep-server starts: the server's options, and what its startup lines report besides
// the ports.
struct Startup {
  ServerOptions options;
  std::string transport;  // how the gRPC port is secured
  MemoryLimits memory;
};

// How the startup and lifecycle lines are written: as the log is (--log_format).
LogFormat console_format = LogFormat::kText;

// One startup or lifecycle line to `out`: as it is in text, a JSON object (its text the message)
// in JSON, so that a collector reading both streams parses every line.
void Say(std::ostream& out, LogLevel level, const std::string& text) {
  out << (console_format == LogFormat::kText
              ? text + "\n"
              : FormatLogLine(console_format, absl::Now(), level, "", {{"message", text}}))
      << std::flush;
}

// Every startup error ends the process alike: one line on stderr and exit status 1.
int Fail(const absl::Status& status) {
  Say(std::cerr, LogLevel::kWarning, absl::StrCat("scanprep-server: ", status.message()));
  return 1;
}

// The error of `value` with the flag it came from before its message, for errors that do not
// name it themselves.
template <typename T>
absl::StatusOr<T> NamingFlag(absl::string_view flag, absl::StatusOr<T> value) {
  if (value.ok()) return value;
  return absl::Status(value.status().code(), absl::StrCat(flag, ": ", value.status().message()));
}

void ParseFlags(int argc, char** argv) {
  absl::FlagsUsageConfig usage;
  usage.version_string = [] { return std::string("scanprep-server " SCANPREP_VERSION "\n"); };
  // --help lists the flags of the file named like the program; ours live in server/main.cc.
  usage.contains_help_flags = [](absl::string_view file) {
    return absl::EndsWith(file, "server/main.cc");
  };
  usage.normalize_filename = [](absl::string_view file) {
    const size_t at = file.rfind("server/main.cc");
    return std::string(at == absl::string_view::npos ? file : file.substr(at));
  };
  absl::SetFlagsUsageConfig(usage);
  absl::SetProgramUsageMessage(
      "scanprep-server (--tls_cert FILE --tls_key FILE [--tls_client_ca FILE] | --plaintext) "
      "[--listen HOST:PORT] [flags]");
  absl::ParseCommandLine(argc, argv);
}

// A job's arrays (4-40 MB each at 1 M points) come and go stage by stage. By default glibc
// raises its mmap threshold to the size of each such block freed, so later ones come from the
// heap and the holes they leave stay resident: a 1 M job's peak RSS was 178-187 MiB against a
// live heap of about 150. A fixed threshold maps every block over 128 KiB on its own and hands
// it back when freed: 159-160 MiB, end to end 1-1.5 % slower (5faaf5c's docs/benchmarks.md).
void UseFixedMmapThreshold() { mallopt(M_MMAP_THRESHOLD, 128 * 1024); }

// Blocks the stop signals in every thread (gRPC's and TBB's threads inherit this mask), so that
// ServeUntilStopped takes them synchronously on one thread, where calling into gRPC is safe.
sigset_t BlockStopSignals() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  return stop_signals;
}

// The config file first, then the flags, each overriding what came before.
absl::StatusOr<TimeBudgetDefaults> TimeBudgetsFromFlags() {
  TimeBudgetDefaults budgets;
  if (const std::string path = absl::GetFlag(FLAGS_budget_config); !path.empty()) {
    SCANPREP_RETURN_IF_ERROR(ReadBudgetConfig(path, budgets));
  }
  SCANPREP_RETURN_IF_ERROR(ParseStageBudgets(absl::GetFlag(FLAGS_stage_budgets), budgets));
  const double total = absl::GetFlag(FLAGS_default_budget_seconds);
  if (!(total >= 0)) return absl::InvalidArgumentError("--default_budget_seconds must be >= 0");
  if (total > 0) budgets.total_seconds = total;
  return budgets;
}

// What a job may send and what it defaults to, but its largest size (the memory limits').
absl::StatusOr<JobLimits> JobLimitsFromFlags(const TimeBudgetDefaults& budgets) {
  JobLimits limits;
  SCANPREP_ASSIGN_OR_RETURN(
      std::vector<Preset> presets,
      NamingFlag("--presets_file", LoadPresets(absl::GetFlag(FLAGS_presets_file))));
  limits.max_plan_cost = absl::GetFlag(FLAGS_max_plan_cost);
  if (!(limits.max_plan_cost >= 0))
    return absl::InvalidArgumentError("--max_plan_cost must be >= 0");
  // A preset no job could run is refused at startup, not at every job that names it.
  for (const Preset& preset : presets) {
    SCANPREP_ASSIGN_OR_RETURN(const PlanCost cost, EstimatePlanCost({.params = preset.params}));
    if (absl::Status s = CheckPlanCost(cost, limits.max_plan_cost); !s.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("--presets_file: preset '", preset.name, "': ", s.message()));
    }
  }
  limits.presets = std::make_shared<const std::vector<Preset>>(std::move(presets));
  limits.max_chunk_points = absl::GetFlag(FLAGS_max_chunk_points);
  limits.max_bytes_per_call = absl::GetFlag(FLAGS_max_bytes_per_call);
  limits.max_message_bytes = absl::GetFlag(FLAGS_max_message_bytes);
  if (limits.max_message_bytes < (1u << 20) || limits.max_message_bytes > (1u << 30)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--max_message_bytes must be within 1 MiB and 1 GiB (got ", limits.max_message_bytes, ")"));
  }
  limits.max_scans_per_job = absl::GetFlag(FLAGS_max_scans_per_job);
  limits.default_budget_seconds = budgets.total_seconds;
  limits.default_stage_budget_seconds = budgets.stage_seconds;
  return limits;
}

// Every flag, read and checked; the first error found ends the startup.
absl::StatusOr<Startup> StartupFromFlags() {
  SCANPREP_ASSIGN_OR_RETURN(const TimeBudgetDefaults budgets, TimeBudgetsFromFlags());
  SCANPREP_ASSIGN_OR_RETURN(const Transport transport,
                            TransportFromFlags({
                                .tls_cert = absl::GetFlag(FLAGS_tls_cert),
                                .tls_key = absl::GetFlag(FLAGS_tls_key),
                                .tls_client_ca = absl::GetFlag(FLAGS_tls_client_ca),
                                .plaintext = absl::GetFlag(FLAGS_plaintext),
                                .reload_interval = absl::GetFlag(FLAGS_tls_reload_interval),
                            }));
  Startup startup;
  startup.transport = transport.description;
  ServerOptions& options = startup.options;
  options.credentials = transport.credentials;
  options.tls = !absl::GetFlag(FLAGS_plaintext);
  SCANPREP_ASSIGN_OR_RETURN(options.limits, JobLimitsFromFlags(budgets));
  SCANPREP_ASSIGN_OR_RETURN(
      options.trusted_proxies,
      NamingFlag("--trusted_proxies", ParseCidrList(absl::GetFlag(FLAGS_trusted_proxies))));
  options.log = &std::cerr;
  options.log_format = console_format;
  options.listen = absl::GetFlag(FLAGS_listen);
  options.metrics_listen = absl::GetFlag(FLAGS_metrics_listen);
  options.max_calls_per_peer = absl::GetFlag(FLAGS_max_calls_per_peer);
  options.max_concurrent_jobs = absl::GetFlag(FLAGS_max_concurrent_jobs);
  options.max_queued_jobs = absl::GetFlag(FLAGS_max_queued_jobs);
  options.threads = absl::GetFlag(FLAGS_threads);
  options.timeouts = {.header = absl::GetFlag(FLAGS_header_timeout),
                      .idle = absl::GetFlag(FLAGS_idle_timeout),
                      .min_upload_rate = absl::GetFlag(FLAGS_min_upload_rate),
                      .min_download_rate = absl::GetFlag(FLAGS_min_download_rate)};
  options.connection = {.max_age = absl::GetFlag(FLAGS_max_connection_age),
                        .max_age_grace = absl::GetFlag(FLAGS_max_connection_age_grace),
                        .keepalive_time = absl::GetFlag(FLAGS_keepalive_time),
                        .keepalive_timeout = absl::GetFlag(FLAGS_keepalive_timeout)};
  SCANPREP_RETURN_IF_ERROR(CheckConnectionOptions(options.connection));
  options.sensor_metrics = {
      .max_sensors = absl::GetFlag(FLAGS_max_sensors),
      .max_sensor_pairs = absl::GetFlag(FLAGS_max_sensor_pairs),
      .sensor_allowlist =
          absl::StrSplit(absl::GetFlag(FLAGS_sensor_allowlist), ',', absl::SkipEmpty()),
      .tolerance_mm = absl::GetFlag(FLAGS_sensor_tolerance_mm),
      .rotation_tolerance_deg = absl::GetFlag(FLAGS_sensor_rotation_tolerance_deg)};
  SCANPREP_RETURN_IF_ERROR(CheckSensorMetricsOptions(options.sensor_metrics));
  // Before the limits are resolved: the hook changes the estimates they are made of.
  SetBytesPerPointForTesting(absl::GetFlag(FLAGS_test_bytes_per_point));
  SCANPREP_ASSIGN_OR_RETURN(startup.memory,
                            ResolveMemoryLimits(absl::GetFlag(FLAGS_memory_capacity),
                                                absl::GetFlag(FLAGS_max_points_per_job)));
  options.memory_capacity_bytes = startup.memory.capacity.bytes;
  options.memory_guard.enabled = absl::GetFlag(FLAGS_memory_guard);
  options.limits.max_points_per_job = startup.memory.max_points_per_job;
  return startup;
}

// The actual ports, for callers that asked for port 0, and the memory limits in force.
void PrintStartup(const ScanPrepServer& server, const Startup& startup) {
  Say(std::cout, LogLevel::kInfo,
      absl::StrCat("scanprep-server " SCANPREP_VERSION " listening on port ", server.port(), " (",
                   startup.transport, ")"));
  Say(std::cout, LogLevel::kInfo,
      absl::StrCat("scanprep-server: memory capacity ", startup.memory.capacity.bytes, " bytes (",
                   startup.memory.capacity.source, "), ", BaseBytesPerPoint(),
                   " B/point estimated, max_points_per_job ", startup.memory.max_points_per_job));
  if (server.metrics_port() != 0) {
    Say(std::cout, LogLevel::kInfo,
        absl::StrCat("scanprep-server: metrics on port ", server.metrics_port()));
  }
}

// Jobs are cancelled at the end of the grace period and stop within 0.2 s; should one not, the
// process still ends within a second of it rather than when the job is done. Should the exit
// itself hang (a library's threads at teardown), it ends 5 s after the calls did: the watchdog
// outlives main(), and so does the notification it waits on, which the caller gives once the
// calls ended.
absl::Notification* StartExitWatchdog(absl::Duration grace) {
  auto* calls_ended = new absl::Notification;
  std::thread([grace, calls_ended] {
    if (!calls_ended->WaitForNotificationWithTimeout(grace + absl::Milliseconds(900))) {
      Say(std::cerr, LogLevel::kWarning,
          "scanprep-server: calls still running 0.9 s after the grace period; exiting");
      std::_Exit(1);
    }
    absl::SleepFor(absl::Seconds(5));
    Say(std::cerr, LogLevel::kWarning,
        "scanprep-server: still not exited 5 s after the calls ended; exiting");
    std::_Exit(1);
  }).detach();
  return calls_ended;
}

// Serves until one of `stop_signals` arrives, then shuts down within --grace_period.
void ServeUntilStopped(ScanPrepServer& server, const sigset_t& stop_signals) {
  std::thread stopper([&] {
    int signal = 0;
    sigwait(&stop_signals, &signal);
    Say(std::cout, LogLevel::kInfo,
        absl::StrCat("scanprep-server: signal ", signal, ", shutting down"));
    const absl::Duration grace = absl::GetFlag(FLAGS_grace_period);
    absl::Notification* calls_ended = StartExitWatchdog(grace);
    server.Shutdown(grace);
    calls_ended->Notify();
  });
  server.Wait();
  stopper.join();
}

// What is left once the server is gone is gRPC's library teardown (grpc_shutdown, when the
// credentials go), which in Debian's gRPC 1.51 can wait in an executor thread's poll after a
// large job (measured here: 10 s after a 4 M-point job, none after small ones). Nothing of the
// service is left to tear down, so the process ends here, after the leak check a sanitizer build
// runs at exit.
[[noreturn]] void ExitWithoutLibraryTeardown() {
  std::cout.flush();
  std::cerr.flush();
#ifdef SCANPREP_LEAK_CHECK_AT_EXIT
  __lsan_do_leak_check();
#endif
  std::_Exit(0);
}

}  // namespace
}  // namespace scanprep::server

int main(int argc, char** argv) {
  namespace server = scanprep::server;
  server::ParseFlags(argc, argv);
  if (auto format = server::ParseLogFormat(absl::GetFlag(FLAGS_log_format)); !format.ok()) {
    return server::Fail(format.status());
  } else {
    server::console_format = *format;
  }
  server::UseFixedMmapThreshold();
  const sigset_t stop_signals = server::BlockStopSignals();
  const absl::StatusOr<server::Startup> startup = server::StartupFromFlags();
  if (!startup.ok()) return server::Fail(startup.status());
  auto running = server::ScanPrepServer::Start(startup->options);
  if (!running.ok()) return server::Fail(running.status());
  server::PrintStartup(**running, *startup);
  server::ServeUntilStopped(**running, stop_signals);
  running->reset();  // the service's own threads, jobs and metrics endpoint end here
  server::ExitWithoutLibraryTeardown();
}
