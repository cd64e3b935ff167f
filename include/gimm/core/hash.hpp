#pragma once
/// One stable hash: 64-bit FNV-1a (offset basis 14695981039346656037, prime 1099511628211), the
/// same on every platform and compiler, for seeding per-item random streams from names.
#include <cstdint>
#include <string>

namespace gimm {

inline std::uint64_t stable_hash(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

}  // namespace gimm
