// SPDX-License-Identifier: Apache-2.0
#include "server/metrics/registry.h"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

namespace scanprep::metrics {
namespace {

std::string FormatValue(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  char buf[32];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, end);
}

// HELP text escapes backslash and newline; label values also escape the double quote.
std::string Escape(const std::string& text, bool quote) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    if (c == '\\')
      out += "\\\\";
    else if (c == '\n')
      out += "\\n";
    else if (c == '"' && quote)
      out += "\\\"";
    else
      out += c;
  }
  return out;
}

void Header(std::string& out, const std::string& name, const std::string& help,
            const std::string& type) {
  out += "# HELP " + name + " " + Escape(help, false) + "\n";
  out += "# TYPE " + name + " " + type + "\n";
}

// {a="x",b="y"} plus an optional extra label (the histogram's le); empty when there are none.
std::string LabelSet(const std::vector<std::string>& names, const std::vector<std::string>& values,
                     const std::string& extra_name = {}, const std::string& extra_value = {}) {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) {
    out += (out.empty() ? "{" : ",") + names[i] + "=\"" + Escape(values[i], true) + "\"";
  }
  if (!extra_name.empty())
    out += (out.empty() ? "{" : ",") + extra_name + "=\"" + extra_value + "\"";
  return out.empty() ? out : out + "}";
}

template <typename Metric>
void SimpleFamily(std::string& out, const Family<Metric>& family, const char* type) {
  Header(out, family.name(), family.help(), type);
  family.ForEach([&](const std::vector<std::string>& values, const Metric& metric) {
    out += family.name() + LabelSet(family.label_names(), values) + " " +
           FormatValue(metric.value()) + "\n";
  });
}

}  // namespace

Histogram::Histogram(std::vector<double> bounds)
    : bounds_(std::move(bounds)), counts_(new std::atomic<uint64_t>[bounds_.size() + 1]) {
  for (size_t i = 0; i <= bounds_.size(); ++i) counts_[i].store(0);
}

void Histogram::Observe(double value) {
  const size_t bucket = std::lower_bound(bounds_.begin(), bounds_.end(), value) - bounds_.begin();
  counts_[bucket].fetch_add(1, std::memory_order_relaxed);
  sum_.fetch_add(value, std::memory_order_relaxed);
}

Histogram::Snapshot Histogram::snapshot() const {
  Snapshot s;
  uint64_t running = 0;
  for (size_t i = 0; i <= bounds_.size(); ++i) {
    running += counts_[i].load(std::memory_order_relaxed);
    s.cumulative.push_back(running);
  }
  s.count = running;
  s.sum = sum_.load(std::memory_order_relaxed);
  return s;
}

std::vector<double> ExponentialBuckets(double start, double factor, int count) {
  std::vector<double> bounds;
  for (int i = 0; i < count; ++i, start *= factor) bounds.push_back(start);
  return bounds;
}

Family<Counter>& Registry::AddCounter(std::string name, std::string help,
                                      std::vector<std::string> label_names) {
  std::lock_guard lock(mu_);
  counters_.push_back(
      std::make_unique<Family<Counter>>(std::move(name), std::move(help), std::move(label_names),
                                        [] { return std::make_unique<Counter>(); }));
  return *counters_.back();
}

Family<Gauge>& Registry::AddGauge(std::string name, std::string help,
                                  std::vector<std::string> label_names) {
  std::lock_guard lock(mu_);
  gauges_.push_back(std::make_unique<Family<Gauge>>(std::move(name), std::move(help),
                                                    std::move(label_names),
                                                    [] { return std::make_unique<Gauge>(); }));
  return *gauges_.back();
}

Family<Histogram>& Registry::AddHistogram(std::string name, std::string help,
                                          std::vector<double> bounds,
                                          std::vector<std::string> label_names) {
  std::lock_guard lock(mu_);
  histograms_.push_back(std::make_unique<Family<Histogram>>(
      std::move(name), std::move(help), std::move(label_names),
      [bounds = std::move(bounds)] { return std::make_unique<Histogram>(bounds); }));
  return *histograms_.back();
}

void Registry::AddCallback(std::string name, std::string help, std::string type,
                           std::function<double()> read) {
  std::lock_guard lock(mu_);
  callbacks_.push_back({std::move(name), std::move(help), std::move(type), std::move(read)});
}

std::string Registry::Serialize() const {
  std::lock_guard lock(mu_);
  std::string out;
  for (const auto& family : counters_) SimpleFamily(out, *family, "counter");
  for (const auto& family : gauges_) SimpleFamily(out, *family, "gauge");
  for (const auto& family : histograms_) {
    Header(out, family->name(), family->help(), "histogram");
    const auto& names = family->label_names();
    family->ForEach([&](const std::vector<std::string>& values, const Histogram& h) {
      const Histogram::Snapshot s = h.snapshot();
      for (size_t i = 0; i < s.cumulative.size(); ++i) {
        const std::string le = i < h.bounds().size() ? FormatValue(h.bounds()[i]) : "+Inf";
        out += family->name() + "_bucket" + LabelSet(names, values, "le", le) + " " +
               FormatValue(static_cast<double>(s.cumulative[i])) + "\n";
      }
      out += family->name() + "_sum" + LabelSet(names, values) + " " + FormatValue(s.sum) + "\n";
      out += family->name() + "_count" + LabelSet(names, values) + " " +
             FormatValue(static_cast<double>(s.count)) + "\n";
    });
  }
  for (const Callback& cb : callbacks_) {
    Header(out, cb.name, cb.help, cb.type);
    out += cb.name + " " + FormatValue(cb.read()) + "\n";
  }
  return out;
}

namespace {

// Fields of /proc/self/stat after the command name: utime is field 14, stime 15, starttime 22.
std::vector<std::string> ProcStatFields() {
  std::ifstream in("/proc/self/stat");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> fields;
  const size_t close = line.rfind(')');
  if (close == std::string::npos) return fields;
  std::istringstream rest(line.substr(close + 2));
  for (std::string f; rest >> f;) fields.push_back(f);
  return fields;  // fields[0] is field 3 (state)
}

double BootTimeSeconds() {
  std::ifstream in("/proc/stat");
  for (std::string key; in >> key;) {
    if (key == "btime") {
      double t = 0;
      in >> t;
      return t;
    }
  }
  return 0;
}

}  // namespace

void AddProcessMetrics(Registry& registry) {
  const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
  registry.AddCallback("process_cpu_seconds_total",
                       "Total user and system CPU time spent in seconds.", "counter", [ticks] {
                         const auto f = ProcStatFields();
                         return f.size() > 12 ? (std::stod(f[11]) + std::stod(f[12])) / ticks : 0.0;
                       });
  registry.AddCallback("process_resident_memory_bytes", "Resident memory size in bytes.", "gauge",
                       [] {
                         const auto f = ProcStatFields();
                         return f.size() > 21 ? std::stod(f[21]) * sysconf(_SC_PAGESIZE) : 0.0;
                       });
  registry.AddCallback("process_open_fds", "Number of open file descriptors.", "gauge", [] {
    std::error_code ec;
    double n = 0;
    for (auto it = std::filesystem::directory_iterator("/proc/self/fd", ec);
         !ec && it != std::filesystem::directory_iterator(); it.increment(ec)) {
      ++n;
    }
    return n;
  });
  const auto f = ProcStatFields();
  const double start = f.size() > 19 ? BootTimeSeconds() + std::stod(f[19]) / ticks : 0.0;
  registry.AddCallback("process_start_time_seconds",
                       "Start time of the process since unix epoch in seconds.", "gauge",
                       [start] { return start; });
}

}  // namespace scanprep::metrics
