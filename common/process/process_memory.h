#pragma once
// A process's resident memory from /proc/<pid>/status (Linux): now (VmRSS) and the most it has
// held (VmHWM), in MB. For GetStatus (an operator watching epmapd on a small computer) and the
// benchmarks that report epmapd's peak.

#include <fstream>
#include <string>

namespace epmap::process {

struct ProcessMemory {
  double resident_mb = -1;  // -1: not readable (no /proc, process gone)
  double peak_resident_mb = -1;
};

// pid "self" is the calling process.
inline ProcessMemory ReadProcessMemory(const std::string& pid = "self") {
  ProcessMemory m;
  std::ifstream in("/proc/" + pid + "/status");
  std::string line;
  // Lines read "VmRSS:	  123456 kB".
  const auto kb = [&](const char* key, double* mb) {
    const std::string k(key);
    if (line.rfind(k, 0) == 0) *mb = std::stod(line.substr(k.size())) / 1024.0;
  };
  while (std::getline(in, line)) {
    kb("VmRSS:", &m.resident_mb);
    kb("VmHWM:", &m.peak_resident_mb);
  }
  return m;
}

}  // namespace epmap::process
