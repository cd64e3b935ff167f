#pragma once
/// MetaImage volumes -> Volume<T>: .mha (ElementDataFile = LOCAL, the data after the header)
/// and .mhd (ElementDataFile names a data file, relative to the header's folder or absolute).
///
/// Written on zlib rather than MetaIO/ITK for nifti.hpp's reasons.
///
/// The header is "Key = Value" lines; ElementDataFile is the last, and for LOCAL the data
/// starts right after its line. Keys are matched without regard to case; keys gimm does not
/// use are skipped (MetaImage allows any, and ITK writes many, e.g. ITK_original_direction).
/// Reads: NDims 3; DimSize; ElementSpacing (else ElementSize, else 1 mm, as MetaIO); ElementType
/// MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT, MET_ULONG and MET_LONG (32-bit
/// in MetaIO), MET_FLOAT, MET_DOUBLE; BinaryDataByteOrderMSB or ElementByteOrderMSB (absent:
/// this machine's order, as MetaIO); CompressedData (zlib deflate, as MetaIO writes it; gzip
/// is accepted too, as MetaIO reads it) with CompressedDataSize (absent: the rest of the file);
/// HeaderSize (bytes skipped at the start of a data file; -1: the data is its last bytes).
/// Refuses, naming the key and value: NDims other than 3, more than one channel, BinaryData
/// False or absent (text voxels), 64-bit integer and array types, ElementDataFile LIST or a
/// pattern, HeaderSize > 0 with LOCAL data, HeaderSize -1 with compressed data, an intensity
/// function other than the identity, ObjectType other than Image.
///
/// Geometry: MetaImage's physical space is ITK's, which is LPS, so nothing is negated. Offset
/// (aliases Position, Origin) is the centre of the first voxel. TransformMatrix (aliases
/// Rotation, Orientation) lists the axis directions one after another: its first three numbers
/// are the world direction of i, the next three of j, the last three of k (ITK's MetaImageIO
/// writes GetDirection(i)[j] at 3 i + j; plastimatch's .mha/.nrrd of one volume confirm it, see
/// tests/data/volumes). AnatomicalOrientation is informational and not used.
#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gimm/core/volume.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/header_text.hpp"
#include "gimm/io/voxel_data.hpp"

namespace gimm {

/// What a MetaImage header says, after validation.
struct MetaImageHeader {
  VolumeGeometry geometry;             ///< LPS world
  VoxelLayout data;                    ///< where the voxels are
  std::string anatomical_orientation;  ///< as written (informational), "" when absent
};

namespace detail {

constexpr std::size_t kMetaImageHeaderLimit = 1 << 20;

/// A key lowercased, its aliases mapped to one name.
inline std::string metaimage_key(std::string_view raw) {
  const std::string key = lowercase(trim(raw));
  if (key == "position" || key == "origin") return "offset";
  if (key == "rotation" || key == "orientation") return "transformmatrix";
  if (key == "elementbyteordermsb") return "binarydatabyteordermsb";
  return key;
}

inline bool metaimage_bool(const std::string& value, const std::string& what,
                           const std::string& key) {
  const std::string v = lowercase(value);
  if (v == "true" || v == "t" || v == "1") return true;
  if (v == "false" || v == "f" || v == "0") return false;
  GIMM_CHECK_AS(FormatError, false,
                "'" << what << "': " << key << " = '" << value << "' is not True or False");
  return false;
}

inline StoredType metaimage_type(const std::string& value, const std::string& what) {
  static const std::map<std::string, StoredType> types = {
      {"MET_UCHAR", StoredType::uint8},   {"MET_CHAR", StoredType::int8},
      {"MET_USHORT", StoredType::uint16}, {"MET_SHORT", StoredType::int16},
      {"MET_UINT", StoredType::uint32},   {"MET_INT", StoredType::int32},
      {"MET_ULONG", StoredType::uint32},  {"MET_LONG", StoredType::int32},
      {"MET_FLOAT", StoredType::float32}, {"MET_DOUBLE", StoredType::float64}};
  std::string upper(value);
  for (char& c : upper)
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  const auto it = types.find(upper);
  GIMM_CHECK_AS(FormatError, it != types.end(),
                "'" << what << "': ElementType = '" << value
                    << "' is not supported (gimm reads MET_UCHAR, MET_CHAR, MET_USHORT, "
                       "MET_SHORT, MET_UINT, MET_INT, MET_ULONG, MET_LONG, MET_FLOAT, "
                       "MET_DOUBLE)");
  return it->second;
}

/// The header's keys (canonical names) with their values as written and their original
/// spelling, and where the data of a LOCAL file starts.
struct MetaImageFields {
  std::map<std::string, std::pair<std::string, std::string>> values;  // key -> (spelling, value)
  std::uint64_t end = 0;
};

inline MetaImageFields metaimage_fields(std::string_view text, bool whole_file,
                                        const std::string& what) {
  MetaImageFields out;
  HeaderLine line;
  line.complete = true;
  for (int number = 1; line.complete; ++number) {
    line = header_line(text, line.next);
    const std::string_view t = trim(line.text);
    if (t.empty()) continue;
    const std::size_t eq = t.find('=');
    GIMM_CHECK_AS(FormatError, eq != std::string_view::npos,
                  "'" << what << "': header line " << number << " '" << std::string(t.substr(0, 80))
                      << "' is not 'Key = Value'"
                      << (number == 1 ? " (not a MetaImage file?)" : ""));
    GIMM_CHECK_AS(FormatError, line.complete || whole_file,
                  "'" << what << "': no ElementDataFile within the first " << kMetaImageHeaderLimit
                      << " bytes");
    const std::string spelling(trim(t.substr(0, eq)));
    const std::string key = metaimage_key(spelling);
    const auto [it, fresh] =
        out.values.emplace(key, std::make_pair(spelling, std::string(trim(t.substr(eq + 1)))));
    GIMM_CHECK_AS(FormatError, fresh,
                  "'" << what << "': '" << spelling << "' repeats '" << it->second.first << "'");
    if (key == "elementdatafile") {
      out.end = line.next;
      return out;
    }
  }
  GIMM_CHECK_AS(FormatError, whole_file,
                "'" << what << "': no ElementDataFile within the first " << kMetaImageHeaderLimit
                    << " bytes");
  GIMM_CHECK_AS(FormatError, false,
                "'" << what << "': missing ElementDataFile (the last key of a MetaImage header)");
  return out;
}

}  // namespace detail

/// Parses and validates the header of `path` (.mha or .mhd).
inline MetaImageHeader read_metaimage_header(const std::filesystem::path& path) {
  const std::string what = path.string();
  const auto head = read_file_prefix(path, detail::kMetaImageHeaderLimit);
  const std::string_view text(reinterpret_cast<const char*>(head.data()), head.size());
  const auto fields =
      detail::metaimage_fields(text, head.size() < detail::kMetaImageHeaderLimit, what);
  const auto has = [&](const char* k) { return fields.values.count(k) != 0; };
  const auto value = [&](const char* k) -> const std::string& {
    return fields.values.at(k).second;
  };
  const auto spelled = [&](const char* k) { return fields.values.at(k).first; };
  for (const auto& [k, name] : {std::pair<const char*, const char*>{"ndims", "NDims"},
                                {"dimsize", "DimSize"},
                                {"elementtype", "ElementType"}})
    GIMM_CHECK_AS(FormatError, has(k), "'" << what << "': missing " << name);

  if (has("objecttype"))
    GIMM_CHECK_AS(FormatError, detail::lowercase(value("objecttype")) == "image",
                  "'" << what << "': ObjectType = '" << value("objecttype")
                      << "' is not supported (gimm reads Image)");
  const int ndims = detail::parse_number<int>(value("ndims"), what, "NDims");
  GIMM_CHECK_AS(FormatError, ndims == 3,
                "'" << what << "': NDims = " << ndims << " is not supported (gimm reads 3)");

  MetaImageHeader out;
  VolumeGeometry& g = out.geometry;
  const auto dims = detail::parse_numbers<std::uint64_t>(value("dimsize"), 3, what, "DimSize");
  for (int a = 0; a < 3; ++a) {
    GIMM_CHECK_AS(
        FormatError, dims[a] >= 1 && dims[a] <= 65536,
        "'" << what << "': DimSize " << a << " is " << dims[a] << ", gimm reads 1 to 65536");
    g.dims[a] = static_cast<int>(dims[a]);
  }
  const char* spacing_key = has("elementspacing") ? "elementspacing"
                            : has("elementsize")  ? "elementsize"
                                                  : nullptr;
  if (spacing_key) {  // else 1 mm, MetaIO's default
    const auto s = detail::parse_numbers<double>(value(spacing_key), 3, what, spelled(spacing_key));
    for (int a = 0; a < 3; ++a) g.spacing[a] = s[a];
  }
  if (has("offset")) {
    const auto o = detail::parse_numbers<double>(value("offset"), 3, what, spelled("offset"));
    g.origin = Eigen::Vector3d(o[0], o[1], o[2]);
  }
  if (has("transformmatrix")) {
    const auto m = detail::parse_numbers<double>(value("transformmatrix"), 9, what,
                                                 spelled("transformmatrix"));
    for (int axis = 0; axis < 3; ++axis)
      for (int r = 0; r < 3; ++r) g.direction(r, axis) = m[3 * axis + r];
  }
  try {
    g.validate(("'" + what + "'").c_str());
  } catch (const Error& e) {
    throw FormatError(e.what());
  }
  if (has("anatomicalorientation")) out.anatomical_orientation = value("anatomicalorientation");

  VoxelLayout& data = out.data;
  data.type = detail::metaimage_type(value("elementtype"), what);
  if (has("elementnumberofchannels"))
    GIMM_CHECK_AS(FormatError, value("elementnumberofchannels") == "1",
                  "'" << what << "': ElementNumberOfChannels = " << value("elementnumberofchannels")
                      << " is not supported (gimm reads scalar volumes)");
  GIMM_CHECK_AS(FormatError, has("binarydata"),
                "'" << what
                    << "': missing BinaryData (MetaIO then reads text voxels, which "
                       "gimm does not)");
  GIMM_CHECK_AS(FormatError, detail::metaimage_bool(value("binarydata"), what, "BinaryData"),
                "'" << what << "': BinaryData = " << value("binarydata")
                    << " (text voxels) is not supported");
  data.big_endian = has("binarydatabyteordermsb")
                        ? detail::metaimage_bool(value("binarydatabyteordermsb"), what,
                                                 spelled("binarydatabyteordermsb"))
                        : detail::host_is_big_endian();
  for (const auto& [key, identity] :
       {std::pair<const char*, double>{"elementtointensityfunctionslope", 1.0},
        std::pair<const char*, double>{"elementtointensityfunctionoffset", 0.0}})
    if (has(key))
      GIMM_CHECK_AS(FormatError,
                    detail::parse_number<double>(value(key), what, spelled(key)) == identity,
                    "'" << what << "': " << spelled(key) << " = " << value(key)
                        << " is not supported (ITK ignores it; convert the values instead)");
  const bool compressed = has("compresseddata") &&
                          detail::metaimage_bool(value("compresseddata"), what, "CompressedData");
  data.compression = compressed ? VoxelCompression::zlib : VoxelCompression::none;
  if (compressed && has("compresseddatasize")) {
    data.compressed_size = detail::parse_number<std::uint64_t>(value("compresseddatasize"), what,
                                                               "CompressedDataSize");
    GIMM_CHECK_AS(FormatError, *data.compressed_size > 0,
                  "'" << what << "': CompressedDataSize = 0");
  }

  const std::string file = value("elementdatafile");
  const auto words = detail::split_words(file);
  const bool local = detail::lowercase(file) == "local";
  GIMM_CHECK_AS(FormatError,
                !words.empty() && detail::lowercase(words[0]) != "list" &&
                    file.find('%') == std::string::npos,
                "'" << what << "': ElementDataFile = '" << file
                    << "' is not supported (gimm reads LOCAL or one data file, not LIST or a "
                       "pattern)");
  const std::int64_t header_size = has("headersize") ? detail::parse_number<std::int64_t>(
                                                           value("headersize"), what, "HeaderSize")
                                                     : 0;
  GIMM_CHECK_AS(FormatError, header_size >= -1,
                "'" << what << "': HeaderSize = " << header_size << " (must be >= -1)");
  GIMM_CHECK_AS(FormatError, !(local && header_size > 0),
                "'" << what << "': HeaderSize = " << header_size
                    << " with ElementDataFile = LOCAL is not supported");
  GIMM_CHECK_AS(FormatError, !(compressed && header_size < 0),
                "'" << what << "': HeaderSize = -1 with CompressedData = True is not supported");
  data.skip_field = "HeaderSize";
  if (local) {
    data.file = path;
    data.offset = fields.end;
  } else {
    data.file = detached_data_file(path, file, what, "ElementDataFile");
  }
  // HeaderSize counts bytes of the data file, before any decompression (MetaIO seeks there).
  if (compressed)
    data.offset += std::uint64_t(std::max<std::int64_t>(header_size, 0));
  else
    data.skip = header_size;
  return out;
}

/// Reads a MetaImage volume (.mha or .mhd) into Volume<T> (LPS world). Throws gimm::IoError if
/// a file cannot be read, gimm::FormatError (naming the file and key) if it is malformed or
/// uses what gimm does not read.
template <class T>
Volume<T> read_metaimage(const std::filesystem::path& path) {
  const MetaImageHeader header = read_metaimage_header(path);
  return read_voxels<T>(header.geometry, header.data, path.string());
}

}  // namespace gimm
