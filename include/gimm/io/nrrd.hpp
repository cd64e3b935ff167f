#pragma once
/// NRRD volumes -> Volume<T>: .nrrd (data attached after the header's blank line) and .nhdr
/// (a detached header whose "data file:" is relative to the header's folder, or absolute).
///
/// Written on zlib rather than teem/NrrdIO for nifti.hpp's reasons: the header is a page of
/// text, and errors must name the file and the bad field.
///
/// Reads: NRRD0001-NRRD0005; dimension 3, or 4 with a leading or trailing axis of size 1 (the
/// stub axis some writers give a scalar volume; it is dropped); every teem spelling of the 8-,
/// 16- and 32-bit integer types, float and double; encoding raw or gzip (gz); endian little or
/// big; "line skip" (lines of the data file skipped first) and "byte skip" (bytes skipped
/// next: of the inflated stream for gzip, as teem does; -1: the data is the last bytes).
/// Refuses, naming the field and the value: the ascii, hex and bzip2 encodings, 64-bit integer
/// and block types, "data file: LIST" and multi-file patterns, non-scalar axes (kinds other
/// than domain or space), units other than mm, and fields teem does not define.
///
/// Orientation: "space directions" are the world vectors of one voxel step along each axis and
/// "space origin" the centre of the first voxel, in the named space: left-posterior-superior
/// (LPS) as is, right-anterior-superior (RAS) with x and y negated, left-anterior-superior (LAS)
/// with y negated. "3D-right-handed", and "space dimension: 3" with no space named, carry no
/// anatomy; they are taken as LPS, as ITK's NrrdImageIO does. scanner-xyz, 3D-left-handed and
/// the spaces with time are refused. A header without space fields places its grid by
/// "spacings" alone (teem's older per-axis form, no anatomy): identity directions, origin 0.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gimm/core/volume.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/header_text.hpp"
#include "gimm/io/voxel_data.hpp"

namespace gimm {

/// What a NRRD header says, after validation.
struct NrrdHeader {
  VolumeGeometry geometry;  ///< LPS world
  VoxelLayout data;         ///< where the voxels are (line skip already resolved into offset)
  std::string space;        ///< the "space" field, lowercased ("" when absent)
  int version = 0;          ///< X of the NRRD000X magic
};

namespace detail {

constexpr std::size_t kNrrdHeaderLimit = 1 << 20;  // a header is a few KB (DWI: tens of KB)

/// Field names as teem spells them, its alternative spellings mapped to the main one.
inline std::string nrrd_field_name(std::string_view raw) {
  std::string name = lowercase(trim(raw));
  static const std::map<std::string, std::string> aliases = {
      {"datafile", "data file"}, {"lineskip", "line skip"},   {"byteskip", "byte skip"},
      {"axismins", "axis mins"}, {"axismaxs", "axis maxs"},   {"oldmin", "old min"},
      {"oldmax", "old max"},     {"blocksize", "block size"}, {"centerings", "centers"}};
  const auto it = aliases.find(name);
  return it == aliases.end() ? name : it->second;
}

inline bool nrrd_field_known(const std::string& name) {
  static const char* const known[] = {"type",
                                      "dimension",
                                      "sizes",
                                      "encoding",
                                      "endian",
                                      "data file",
                                      "line skip",
                                      "byte skip",
                                      "space",
                                      "space dimension",
                                      "space directions",
                                      "space origin",
                                      "space units",
                                      "spacings",
                                      "kinds",
                                      "units",
                                      "axis mins",
                                      "axis maxs",
                                      "thicknesses",
                                      "centers",
                                      "labels",
                                      "content",
                                      "number",
                                      "min",
                                      "max",
                                      "old min",
                                      "old max",
                                      "sample units",
                                      "measurement frame",
                                      "block size"};
  for (const char* k : known)
    if (name == k) return true;
  return false;
}

/// The NRRD type name (any teem spelling, any case) as a stored type.
inline StoredType nrrd_type(const std::string& value, const std::string& what) {
  const std::string lower = lowercase(value);  // split_words' views point into it
  std::string name;
  for (const auto& w : split_words(lower)) name += (name.empty() ? "" : " ") + std::string(w);
  static const std::map<std::string, StoredType> types = {
      {"signed char", StoredType::int8},
      {"int8", StoredType::int8},
      {"int8_t", StoredType::int8},
      {"uchar", StoredType::uint8},
      {"unsigned char", StoredType::uint8},
      {"uint8", StoredType::uint8},
      {"uint8_t", StoredType::uint8},
      {"short", StoredType::int16},
      {"short int", StoredType::int16},
      {"signed short", StoredType::int16},
      {"signed short int", StoredType::int16},
      {"int16", StoredType::int16},
      {"int16_t", StoredType::int16},
      {"ushort", StoredType::uint16},
      {"unsigned short", StoredType::uint16},
      {"unsigned short int", StoredType::uint16},
      {"uint16", StoredType::uint16},
      {"uint16_t", StoredType::uint16},
      {"int", StoredType::int32},
      {"signed int", StoredType::int32},
      {"int32", StoredType::int32},
      {"int32_t", StoredType::int32},
      {"uint", StoredType::uint32},
      {"unsigned int", StoredType::uint32},
      {"uint32", StoredType::uint32},
      {"uint32_t", StoredType::uint32},
      {"float", StoredType::float32},
      {"double", StoredType::float64}};
  const auto it = types.find(name);
  if (it != types.end()) return it->second;
  const bool wide = name.find("long") != std::string::npos || name.find("64") != std::string::npos;
  GIMM_CHECK_AS(FormatError, false,
                "'" << what << "': field 'type': '" << value << "' is not supported ("
                    << (wide              ? "64-bit integers are not; "
                        : name == "block" ? "block data is not; "
                                          : "")
                    << "gimm reads 8-, 16- and 32-bit integers, float and double)");
  return StoredType::uint8;
}

/// Per-axis vectors "(x,y,z)" or "none", as in "space directions" and "space origin".
inline std::vector<std::optional<Eigen::Vector3d>> nrrd_vectors(std::string_view value,
                                                                const std::string& what,
                                                                const std::string& field) {
  std::vector<std::optional<Eigen::Vector3d>> out;
  for (std::size_t i = 0; i < value.size();) {
    if (value[i] == ' ' || value[i] == '\t') {
      ++i;
      continue;
    }
    if (value[i] != '(') {  // a word: only "none" is allowed
      std::size_t end = value.find_first_of(" \t", i);
      if (end == std::string_view::npos) end = value.size();
      const std::string word(value.substr(i, end - i));
      GIMM_CHECK_AS(FormatError, lowercase(word) == "none",
                    "'" << what << "': field '" << field << "': '" << word
                        << "' is neither a vector (x,y,z) nor none");
      out.emplace_back();
      i = end;
      continue;
    }
    const std::size_t close = value.find(')', i);
    GIMM_CHECK_AS(FormatError, close != std::string_view::npos,
                  "'" << what << "': field '" << field << "': '(' without ')'");
    const std::string_view inside = value.substr(i + 1, close - i - 1);
    std::vector<double> xyz;
    for (std::size_t p = 0;;) {
      const std::size_t comma = inside.find(',', p);
      xyz.push_back(parse_number<double>(inside.substr(p, comma - p), what, field));
      if (comma == std::string_view::npos) break;
      p = comma + 1;
    }
    GIMM_CHECK_AS(FormatError, xyz.size() == 3,
                  "'" << what << "': field '" << field << "': vector (" << std::string(inside)
                      << ") must have 3 components (space dimension 3)");
    out.emplace_back(Eigen::Vector3d(xyz[0], xyz[1], xyz[2]));
    i = close + 1;
  }
  return out;
}

/// Quoted strings, as in "units" and "space units": "mm" "mm" "".
inline std::vector<std::string> nrrd_quoted(std::string_view value, const std::string& what,
                                            const std::string& field) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < value.size();) {
    if (value[i] == ' ' || value[i] == '\t') {
      ++i;
      continue;
    }
    const std::size_t close = value[i] == '"' ? value.find('"', i + 1) : std::string_view::npos;
    GIMM_CHECK_AS(FormatError, close != std::string_view::npos,
                  "'" << what << "': field '" << field << "' must be quoted strings, got '"
                      << std::string(value) << "'");
    out.emplace_back(value.substr(i + 1, close - i - 1));
    i = close + 1;
  }
  return out;
}

/// x and y signs taking the named space to LPS.
inline Eigen::Vector3d nrrd_space_to_lps(const std::string& space, const std::string& what) {
  if (space == "left-posterior-superior" || space == "lps" || space == "3d-right-handed")
    return {1, 1, 1};
  if (space == "right-anterior-superior" || space == "ras") return {-1, -1, 1};
  if (space == "left-anterior-superior" || space == "las") return {1, -1, 1};
  GIMM_CHECK_AS(FormatError, false,
                "'" << what << "': field 'space': '" << space
                    << "' is not supported (gimm reads left-posterior-superior, "
                       "right-anterior-superior, left-anterior-superior, 3D-right-handed)");
  return {};
}

/// The fields of the header in `text` (the file's first bytes), and where the header ends.
struct NrrdFields {
  std::map<std::string, std::string> values;
  int version = 0;
  std::uint64_t end = 0;  ///< first byte after the blank line (the attached data)
};

inline NrrdFields nrrd_fields(std::string_view text, bool whole_file, const std::string& what) {
  NrrdFields out;
  HeaderLine line = header_line(text, 0);
  const std::string magic(line.text.substr(0, 64));
  GIMM_CHECK_AS(FormatError, magic.size() == 8 && magic.compare(0, 7, "NRRD000") == 0,
                "'" << what << "': not a NRRD file (first line '" << magic
                    << "', expected NRRD0001 to NRRD0005)");
  out.version = magic[7] - '0';
  GIMM_CHECK_AS(FormatError, out.version >= 1 && out.version <= 5,
                "'" << what << "': unsupported NRRD version '" << magic
                    << "' (gimm reads NRRD0001 to NRRD0005)");
  for (int number = 2; line.complete; ++number) {
    line = header_line(text, line.next);
    if (line.text.empty() && line.complete) break;  // the blank line ending the header
    if (line.text.empty()) {
      GIMM_CHECK_AS(FormatError, whole_file,
                    "'" << what << "': no blank line ends the header within its first "
                        << kNrrdHeaderLimit << " bytes");
      break;  // end of file: a detached header needs no blank line
    }
    if (line.text[0] == '#') continue;
    const std::size_t colon = line.text.find(':');
    GIMM_CHECK_AS(FormatError, colon != std::string_view::npos,
                  "'" << what << "': header line " << number << " '" << std::string(line.text)
                      << "' is not 'field: value'");
    if (colon + 1 < line.text.size() && line.text[colon + 1] == '=') continue;  // key:=value
    const std::string name = nrrd_field_name(line.text.substr(0, colon));
    GIMM_CHECK_AS(
        FormatError, nrrd_field_known(name),
        "'" << what << "': unknown field '" << name << "' (header line " << number << ")");
    GIMM_CHECK_AS(FormatError,
                  out.values.emplace(name, std::string(trim(line.text.substr(colon + 1)))).second,
                  "'" << what << "': field '" << name << "' appears twice");
    if (!line.complete) GIMM_CHECK_AS(FormatError, whole_file, "'" << what << "': header too long");
  }
  out.end = line.next;
  return out;
}

/// The axes that hold the volume: all three of a 3D header, or the three besides a leading or
/// trailing size-1 axis of a 4D one (the one whose space direction is none, if given).
inline std::vector<int> nrrd_spatial_axes(const std::vector<std::uint64_t>& sizes,
                                          const std::vector<std::optional<Eigen::Vector3d>>* dirs,
                                          const std::string& what) {
  if (sizes.size() == 3) return {0, 1, 2};
  int drop = -1;
  for (const int a : {3, 0}) {
    const bool none = dirs && !(*dirs)[std::size_t(a)];
    if (sizes[std::size_t(a)] == 1 && (!dirs || none) && drop < 0) drop = a;
  }
  GIMM_CHECK_AS(FormatError, drop >= 0,
                "'" << what << "': dimension 4 needs a leading or trailing axis of size 1"
                    << (dirs ? " whose space direction is none" : "") << " (sizes " << sizes[0]
                    << " " << sizes[1] << " " << sizes[2] << " " << sizes[3]
                    << "); gimm reads scalar 3D volumes");
  return drop == 0 ? std::vector<int>{1, 2, 3} : std::vector<int>{0, 1, 2};
}

/// Geometry (LPS) from the space fields, or from "spacings" when there are none.
inline VolumeGeometry nrrd_geometry(const std::map<std::string, std::string>& f,
                                    const std::vector<std::uint64_t>& sizes, std::string& space,
                                    const std::string& what) {
  const auto has = [&](const char* k) { return f.count(k) != 0; };
  const std::size_t dim = sizes.size();
  VolumeGeometry g;
  std::vector<std::optional<Eigen::Vector3d>> dirs;
  if (has("space directions")) {
    dirs = nrrd_vectors(f.at("space directions"), what, "space directions");
    GIMM_CHECK_AS(FormatError, dirs.size() == dim,
                  "'" << what << "': field 'space directions' has " << dirs.size()
                      << " entries for dimension " << dim);
  }
  const std::vector<int> axes =
      nrrd_spatial_axes(sizes, has("space directions") ? &dirs : nullptr, what);
  for (int a = 0; a < 3; ++a) {
    const std::uint64_t n = sizes[std::size_t(axes[std::size_t(a)])];
    GIMM_CHECK_AS(FormatError, n >= 1 && n <= 65536,
                  "'" << what << "': field 'sizes': axis " << axes[std::size_t(a)] << " has " << n
                      << " samples, gimm reads 1 to 65536");
    g.dims[std::size_t(a)] = static_cast<int>(n);
  }
  if (has("kinds")) {
    const auto kinds = split_words(f.at("kinds"));
    GIMM_CHECK_AS(
        FormatError, kinds.size() == dim,
        "'" << what << "': field 'kinds' has " << kinds.size() << " entries for dimension " << dim);
    for (const int a : axes) {
      const std::string kind = lowercase(kinds[std::size_t(a)]);
      GIMM_CHECK_AS(FormatError,
                    kind == "domain" || kind == "space" || kind == "???" || kind == "none",
                    "'" << what << "': field 'kinds': axis " << a << " is '" << kind
                        << "'; gimm reads scalar volumes (kinds domain or space)");
    }
  }

  const bool spatial = has("space") || has("space dimension");
  if (has("space")) {
    space = lowercase(f.at("space"));
    if (has("space dimension"))
      GIMM_CHECK_AS(FormatError, f.at("space dimension") == "3",
                    "'" << what << "': 'space dimension' " << f.at("space dimension")
                        << " disagrees with space '" << space << "'");
  } else if (has("space dimension")) {
    GIMM_CHECK_AS(FormatError,
                  parse_number<int>(f.at("space dimension"), what, "space dimension") == 3,
                  "'" << what << "': field 'space dimension': " << f.at("space dimension")
                      << " is not supported (gimm reads 3)");
  }
  if (!spatial) {
    for (const char* k : {"space directions", "space origin", "space units"})
      GIMM_CHECK_AS(FormatError, !has(k),
                    "'" << what << "': field '" << k << "' needs a 'space' (or 'space dimension')");
    // No space: the grid from "spacings" (identity directions, origin 0).
    GIMM_CHECK_AS(FormatError, has("spacings"),
                  "'" << what << "': no geometry: neither 'space directions' nor 'spacings'");
    GIMM_CHECK_AS(FormatError, !has("axis mins"),
                  "'" << what << "': field 'axis mins' is not supported (use space origin)");
    const auto spacings = parse_numbers<double>(f.at("spacings"), dim, what, "spacings");
    for (int a = 0; a < 3; ++a) {
      const double s = spacings[std::size_t(axes[std::size_t(a)])];
      GIMM_CHECK_AS(FormatError, std::isfinite(s) && s > 0,
                    "'" << what << "': field 'spacings': axis " << axes[std::size_t(a)]
                        << " has spacing " << s << " (must be finite and > 0)");
      g.spacing[a] = s;
    }
    if (has("units")) {
      const auto units = nrrd_quoted(f.at("units"), what, "units");
      GIMM_CHECK_AS(FormatError, units.size() == dim,
                    "'" << what << "': field 'units' has " << units.size()
                        << " entries for dimension " << dim);
      for (const int a : axes)
        GIMM_CHECK_AS(FormatError, units[std::size_t(a)].empty() || units[std::size_t(a)] == "mm",
                      "'" << what << "': field 'units': axis " << a << " is in '"
                          << units[std::size_t(a)] << "', gimm reads mm");
    }
    return g;
  }

  const Eigen::Vector3d flip =
      has("space") ? nrrd_space_to_lps(space, what) : Eigen::Vector3d(1, 1, 1);
  GIMM_CHECK_AS(FormatError, has("space directions"),
                "'" << what << "': space '" << (has("space") ? space : "3D")
                    << "' without 'space directions'");
  if (has("spacings")) {  // teem: an axis has a space direction or a spacing, not both
    const auto spacings = parse_numbers<double>(f.at("spacings"), dim, what, "spacings");
    for (const int a : axes)
      GIMM_CHECK_AS(
          FormatError, !std::isfinite(spacings[std::size_t(a)]),
          "'" << what << "': axis " << a << " has both a space direction and a spacing (use one)");
  }
  for (int a = 0; a < 3; ++a) {
    const auto& v = dirs[std::size_t(axes[std::size_t(a)])];
    GIMM_CHECK_AS(FormatError, v.has_value(),
                  "'" << what << "': field 'space directions': axis " << axes[std::size_t(a)]
                      << " (size " << g.dims[std::size_t(a)] << ") is none");
    const double s = v->norm();
    GIMM_CHECK_AS(FormatError, std::isfinite(s) && s > 0,
                  "'" << what << "': field 'space directions': axis " << axes[std::size_t(a)]
                      << " has length " << s << " (must be finite and > 0)");
    g.spacing[a] = s;
    g.direction.col(a) = flip.asDiagonal() * (*v / s);
  }
  if (has("space origin")) {
    const auto origin = nrrd_vectors(f.at("space origin"), what, "space origin");
    GIMM_CHECK_AS(FormatError, origin.size() == 1 && origin[0],
                  "'" << what << "': field 'space origin' must be one vector (x,y,z), got '"
                      << f.at("space origin") << "'");
    g.origin = flip.asDiagonal() * *origin[0];
  }
  if (has("space units")) {
    const auto units = nrrd_quoted(f.at("space units"), what, "space units");
    for (const auto& u : units)
      GIMM_CHECK_AS(FormatError, u.empty() || u == "mm",
                    "'" << what << "': field 'space units': '" << u << "', gimm reads mm");
  }
  return g;
}

}  // namespace detail

/// Parses and validates the header of `path`; the data file and line skip are resolved, so
/// `data` points at the first byte after the skipped lines.
inline NrrdHeader read_nrrd_header(const std::filesystem::path& path) {
  const std::string what = path.string();
  const auto head = read_file_prefix(path, detail::kNrrdHeaderLimit);
  const std::string_view text(reinterpret_cast<const char*>(head.data()), head.size());
  const bool whole_file = head.size() < detail::kNrrdHeaderLimit;
  const detail::NrrdFields fields = detail::nrrd_fields(text, whole_file, what);
  const auto& f = fields.values;
  const auto has = [&](const char* k) { return f.count(k) != 0; };
  for (const char* k : {"type", "dimension", "sizes", "encoding"})
    GIMM_CHECK_AS(FormatError, has(k), "'" << what << "': missing field '" << k << "'");

  NrrdHeader out;
  out.version = fields.version;
  const int dim = detail::parse_number<int>(f.at("dimension"), what, "dimension");
  GIMM_CHECK_AS(FormatError, dim == 3 || dim == 4,
                "'" << what << "': field 'dimension': " << dim
                    << " is not supported (gimm reads 3, or 4 with a size-1 axis)");
  const auto sizes =
      detail::parse_numbers<std::uint64_t>(f.at("sizes"), std::size_t(dim), what, "sizes");
  out.geometry = detail::nrrd_geometry(f, sizes, out.space, what);
  try {
    out.geometry.validate(("'" + what + "'").c_str());
  } catch (const Error& e) {
    throw FormatError(e.what());
  }

  VoxelLayout& data = out.data;
  data.type = detail::nrrd_type(f.at("type"), what);
  const std::string encoding = detail::lowercase(f.at("encoding"));
  if (encoding == "raw") {
    data.compression = VoxelCompression::none;
  } else if (encoding == "gzip" || encoding == "gz") {
    data.compression = VoxelCompression::gzip;
  } else {
    GIMM_CHECK_AS(FormatError, false,
                  "'" << what << "': field 'encoding': '" << f.at("encoding")
                      << "' is not supported (gimm reads raw and gzip)");
  }
  if (has("endian")) {
    const std::string endian = detail::lowercase(f.at("endian"));
    GIMM_CHECK_AS(
        FormatError, endian == "little" || endian == "big",
        "'" << what << "': field 'endian': '" << f.at("endian") << "' is not little or big");
    data.big_endian = endian == "big";
  } else {
    GIMM_CHECK_AS(FormatError, stored_size(data.type) == 1,
                  "'" << what << "': missing field 'endian' (needed for " << to_string(data.type)
                      << " data)");
  }
  data.skip = has("byte skip")
                  ? detail::parse_number<std::int64_t>(f.at("byte skip"), what, "byte skip")
                  : 0;
  GIMM_CHECK_AS(FormatError, data.skip >= -1,
                "'" << what << "': field 'byte skip': " << data.skip << " (must be >= -1)");
  const std::int64_t line_skip =
      has("line skip") ? detail::parse_number<std::int64_t>(f.at("line skip"), what, "line skip")
                       : 0;
  GIMM_CHECK_AS(FormatError, line_skip >= 0,
                "'" << what << "': field 'line skip': " << line_skip << " (must be >= 0)");

  data.file = path;
  data.offset = fields.end;
  if (has("data file")) {
    const std::string name = f.at("data file");
    const auto words = detail::split_words(name);
    GIMM_CHECK_AS(FormatError,
                  !words.empty() && detail::lowercase(words[0]) != "list" &&
                      !(words.size() > 1 && words[0].find('%') != std::string_view::npos),
                  "'" << what << "': field 'data file': '" << name
                      << "' is not supported (gimm reads one data file, not LIST or a pattern)");
    data.file = detached_data_file(path, name, what, "field 'data file'");
    data.offset = 0;
  }
  if (line_skip > 0) {  // the lines sit before the (possibly compressed) data
    const std::uint64_t size = file_size_of(data.file);
    const std::size_t window = static_cast<std::size_t>(
        std::min<std::uint64_t>(size - std::min(size, data.offset), detail::kNrrdHeaderLimit));
    const auto lines = read_file_range(data.file, data.offset, window);
    std::int64_t found = 0;
    std::size_t at = 0;
    while (found < line_skip && at < lines.size())
      if (lines[at++] == '\n') ++found;
    GIMM_CHECK_AS(FormatError, found == line_skip,
                  "'" << what << "': field 'line skip': " << line_skip << " lines, but '"
                      << data.file.string() << "' has only " << found << " in the " << window
                      << " bytes from byte " << data.offset);
    data.offset += at;
  }
  return out;
}

/// Reads a NRRD volume (.nrrd or .nhdr) into Volume<T> (LPS world). Throws gimm::IoError if a
/// file cannot be read, gimm::FormatError (naming the file and field) if it is malformed or
/// uses what gimm does not read.
template <class T>
Volume<T> read_nrrd(const std::filesystem::path& path) {
  const NrrdHeader header = read_nrrd_header(path);
  return read_voxels<T>(header.geometry, header.data, path.string());
}

}  // namespace gimm
