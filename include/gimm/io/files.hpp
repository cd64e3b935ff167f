#pragma once
/// Whole-file and byte-range reads, and atomic writes.
///
/// write_file_atomic writes to "<path>.tmp.<host>.<pid>" in the same directory, flushes, and
/// renames over `path`, so a reader (or a run killed at any moment) sees either the old file or
/// the complete new one, never a half-written file. The host name keeps the temporaries of
/// processes on different machines apart (every Kubernetes pod's process may be PID 1). Errors
/// name the file and the OS reason.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <vector>

#include "gimm/core/error.hpp"

namespace gimm {

/// The whole file in one read (an istreambuf_iterator copy runs at ~300 MB/s; this at memory
/// speed, which is most of the load time of a CT volume).
inline std::vector<unsigned char> read_file_bytes(const std::filesystem::path& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  GIMM_CHECK_AS(IoError, f != nullptr,
                "cannot open '" << path.string() << "': " << std::strerror(errno));
  std::vector<unsigned char> bytes;
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec) bytes.resize(static_cast<std::size_t>(size));
  std::size_t got = bytes.empty() ? 0 : std::fread(bytes.data(), 1, bytes.size(), f);
  // Files whose size is not known up front (pipes, /proc) or that grew: read on in chunks.
  unsigned char chunk[1 << 16];
  for (std::size_t n; (n = std::fread(chunk, 1, sizeof chunk, f)) > 0;) {
    bytes.resize(got);
    bytes.insert(bytes.end(), chunk, chunk + n);
    got = bytes.size();
  }
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  GIMM_CHECK_AS(IoError, !failed, "error reading '" << path.string() << "'");
  bytes.resize(got);
  return bytes;
}

/// The size of a file; errors name it and the OS reason.
inline std::uint64_t file_size_of(const std::filesystem::path& path) {
  std::error_code ec;
  GIMM_CHECK_AS(IoError, !std::filesystem::is_directory(path, ec),
                "'" << path.string() << "' is a folder, not a file");
  const auto size = std::filesystem::file_size(path, ec);
  GIMM_CHECK_AS(IoError, !ec, "cannot open '" << path.string() << "': " << ec.message());
  return static_cast<std::uint64_t>(size);
}

/// `size` bytes from byte `offset` of the file into `dst` (a header read without the voxels, or
/// the voxels read straight into a volume). A short read is an error with both counts.
inline void read_file_range(const std::filesystem::path& path, std::uint64_t offset, void* dst,
                            std::size_t size) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  GIMM_CHECK_AS(IoError, f != nullptr,
                "cannot open '" << path.string() << "': " << std::strerror(errno));
  GIMM_CHECK_AS(IoError, ::fseeko(f.get(), static_cast<off_t>(offset), SEEK_SET) == 0,
                "cannot seek to byte " << offset << " of '" << path.string()
                                       << "': " << std::strerror(errno));
  const std::size_t got = size ? std::fread(dst, 1, size, f.get()) : 0;
  GIMM_CHECK_AS(IoError, got == size,
                "error reading '" << path.string() << "': expected " << size << " bytes at byte "
                                  << offset << ", got " << got);
}

inline std::vector<unsigned char> read_file_range(const std::filesystem::path& path,
                                                  std::uint64_t offset, std::size_t size) {
  std::vector<unsigned char> bytes(size);
  read_file_range(path, offset, bytes.data(), size);
  return bytes;
}

/// The first min(limit, file size) bytes of a file: a text header without the data after it.
inline std::vector<unsigned char> read_file_prefix(const std::filesystem::path& path,
                                                   std::size_t limit) {
  const std::uint64_t size = file_size_of(path);
  return read_file_range(path, 0, static_cast<std::size_t>(std::min<std::uint64_t>(size, limit)));
}

/// "<host>.<pid>": names this process's temporary files apart from any other writer's.
inline std::string process_tag() {
  char host[256] = {0};
  if (::gethostname(host, sizeof host - 1) != 0 || host[0] == 0) std::strcpy(host, "host");
  for (char* c = host; *c; ++c)
    if (*c == '/') *c = '_';
  return std::string(host) + "." + std::to_string(static_cast<long>(::getpid()));
}

inline void write_file_atomic(const std::filesystem::path& path, const void* data,
                              std::size_t size) {
  const std::filesystem::path tmp = path.string() + ".tmp." + process_tag();
  {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    GIMM_CHECK_AS(IoError, f != nullptr,
                  "cannot write '" << path.string() << "': " << std::strerror(errno));
    const bool ok = std::fwrite(data, 1, size, f) == size && std::fflush(f) == 0;
    const int saved_errno = errno;
    const bool closed = std::fclose(f) == 0;
    if (!ok || !closed) {
      std::remove(tmp.c_str());
      GIMM_FAIL("error writing '" << path.string() << "': " << std::strerror(saved_errno));
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    GIMM_FAIL("cannot move '" << tmp.string() << "' to '" << path.string()
                              << "': " << ec.message());
  }
}

inline void write_file_atomic(const std::filesystem::path& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

/// The outputs of one command, all there or none: runs `write`, which writes `outputs` (each
/// atomically); if it throws (a later file failed, e.g. on a full disk), every one of `outputs`
/// is removed and the error rethrown. Empty paths (outputs not asked for) are skipped.
template <class Write>
void write_all_or_nothing(const std::vector<std::filesystem::path>& outputs, Write&& write) {
  try {
    write();
  } catch (...) {
    std::error_code ignored;
    for (const auto& path : outputs)
      if (!path.empty()) std::filesystem::remove(path, ignored);
    throw;
  }
}

/// Parses a JSON file; errors name the file and the parse position.
inline nlohmann::json read_json_file(const std::filesystem::path& path) {
  const auto bytes = read_file_bytes(path);
  try {
    return nlohmann::json::parse(bytes.begin(), bytes.end());
  } catch (const nlohmann::json::exception& e) {  // parse errors, and numbers like 1e999
    throw FormatError("gimm: '" + path.string() + "' is not valid JSON: " + e.what());
  }
}

/// Writes JSON (indented by `indent`, -1 for compact) atomically, with a final newline.
inline void write_json_file(const std::filesystem::path& path, const nlohmann::json& j,
                            int indent = 1) {
  write_file_atomic(path, j.dump(indent) + "\n");
}

}  // namespace gimm
