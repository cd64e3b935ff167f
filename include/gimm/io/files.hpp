#pragma once
/// Whole-file and byte-range reads, atomic writes, and outputs that are all there or none.
///
/// write_file_atomic writes to "<path>.tmp.<host>.<pid>" in the same directory, flushes, and
/// renames over `path`, so a reader (or a run killed at any moment) sees either the old file or
/// the complete new one, never a half-written file. The host name keeps the temporaries of
/// processes on different machines apart (every Kubernetes pod's process may be PID 1). Errors
/// name the file and the OS reason, as WriteError.
///
/// The outputs of one command are all or nothing, on a full disk too: StagedFiles (a few named
/// files) and StagedFolder (a folder of them) write everything to temporaries first and rename
/// it into place at the end. A full disk fails a write before anything is renamed, and the
/// temporaries (and any folder made for them) are removed: what was at the output paths before
/// is left as it was. The renames themselves are one at a time: one failing after others (no
/// room for a directory entry, a folder in the way) leaves old and new outputs mixed.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/huge_pages.hpp"

namespace gimm {

/// The whole file in one read (an istreambuf_iterator copy runs at ~300 MB/s; this at memory
/// speed, which is most of the load time of a CT volume).
inline std::vector<unsigned char> read_file_bytes(const std::filesystem::path& path) {
  // fopen opens a folder on Linux and only the read fails ("error reading"): say what it is.
  GIMM_CHECK_AS(IoError, !std::filesystem::is_directory(path),
                "'" << path.string() << "' is a folder, not a file");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  GIMM_CHECK_AS(IoError, f != nullptr,
                "cannot open '" << path.string() << "': " << std::strerror(errno));
  std::vector<unsigned char> bytes;
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec) resize_huge(bytes, static_cast<std::size_t>(size));
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

/// "<path>.tmp.<host>.<pid>": this process's temporary for `path`, beside it (same folder, so
/// same filesystem: renaming it over `path` is atomic). temporary_suffix() is what it appends.
/// What marks a name as a temporary or staging name of any process: "<name>.tmp.<host>.<pid>".
inline constexpr const char* kTemporaryMark = ".tmp.";

inline std::string temporary_suffix() {
  return kTemporaryMark + process_tag();
}

/// True for a temporary file or staging folder name (of this process or another).
inline bool is_temporary_name(const std::string& name) {
  return name.find(kTemporaryMark) != std::string::npos;
}

inline std::filesystem::path temporary_path(const std::filesystem::path& path) {
  return path.string() + temporary_suffix();
}

/// Writes `size` bytes to `tmp`, flushed and closed. On failure removes `tmp` and throws
/// WriteError naming `path` (the file the bytes are for) and the OS reason.
inline void write_whole_file(const std::filesystem::path& tmp, const std::filesystem::path& path,
                             const void* data, std::size_t size) {
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  GIMM_CHECK_AS(WriteError, f != nullptr,
                "cannot write '" << path.string() << "': " << std::strerror(errno));
  const bool ok = std::fwrite(data, 1, size, f) == size && std::fflush(f) == 0;
  const int saved_errno = errno;
  const bool closed = std::fclose(f) == 0;
  const int close_errno = errno;  // before std::remove, which may set errno
  if (ok && closed) return;
  std::remove(tmp.c_str());
  GIMM_CHECK_AS(
      WriteError, false,
      "error writing '" << path.string() << "': " << std::strerror(ok ? close_errno : saved_errno));
}

/// Renames `tmp` (a file or a folder) to `path`; on failure removes `tmp` and throws WriteError
/// naming both and the OS reason.
inline void move_into_place(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (!ec) return;
  std::error_code ignored;
  std::filesystem::remove_all(tmp, ignored);
  GIMM_CHECK_AS(
      WriteError, false,
      "cannot move '" << tmp.string() << "' to '" << path.string() << "': " << ec.message());
}

inline void write_file_atomic(const std::filesystem::path& path, const void* data,
                              std::size_t size) {
  const std::filesystem::path tmp = temporary_path(path);
  write_whole_file(tmp, path, data, size);
  move_into_place(tmp, path);
}

inline void write_file_atomic(const std::filesystem::path& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

/// Makes `dir` and its missing parents; WriteError naming it and the OS reason on failure (a
/// folder needs space too).
/// A path given on a command line or to a job, with the name it was given under ("--out").
struct NamedPath {
  std::string name;
  std::filesystem::path path;
};

/// The path with symbolic links, "." and ".." resolved as far as it exists (weakly canonical,
/// absolute): two spellings of one file compare equal.
inline std::filesystem::path resolved_path(const std::filesystem::path& p) {
  std::error_code ec;
  std::filesystem::path r = std::filesystem::weakly_canonical(std::filesystem::absolute(p), ec);
  return ec ? std::filesystem::absolute(p).lexically_normal() : r;
}

/// Whether `inner` is `outer` or lies below it (resolved paths).
inline bool path_is_within(const std::filesystem::path& inner, const std::filesystem::path& outer) {
  const std::filesystem::path i = resolved_path(inner), o = resolved_path(outer);
  auto a = i.begin(), b = o.begin();
  for (; b != o.end() && !b->empty(); ++a, ++b)
    if (a == i.end() || *a != *b) return false;
  return true;
}

/// Refuses a run that would write over what it reads: an output that is (or resolves to, or is
/// a hard link of) one of the inputs, and, with `folders_contain`, an input inside an output
/// folder (a dataset written over its own source volumes); and two outputs that are one file
/// (the second would replace the first). Empty paths are not given ones.
inline void check_outputs_not_inputs(const std::vector<NamedPath>& outputs,
                                     const std::vector<NamedPath>& inputs,
                                     bool folders_contain = false) {
  const auto same_file = [](const std::filesystem::path& a, const std::filesystem::path& b) {
    std::error_code ec;
    return resolved_path(a) == resolved_path(b) || std::filesystem::equivalent(a, b, ec);
  };
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const auto& out = outputs[i];
    if (out.path.empty()) continue;
    for (std::size_t j = i + 1; j < outputs.size(); ++j)
      GIMM_CHECK(outputs[j].path.empty() || !same_file(out.path, outputs[j].path),
                 out.name << " " << out.path.string() << " and " << outputs[j].name << " "
                          << outputs[j].path.string()
                          << " are one file: one output would replace the other; give each its "
                             "own path");
    for (const auto& in : inputs) {
      if (in.path.empty()) continue;
      const bool same = same_file(out.path, in.path);
      GIMM_CHECK(!same, out.name << " " << out.path.string() << " is the input " << in.name << " "
                                 << in.path.string()
                                 << ": the run would overwrite what it reads; write elsewhere");
      GIMM_CHECK(!folders_contain || !path_is_within(in.path, out.path),
                 in.name << " " << in.path.string() << " lies inside the output " << out.name << " "
                         << out.path.string()
                         << ": the run would write over its own input; write elsewhere");
    }
  }
}

inline void create_folders(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  GIMM_CHECK_AS(WriteError, !ec, "cannot create folder '" << dir.string() << "': " << ec.message());
}

/// Folders made for a command's outputs, removed again if the command fails. create() makes a
/// folder and its missing parents and notes each one made; unless keep() is called, the
/// destructor removes them, children first, each only while empty: a failed command leaves no
/// empty output folder behind, and never removes what another process put there meanwhile.
class CreatedFolders {
 public:
  CreatedFolders() = default;
  CreatedFolders(const CreatedFolders&) = delete;
  CreatedFolders& operator=(const CreatedFolders&) = delete;
  ~CreatedFolders() {
    std::error_code ignored;  // a folder no longer empty stays
    for (auto it = made_.rbegin(); it != made_.rend(); ++it) std::filesystem::remove(*it, ignored);
  }

  void create(const std::filesystem::path& dir) {
    std::vector<std::filesystem::path> missing;  // `dir` first, then its parents
    std::error_code ec;  // a folder that cannot be looked at counts as there: making it says why
    for (auto p = dir; !p.empty() && !std::filesystem::exists(p, ec) && !ec; p = p.parent_path()) {
      missing.push_back(p);
      if (p == p.parent_path()) break;
    }
    for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
      const bool made = std::filesystem::create_directory(*it, ec);
      GIMM_CHECK_AS(WriteError, !ec,
                    "cannot create folder '" << it->string() << "': " << ec.message());
      if (made) made_.push_back(*it);
    }
  }

  /// The command succeeded: the folders stay.
  void keep() { made_.clear(); }

 private:
  std::vector<std::filesystem::path> made_;  // in the order made: parents before children
};

/// A few output files committed together. Write each file to path_for(file) (its temporary,
/// beside it); commit() renames them all into place. Until then no output file has changed; the
/// destructor of an uncommitted batch (the command failed) removes the temporaries and the
/// folders made with create_folder.
class StagedFiles {
 public:
  StagedFiles() = default;
  StagedFiles(const StagedFiles&) = delete;
  StagedFiles& operator=(const StagedFiles&) = delete;
  ~StagedFiles() {
    std::error_code ignored;
    for (const auto& staged : staged_) std::filesystem::remove(staged.first, ignored);
  }

  std::filesystem::path path_for(const std::filesystem::path& file) {
    staged_.emplace_back(temporary_path(file), file);
    return staged_.back().first;
  }

  /// Makes a folder for some of the files (and its missing parents), removed again unless the
  /// batch is committed.
  void create_folder(const std::filesystem::path& dir) { folders_.create(dir); }

  void commit() {
    for (const auto& [tmp, file] : staged_) move_into_place(tmp, file);
    staged_.clear();
    folders_.keep();
  }

 private:
  CreatedFolders folders_;  // declared first: removed after the temporaries in them
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> staged_;  // (tmp, file)
};

/// A command's output folder, all or nothing: the files are written under dir(), a staging
/// folder, and moved into `target` by commit(). A new target is staged beside it as
/// "<target>.tmp.<host>.<pid>" and appears whole by one rename; into an existing target
/// (Commit::merge) the staging folder is "<target>/.staging.tmp.<host>.<pid>" (the target's parent
/// may not be writable), and commit() moves each file to the same place in the target, replacing
/// files of the same names and keeping the others. Commit::replace stages beside the target and
/// replaces it whole (what was there goes). Without commit() (the command failed) the destructor
/// removes the staging folder and any parent folder made for it: the target is as it was.
class StagedFolder {
 public:
  enum class Commit { merge, replace };
  /// The name of a staging folder inside its target starts with this (then temporary_suffix()).
  static constexpr const char* kInsidePrefix = ".staging";

  explicit StagedFolder(const std::filesystem::path& target, Commit how = Commit::merge)
      : target_(without_trailing_separator(target)), how_(how) {
    const bool inside = how == Commit::merge && std::filesystem::is_directory(target_);
    dir_ = inside ? target_ / (kInsidePrefix + temporary_suffix()) : temporary_path(target_);
    std::error_code ignored;  // a killed run of this process id (a container restarted)
    std::filesystem::remove_all(dir_, ignored);
    folders_.create(dir_);
  }
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  ~StagedFolder() {
    std::error_code ignored;
    if (!committed_) std::filesystem::remove_all(dir_, ignored);
  }

  /// Where the outputs are written.
  const std::filesystem::path& dir() const { return dir_; }
  const std::filesystem::path& target() const { return target_; }

  void commit() {
    if (how_ == Commit::replace) remove_target();
    if (std::filesystem::exists(target_))
      move_files_into_target();
    else
      move_into_place(dir_, target_);  // the folder appears whole
    committed_ = true;
    folders_.keep();
  }

 private:
  /// "out/" -> "out": "<target>.tmp.<tag>" must lie beside the target, not in it.
  static std::filesystem::path without_trailing_separator(const std::filesystem::path& p) {
    return p.has_filename() || !p.has_relative_path() ? p : p.parent_path();
  }

  void remove_target() const {
    std::error_code ec;
    std::filesystem::remove_all(target_, ec);
    GIMM_CHECK_AS(WriteError, !ec, "cannot replace '" << target_.string() << "': " << ec.message());
  }

  /// Merging into an existing target: its folders first (they may need space), then the files
  /// (renames), then the empty staging folder.
  void move_files_into_target() {
    namespace fs = std::filesystem;
    std::vector<fs::path> files;  // relative to dir_
    for (const auto& entry : fs::recursive_directory_iterator(dir_)) {
      const fs::path relative = entry.path().lexically_relative(dir_);
      if (entry.is_directory())
        create_folders(target_ / relative);
      else
        files.push_back(relative);
    }
    for (const auto& file : files) move_into_place(dir_ / file, target_ / file);
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  std::filesystem::path target_, dir_;
  Commit how_;
  CreatedFolders folders_;
  bool committed_ = false;
};

/// StagedFiles in one call: `write(at)` writes each output to at(path), its temporary (an empty
/// path, an output not asked for, stays empty); they are renamed into place when `write`
/// returns. If it throws (a full disk), every output path is left as it was; a WriteError, which
/// names a temporary, says so.
template <class Write>
void write_all_or_nothing(Write&& write) {
  StagedFiles staged;
  try {
    write([&](const std::filesystem::path& path) {
      return path.empty() ? path : staged.path_for(path);
    });
  } catch (const WriteError& e) {
    throw WriteError(std::string(e.what()) + "; the outputs are left as they were");
  }
  staged.commit();
}

/// StagedFolder in one call: `write(dir)` writes the outputs under `dir`, a staging folder, and
/// they are moved into `target` when it returns. If it throws, `target` is left as it was; a
/// WriteError, which names a file in the staging folder, says so.
template <class Write>
void write_folder_all_or_nothing(const std::filesystem::path& target, Write&& write) {
  StagedFolder staged(target);
  try {
    write(staged.dir());
  } catch (const WriteError& e) {
    throw WriteError(std::string(e.what()) + "; '" + target.string() + "' is left as it was");
  }
  staged.commit();
}

/// True when `v` is a JSON integer in [lo, hi] (lo <= 0 <= hi), unsigned ones included. Check
/// with it before get<int>() and the like: nlohmann converts a double or a wider integer with a
/// plain cast, which is undefined (49e9 -> int) or wraps (4294967360 -> 64).
inline bool json_int_in(const nlohmann::json& v, std::int64_t lo, std::int64_t hi) {
  if (v.is_number_unsigned()) return v.get<std::uint64_t>() <= static_cast<std::uint64_t>(hi);
  return v.is_number_integer() && v.get<std::int64_t>() >= lo && v.get<std::int64_t>() <= hi;
}

/// Typed fields of a JSON object, for readers of files gimm did not write itself: each throws
/// FormatError naming `where`, the key and the bad value.
inline const nlohmann::json& json_field(const nlohmann::json& j, const char* key,
                                        const std::string& where) {
  GIMM_CHECK_AS(FormatError, j.is_object() && j.contains(key),
                where << ": missing field '" << key << "'");
  return j[key];
}

inline std::string json_string(const nlohmann::json& j, const char* key, const std::string& where) {
  const auto& v = json_field(j, key, where);
  GIMM_CHECK_AS(FormatError, v.is_string(),
                where << ": '" << key << "' must be a string, got " << v.dump());
  return v.get<std::string>();
}

inline int json_int(const nlohmann::json& j, const char* key, const std::string& where) {
  const auto& v = json_field(j, key, where);
  GIMM_CHECK_AS(FormatError,
                json_int_in(v, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()),
                where << ": '" << key << "' must be an integer in int's range, got " << v.dump());
  return v.get<int>();
}

inline double json_number(const nlohmann::json& j, const char* key, const std::string& where) {
  const auto& v = json_field(j, key, where);
  GIMM_CHECK_AS(FormatError, v.is_number() && std::isfinite(v.get<double>()),
                where << ": '" << key << "' must be a finite number, got " << v.dump());
  return v.get<double>();
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
