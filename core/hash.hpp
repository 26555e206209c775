// FNV-1a 64-bit hashes as 16 hex digits: of a byte string, and of a file's bytes (case and table fingerprints).
#pragma once
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>

namespace flapstab {

inline std::uint64_t fnv1a64_update(std::uint64_t h, unsigned char byte) { return (h ^ byte) * 1099511628211ull; }
inline constexpr std::uint64_t fnv1a64_basis = 1469598103934665603ull;

inline std::string fnv1a64_hex_of(std::uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

inline std::string fnv1a64_hex(std::string_view bytes) {
  std::uint64_t h = fnv1a64_basis;
  for (unsigned char c : bytes) h = fnv1a64_update(h, c);
  return fnv1a64_hex_of(h);
}

// A missing or unreadable file hashes as the empty string.
inline std::string fnv1a64_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint64_t h = fnv1a64_basis;
  for (std::istreambuf_iterator<char> it(in), end; it != end; ++it) h = fnv1a64_update(h, static_cast<unsigned char>(*it));
  return fnv1a64_hex_of(h);
}

}  // namespace flapstab
