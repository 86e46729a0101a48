// SPDX-License-Identifier: Apache-2.0
#include "client/load_report.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace scanprep::client {
namespace {

constexpr char kResourceExhausted[] = "RESOURCE_EXHAUSTED";

std::string Mode(const LoadOptions& options) {
  if (options.rate <= 0) return "closed";
  return options.arrivals == Arrivals::kFixed ? "fixed" : "poisson";
}

// The target comes from the command line, so it is quoted properly rather than trusted.
std::string JsonQuote(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      absl::StrAppend(&out, "\\", std::string(1, c));
    } else if (static_cast<unsigned char>(c) < 0x20) {
      absl::StrAppend(&out, absl::StrFormat("\\u%04x", static_cast<int>(c)));
    } else {
      out += c;
    }
  }
  return out + "\"";
}

uint64_t ResourceExhausted(const LoadResult& result) {
  auto it = result.errors.find(kResourceExhausted);
  return it == result.errors.end() ? 0 : it->second.count;
}

}  // namespace

LoadReport MakeLoadReport(std::string target, const LoadOptions& options, const Job& job,
                          LoadResult result, std::optional<double> budget_flag) {
  LoadReport r{.target = std::move(target), .options = options};
  r.points_per_job = job.points.size();
  r.scans_per_job = job.header.scans_size();
  r.latency = Summarize(result.latencies);
  if (result.elapsed_seconds > 0) {
    r.jobs_per_second = double(result.jobs_ok) / result.elapsed_seconds;
    r.points_per_second = r.jobs_per_second * double(r.points_per_job);
  }
  if (budget_flag) {
    r.budget_seconds = budget_flag;
  } else if (result.report_budget_seconds > 0) {
    r.budget_seconds = result.report_budget_seconds;
  }
  if (r.budget_seconds && r.latency.p99 > *r.budget_seconds) {
    r.failures.push_back(absl::StrFormat("latency p99 %.3f s exceeds the budget of %g s",
                                         r.latency.p99, *r.budget_seconds));
  }
  if (const uint64_t errors = result.error_count(); errors > 0) {
    r.failures.push_back(absl::StrCat(errors, " calls failed"));
  }
  if (result.jobs_ok == 0) r.failures.push_back("no call succeeded");
  r.result = std::move(result);
  return r;
}

void PrintLoadReport(std::ostream& out, const LoadReport& r) {
  const LoadOptions& o = r.options;
  const LoadResult& res = r.result;
  out << absl::StrFormat("load: %s, %d workers, %s loop", r.target, o.concurrency,
                         o.rate > 0 ? "open" : "closed");
  if (o.rate > 0) out << absl::StrFormat(" at %g jobs/s (%s arrivals)", o.rate, Mode(o));
  out << absl::StrFormat(", %g s (ran %.1f s)\n", absl::ToDoubleSeconds(o.duration),
                         res.elapsed_seconds)
      << absl::StrFormat("job: %d points in %d scan%s\n", r.points_per_job, r.scans_per_job,
                         r.scans_per_job == 1 ? "" : "s")
      << absl::StrFormat("throughput: %d jobs ok, %.2f jobs/s, %.0f points/s\n", res.jobs_ok,
                         r.jobs_per_second, r.points_per_second)
      << absl::StrFormat("latency (s): p50 %.3f  p90 %.3f  p99 %.3f  max %.3f  (mean %.3f)\n",
                         r.latency.p50, r.latency.p90, r.latency.p99, r.latency.max, r.latency.mean)
      << "budget: "
      << (r.budget_seconds ? absl::StrFormat("%g s", *r.budget_seconds) : std::string("none"))
      << absl::StrFormat(", %d jobs missed it on the server (report.budget_met false)\n",
                         res.budget_misses);
  if (o.abort_uploads > 0) {
    out << absl::StrFormat("aborted uploads: %d (cancelled mid-upload, as asked)\n", res.aborted);
  }
  if (o.rate > 0) {
    out << absl::StrFormat("late starts: %d (all %d workers busy at the scheduled time)\n",
                           res.late_starts, o.concurrency);
  }
  out << absl::StrFormat("retries: %d (attempts that ended UNAVAILABLE, sent again)\n", res.retries)
      << absl::StrFormat(
             "retried refusals: %d (refused with RetryInfo, sent again after its "
             "delay%s)\n",
             res.retried_refusals, o.retry ? "" : "; off: --retry=false")
      << absl::StrFormat("errors: %d (%d RESOURCE_EXHAUSTED)\n", res.error_count(),
                         ResourceExhausted(res));
  for (const auto& [code, tally] : res.errors) {
    out << absl::StrFormat("  %s: %d, e.g. \"%s\"\n", code, tally.count, tally.example);
  }
  out << (r.failures.empty() ? "PASS" : "FAIL: " + absl::StrJoin(r.failures, "; ")) << "\n";
}

std::string LoadReportJson(const LoadReport& r) {
  const LoadOptions& o = r.options;
  const LoadResult& res = r.result;
  std::vector<std::string> codes;
  for (const auto& [code, tally] : res.errors) {
    codes.push_back(absl::StrFormat("\"%s\": %d", code, tally.count));
  }
  return absl::StrCat(
      "{\n",
      absl::StrFormat("  \"target\": %s,\n  \"mode\": \"%s\",\n  \"concurrency\": %d,\n",
                      JsonQuote(r.target), Mode(o), o.concurrency),
      absl::StrFormat("  \"rate\": %g,\n  \"duration_s\": %g,\n  \"elapsed_s\": %.6f,\n", o.rate,
                      absl::ToDoubleSeconds(o.duration), res.elapsed_seconds),
      absl::StrFormat("  \"scans_per_job\": %d,\n  \"points_per_job\": %d,\n", r.scans_per_job,
                      r.points_per_job),
      absl::StrFormat("  \"jobs\": %d,\n  \"jobs_per_s\": %.6f,\n  \"points_per_s\": %.3f,\n",
                      res.jobs_ok, r.jobs_per_second, r.points_per_second),
      absl::StrFormat("  \"latency_s\": {\"mean\": %.6f, \"p50\": %.6f, \"p90\": %.6f, "
                      "\"p99\": %.6f, \"max\": %.6f},\n",
                      r.latency.mean, r.latency.p50, r.latency.p90, r.latency.p99, r.latency.max),
      absl::StrFormat("  \"errors\": %d,\n  \"resource_exhausted\": %d,\n", res.error_count(),
                      ResourceExhausted(res)),
      "  \"errors_by_code\": {", absl::StrJoin(codes, ", "), "},\n", "  \"budget_s\": ",
      r.budget_seconds ? absl::StrFormat("%g", *r.budget_seconds) : std::string("null"), ",\n",
      absl::StrFormat("  \"budget_misses\": %d,\n  \"late_starts\": %d,\n", res.budget_misses,
                      res.late_starts),
      absl::StrFormat("  \"aborted_uploads\": %d,\n  \"retries\": %d,\n", res.aborted, res.retries),
      absl::StrFormat("  \"retried_refusals\": %d,\n", res.retried_refusals),
      absl::StrFormat("  \"passed\": %s\n}\n", r.failures.empty() ? "true" : "false"));
}

}  // namespace scanprep::client
