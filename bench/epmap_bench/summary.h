#pragma once
// What every epmap-bench command summarises its samples with, and how it writes numbers and
// strings into its JSON. One definition, so that "median" means the same in every report.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

namespace epmap::bench {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Wall time since t0, ms.
inline double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The median (the mean of the middle two for an even count); NaN without samples.
inline double Median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

inline double Mean(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

inline double Max(const std::vector<double>& v) {
  return v.empty() ? kNaN : *std::max_element(v.begin(), v.end());
}

// The sample at rank floor(q * n) of the sorted samples (q = 1: the largest); NaN without
// samples.
inline double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double rank = std::max(0.0, q * static_cast<double>(v.size()));
  return v[std::min(v.size() - 1, static_cast<size_t>(rank))];
}

// A JSON number with `digits` significant digits (printf %g); null when not finite.
inline std::string JsonNumber(double v, int digits) {
  if (!std::isfinite(v)) return "null";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

// A number with `decimals` digits after the point (printf %f), for JSON and SVG; null when not
// finite.
inline std::string FormatFixed(double v, int decimals) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// {"median":..,"max":..,"n":..} of the samples (4 significant digits); null without samples.
inline std::string JsonMedianMax(const std::vector<double>& v) {
  if (v.empty()) return "null";
  return "{\"median\":" + JsonNumber(Median(v), 4) + ",\"max\":" + JsonNumber(Max(v), 4) +
         ",\"n\":" + std::to_string(v.size()) + "}";
}

// A JSON string: quotes and backslashes escaped (the benchmarks' strings are paths and names).
inline std::string JsonQuote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out.push_back('\\');
    out.push_back(c);
  }
  return out + "\"";
}

}  // namespace epmap::bench
