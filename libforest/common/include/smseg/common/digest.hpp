#pragma once
// A short fingerprint of bytes: FNV-1a, 64 bits, as 16 hex digits. Not for security; for telling
// whether two files or records are the same (a work folder's sequence, a forest part's training data,
// an experiment's cache key).
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace smseg {

inline std::string fnv1a64_hex(std::string_view bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (const unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

}  // namespace smseg
