#pragma once
/// Voxel data as volume files store it, shared by the NIfTI, NRRD and MetaImage readers: the
/// stored scalar types, their conversion into Volume<T>, and reading the data section that a
/// text header (NRRD, MetaImage) points to.
///
/// Conversion: a stored value (scaled by slope and intercept, where the format has them) goes
/// to a floating T by static_cast; an integer T must receive an exact integer in its range,
/// anything else is an error naming the voxel, never a silent clamp.
///
/// Sizes: read_voxels checks what the header claims against the file (for compressed data,
/// against the most that deflate can expand the compressed bytes to) before it allocates, so a
/// header claiming 2^40 voxels in a 100-byte file fails at once, with both numbers.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "gimm/core/volume.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/gzip.hpp"

namespace gimm {

/// Scalar types a volume file can store (and gimm reads).
enum class StoredType { uint8, int8, int16, uint16, int32, uint32, float32, float64 };

inline int stored_size(StoredType type) {
  switch (type) {
    case StoredType::uint8:
    case StoredType::int8:
      return 1;
    case StoredType::int16:
    case StoredType::uint16:
      return 2;
    case StoredType::int32:
    case StoredType::uint32:
    case StoredType::float32:
      return 4;
    case StoredType::float64:
      return 8;
  }
  return 0;
}

inline const char* to_string(StoredType type) {
  switch (type) {
    case StoredType::uint8:
      return "uint8";
    case StoredType::int8:
      return "int8";
    case StoredType::int16:
      return "int16";
    case StoredType::uint16:
      return "uint16";
    case StoredType::int32:
      return "int32";
    case StoredType::uint32:
      return "uint32";
    case StoredType::float32:
      return "float32";
    case StoredType::float64:
      return "float64";
  }
  return "?";
}

enum class VoxelCompression { none, gzip, zlib };

/// Where a text header says the voxels are and how they are stored.
struct VoxelLayout {
  StoredType type = StoredType::uint8;
  bool big_endian = false;
  VoxelCompression compression = VoxelCompression::none;
  std::filesystem::path file;  ///< the file holding the data (the header's own when attached)
  std::uint64_t offset = 0;    ///< first byte of the data (raw) or of the compressed stream
  /// Bytes skipped at the start of the data (raw) or of the inflated stream (compressed);
  /// -1 - N means the data ends N bytes before the end instead (NRRD "byte skip: -1",
  /// MetaImage "HeaderSize = -1").
  std::int64_t skip = 0;
  std::optional<std::uint64_t> compressed_size;  ///< else the stream runs to the end of file
  std::string skip_field = "byte skip";          ///< the header field behind `skip`
};

/// A detached header's data file (NRRD "data file:", MetaImage ElementDataFile): `name` as the
/// header `what` writes it in `field`, relative to the header's folder or absolute. Policy
/// (docs/conventions.md, "Detached data files"): the formats allow any path, and so does gimm
/// (volume_file.hpp's detached_data_note names one outside the header's folder in the CLIs'
/// logs), but only a regular file: a folder, device or pipe (/dev/zero, /dev/stdin) is refused
/// by name, as it would stream without end or block.
inline std::filesystem::path detached_data_file(const std::filesystem::path& header,
                                                const std::string& name, const std::string& what,
                                                const char* field) {
  const std::filesystem::path file(name);
  const std::filesystem::path resolved = file.is_absolute() ? file : header.parent_path() / file;
  std::error_code ec;
  const auto status = std::filesystem::status(resolved, ec);
  GIMM_CHECK_AS(IoError, std::filesystem::exists(status),
                "'" << what << "': " << field << " '" << name << "' ('" << resolved.string()
                    << "') does not exist"
                    << (ec && ec != std::errc::no_such_file_or_directory ? ": " + ec.message()
                                                                         : std::string()));
  GIMM_CHECK_AS(FormatError, std::filesystem::is_regular_file(status),
                "'" << what << "': " << field << " '" << name << "' ('" << resolved.string()
                    << "') is not a regular file (a folder, device or pipe): gimm reads voxels "
                       "from files only");
  return resolved;
}

namespace detail {

inline bool host_is_big_endian() {
  const std::uint16_t one = 1;
  unsigned char first;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

inline void swap_bytes(unsigned char* p, int n) {
  std::reverse(p, p + n);
}

/// a * b, or a FormatError naming `what` when the product does not fit 64 bits.
inline std::uint64_t checked_mul(std::uint64_t a, std::uint64_t b, const std::string& what) {
  std::uint64_t product = 0;
  GIMM_CHECK_AS(FormatError, !__builtin_mul_overflow(a, b, &product),
                "'" << what << "': size " << a << " x " << b << " overflows 64 bits");
  return product;
}

template <class T>
constexpr std::optional<StoredType> stored_type_of() {
  if constexpr (std::is_same_v<T, std::uint8_t>) return StoredType::uint8;
  if constexpr (std::is_same_v<T, std::int8_t>) return StoredType::int8;
  if constexpr (std::is_same_v<T, std::int16_t>) return StoredType::int16;
  if constexpr (std::is_same_v<T, std::uint16_t>) return StoredType::uint16;
  if constexpr (std::is_same_v<T, std::int32_t>) return StoredType::int32;
  if constexpr (std::is_same_v<T, std::uint32_t>) return StoredType::uint32;
  if constexpr (std::is_same_v<T, float>) return StoredType::float32;
  if constexpr (std::is_same_v<T, double>) return StoredType::float64;
  return std::nullopt;
}

template <class T>
T convert_voxel(double value, std::size_t voxel, const std::string& what) {
  if constexpr (std::is_floating_point_v<T>) {
    (void)voxel;
    (void)what;
    return static_cast<T>(value);
  } else {
    GIMM_CHECK_AS(FormatError,
                  value == std::round(value) &&
                      value >= static_cast<double>(std::numeric_limits<T>::lowest()) &&
                      value <= static_cast<double>(std::numeric_limits<T>::max()),
                  "'" << what << "': voxel " << voxel << " has value " << value
                      << ", which does not fit the requested integer type");
    return static_cast<T>(value);
  }
}

/// `count` voxels stored as `Stored` at `src` (byte-swapped when `swapped`), scaled when
/// slope != 1 or inter != 0, into `dst`.
template <class Stored, class T>
void decode_voxels_as(const unsigned char* src, bool swapped, double slope, double inter,
                      const std::string& what, T* dst, std::size_t count) {
  const bool scaled = slope != 1.0 || inter != 0.0;
  if constexpr (std::is_same_v<Stored, T>) {
    if (!scaled && !swapped) {  // the common case: one copy
      if (count) std::memcpy(dst, src, count * sizeof(T));
      return;
    }
  }
  for (std::size_t n = 0; n < count; ++n) {
    unsigned char raw[sizeof(Stored)];
    std::memcpy(raw, src + n * sizeof(Stored), sizeof(Stored));
    if (swapped) swap_bytes(raw, sizeof(Stored));
    Stored stored;
    std::memcpy(&stored, raw, sizeof(Stored));
    if (!scaled && std::is_same_v<Stored, T>) {
      dst[n] = static_cast<T>(stored);
      continue;
    }
    const double value =
        scaled ? static_cast<double>(stored) * slope + inter : static_cast<double>(stored);
    dst[n] = convert_voxel<T>(value, n, what);
  }
}

template <class T>
void decode_voxels(StoredType type, const unsigned char* src, bool swapped, double slope,
                   double inter, const std::string& what, T* dst, std::size_t count) {
  switch (type) {
    case StoredType::uint8:
      return decode_voxels_as<std::uint8_t>(src, swapped, slope, inter, what, dst, count);
    case StoredType::int8:
      return decode_voxels_as<std::int8_t>(src, swapped, slope, inter, what, dst, count);
    case StoredType::int16:
      return decode_voxels_as<std::int16_t>(src, swapped, slope, inter, what, dst, count);
    case StoredType::uint16:
      return decode_voxels_as<std::uint16_t>(src, swapped, slope, inter, what, dst, count);
    case StoredType::int32:
      return decode_voxels_as<std::int32_t>(src, swapped, slope, inter, what, dst, count);
    case StoredType::uint32:
      return decode_voxels_as<std::uint32_t>(src, swapped, slope, inter, what, dst, count);
    case StoredType::float32:
      return decode_voxels_as<float>(src, swapped, slope, inter, what, dst, count);
    case StoredType::float64:
      return decode_voxels_as<double>(src, swapped, slope, inter, what, dst, count);
  }
}

/// "5x4x3 int16 voxels (120 bytes)", for size messages.
inline std::string voxels_description(const VolumeGeometry& g, StoredType type,
                                      std::uint64_t bytes) {
  return std::to_string(g.dims[0]) + "x" + std::to_string(g.dims[1]) + "x" +
         std::to_string(g.dims[2]) + " " + to_string(type) + " voxels (" + std::to_string(bytes) +
         " bytes)";
}

/// deflate expands at most 1032:1, so `compressed` bytes cannot hold more than this.
inline std::uint64_t max_inflated_size(std::uint64_t compressed) {
  return compressed > (std::uint64_t(1) << 50) ? std::uint64_t(-1) : compressed * 1032 + 1024;
}

}  // namespace detail

/// Reads the voxels that `layout` describes onto `geometry` (validated by the caller). `what`
/// names the header in errors. The header's sizes are checked against the file before
/// anything is allocated; a data section shorter or longer than the sizes say is an error
/// with the byte counts.
template <class T>
Volume<T> read_voxels(const VolumeGeometry& geometry, const VoxelLayout& layout,
                      const std::string& what) {
  const std::string data_name = "'" + layout.file.string() + "'";
  const std::uint64_t count = detail::checked_mul(
      detail::checked_mul(std::uint64_t(geometry.dims[0]), std::uint64_t(geometry.dims[1]), what),
      std::uint64_t(geometry.dims[2]), what);
  const std::uint64_t bytes = detail::checked_mul(count, stored_size(layout.type), what);
  // "5x4x3 int16 voxels (120 bytes)", with the skip when there is one.
  const std::string voxels =
      detail::voxels_description(geometry, layout.type, bytes) +
      (layout.skip ? " with " + layout.skip_field + " " + std::to_string(layout.skip) : "");
  // Bytes skipped before (skip >= 0) or after (skip < 0) the voxels.
  const std::uint64_t extra =
      layout.skip >= 0 ? std::uint64_t(layout.skip) : std::uint64_t(-(layout.skip + 1));
  GIMM_CHECK_AS(FormatError, bytes <= (std::uint64_t(1) << 62) - extra,
                "'" << what << "': " << voxels << " is too large");
  const std::uint64_t need = bytes + extra;
  const std::uint64_t file_size = file_size_of(layout.file);
  GIMM_CHECK_AS(FormatError, layout.offset <= file_size,
                "'" << what << "': truncated: the data should start at byte " << layout.offset
                    << " of " << data_name << ", which has " << file_size << " bytes");
  const std::uint64_t available = file_size - layout.offset;
  const bool swapped =
      layout.big_endian != detail::host_is_big_endian() && stored_size(layout.type) > 1;

  if (layout.compression == VoxelCompression::none) {
    GIMM_CHECK_AS(FormatError, available >= need,
                  "'" << what << "': truncated: " << voxels << " need " << need
                      << " bytes from byte " << layout.offset << " of " << data_name << ", found "
                      << available);
    GIMM_CHECK_AS(FormatError, layout.skip < 0 || available == need,
                  "'" << what << "': " << available - need << " bytes beyond the voxel data in "
                      << data_name << ": " << voxels << " do not match the data size");
    const std::uint64_t begin =
        layout.offset + (layout.skip >= 0 ? std::uint64_t(layout.skip) : available - need);
    Volume<T> volume(geometry);
    if (detail::stored_type_of<T>() == layout.type && !swapped) {  // straight into the volume
      read_file_range(layout.file, begin, volume.data(), static_cast<std::size_t>(bytes));
    } else {
      const auto raw = read_file_range(layout.file, begin, static_cast<std::size_t>(bytes));
      detail::decode_voxels(layout.type, raw.data(), swapped, 1.0, 0.0, what, volume.data(),
                            volume.size());
    }
    return volume;
  }

  const char* format = layout.compression == VoxelCompression::gzip ? "gzip" : "zlib";
  const std::uint64_t stream = layout.compressed_size.value_or(available);
  GIMM_CHECK_AS(FormatError, stream <= available,
                "'" << what << "': truncated: CompressedDataSize " << stream << " bytes, but "
                    << data_name << " has " << available << " after byte " << layout.offset);
  GIMM_CHECK_AS(FormatError, stream == available,
                "'" << what << "': " << available - stream << " bytes in " << data_name
                    << " beyond the " << stream << " compressed bytes (CompressedDataSize)");
  GIMM_CHECK_AS(FormatError, need <= detail::max_inflated_size(stream),
                "'" << what << "': truncated: " << voxels << " need " << need
                    << " bytes, more than the " << stream << " " << format << " bytes in "
                    << data_name << " can inflate to");
  const auto packed = read_file_range(layout.file, layout.offset, static_cast<std::size_t>(stream));
  // Room for one byte more than needed, so data beyond the voxels is seen (skip >= 0);
  // with skip < 0 the leading bytes are unknown, bounded by what the stream can hold.
  const std::uint64_t limit = layout.skip >= 0 ? need + 1 : detail::max_inflated_size(stream);
  std::vector<unsigned char> inflated;
  try {
    inflated = layout.compression == VoxelCompression::gzip
                   ? gzip_decompress(packed, layout.file.string(), limit)
                   : zlib_decompress(packed.data(), packed.size(), layout.file.string(), limit);
  } catch (const FormatError& e) {
    throw FormatError(std::string(e.what()) + "; '" + what + "': " + voxels + " need " +
                      std::to_string(need) + " bytes");
  }
  GIMM_CHECK_AS(FormatError, inflated.size() >= need,
                "'" << what << "': truncated: " << voxels << " need " << need << " bytes, the "
                    << format << " data in " << data_name << " inflates to " << inflated.size());
  GIMM_CHECK_AS(FormatError, layout.skip < 0 || inflated.size() == need,
                "'" << what << "': " << inflated.size() - need
                    << " bytes beyond the voxel data in the " << format << " data of " << data_name
                    << ": " << voxels << " do not match the data size");
  const std::size_t begin =
      layout.skip >= 0 ? std::size_t(layout.skip) : std::size_t(inflated.size() - need);
  Volume<T> volume(geometry);
  detail::decode_voxels(layout.type, inflated.data() + begin, swapped, 1.0, 0.0, what,
                        volume.data(), volume.size());
  return volume;
}

}  // namespace gimm
