#pragma once
// The benchmarks' last lines: one JSON object each, for scripts/bench and the tables in
// docs/performance.md and docs/soak.md, written by nlohmann/json (keys in the order given).

#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

namespace occmap::bench {

inline void printJsonLine(const nlohmann::ordered_json& object) {
  std::printf("%s\n", object.dump().c_str());
}

// A measurement to `decimals` places, as the line for people shows it: the digits past them are
// noise. (n / 10^d is the double nearest that decimal, so JSON shows exactly those places.)
inline double rounded(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

}  // namespace occmap::bench
