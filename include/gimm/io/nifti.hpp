#pragma once
/// NIfTI-1 volumes (.nii and .nii.gz) <-> Volume<T>.
///
/// Written on zlib rather than niftilib: a 348-byte header is ~150 lines to parse, niftilib
/// would add a C dependency (and its own error handling, which prints and exits) to every
/// consumer of gimm::io, and we need errors that name the file and the bad field.
///
/// Orientation: NIfTI's world is RAS (+x right, +y anterior, +z superior); gimm's is LPS, so
/// on read the affine's first two rows are negated, and on write they are negated back. The
/// affine comes from the sform if sform_code > 0, else from the qform if qform_code > 0, else
/// from pixdim alone ("method 1", no origin) - the same order as nibabel. Written files carry
/// both, equal, with code 2 ("aligned anatomical").
///
/// Stored types: uint8, int8, int16, uint16, int32, uint32, float32, float64, in either byte
/// order. scl_slope/scl_inter are applied on read (slope 0 or non-finite means "no scaling",
/// as the standard says). Reading into an integer T requires every scaled value to be an
/// integer in T's range; anything else is an error naming the voxel, never a silent clamp (the
/// conversion is voxel_data.hpp's, shared with the NRRD and MetaImage readers).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "gimm/core/volume.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/gzip.hpp"
#include "gimm/io/voxel_data.hpp"

namespace gimm {

/// NIfTI-1 datatype codes gimm reads and writes.
enum NiftiDatatype : int {
  nifti_uint8 = 2,
  nifti_int16 = 4,
  nifti_int32 = 8,
  nifti_float32 = 16,
  nifti_float64 = 64,
  nifti_int8 = 256,
  nifti_uint16 = 512,
  nifti_uint32 = 768,
};

/// What the header says, after validation.
struct NiftiHeader {
  VolumeGeometry geometry;  ///< LPS world
  int datatype = 0;
  int bitpix = 0;
  double scl_slope = 1.0;  ///< 1 when the file has no scaling
  double scl_inter = 0.0;
  std::size_t vox_offset = 352;
  bool byte_swapped = false;
  std::string affine_source;  ///< "sform", "qform" or "pixdim"
};

namespace detail {

constexpr std::size_t kNiftiHeaderSize = 348;

template <class T>
constexpr int nifti_datatype_of() {
  if constexpr (std::is_same_v<T, std::uint8_t>) return nifti_uint8;
  if constexpr (std::is_same_v<T, std::int8_t>) return nifti_int8;
  if constexpr (std::is_same_v<T, std::int16_t>) return nifti_int16;
  if constexpr (std::is_same_v<T, std::uint16_t>) return nifti_uint16;
  if constexpr (std::is_same_v<T, std::int32_t>) return nifti_int32;
  if constexpr (std::is_same_v<T, std::uint32_t>) return nifti_uint32;
  if constexpr (std::is_same_v<T, float>) return nifti_float32;
  if constexpr (std::is_same_v<T, double>) return nifti_float64;
  return 0;
}

/// The stored type of a datatype code nifti_bytes_per_voxel accepts.
inline StoredType nifti_stored_type(int datatype) {
  switch (datatype) {
    case nifti_int8:
      return StoredType::int8;
    case nifti_int16:
      return StoredType::int16;
    case nifti_uint16:
      return StoredType::uint16;
    case nifti_int32:
      return StoredType::int32;
    case nifti_uint32:
      return StoredType::uint32;
    case nifti_float32:
      return StoredType::float32;
    case nifti_float64:
      return StoredType::float64;
    default:  // nifti_uint8
      return StoredType::uint8;
  }
}

inline int nifti_bytes_per_voxel(int datatype) {
  switch (datatype) {
    case nifti_uint8:
    case nifti_int8:
      return 1;
    case nifti_int16:
    case nifti_uint16:
      return 2;
    case nifti_int32:
    case nifti_uint32:
    case nifti_float32:
      return 4;
    case nifti_float64:
      return 8;
    default:
      return 0;
  }
}

/// Reads little- or big-endian header fields.
class HeaderFields {
 public:
  HeaderFields(const unsigned char* bytes, bool swapped) : bytes_(bytes), swapped_(swapped) {}
  template <class T>
  T get(std::size_t offset) const {
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, bytes_ + offset, sizeof(T));
    if (swapped_) swap_bytes(raw, sizeof(T));
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return value;
  }

 private:
  const unsigned char* bytes_;
  bool swapped_;
};

/// NIfTI quaternion (b, c, d; a >= 0 implied) to a rotation matrix.
inline Eigen::Matrix3d nifti_quaternion_to_rotation(double b, double c, double d) {
  const double a = std::sqrt(std::max(0.0, 1.0 - (b * b + c * c + d * d)));
  return Eigen::Quaterniond(a, b, c, d).normalized().toRotationMatrix();
}

/// The 3x4 RAS affine from sform, qform or pixdim, and which one it came from.
inline Eigen::Matrix<double, 3, 4> nifti_affine(const HeaderFields& h, const std::string& what,
                                                std::string& source) {
  Eigen::Matrix<double, 3, 4> A = Eigen::Matrix<double, 3, 4>::Zero();
  const std::int16_t qform_code = h.get<std::int16_t>(252);
  const std::int16_t sform_code = h.get<std::int16_t>(254);
  const Eigen::Vector3d pixdim(h.get<float>(80), h.get<float>(84), h.get<float>(88));
  if (sform_code <= 0)
    for (int a = 0; a < 3; ++a)
      GIMM_CHECK_AS(FormatError, std::isfinite(pixdim[a]) && pixdim[a] > 0,
                    "'" << what << "': pixdim[" << a + 1 << "] (voxel spacing) must be finite "
                        << "and > 0, got " << pixdim[a]);
  if (sform_code > 0) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) A(r, c) = h.get<float>(280 + 16 * r + 4 * c);
    source = "sform";
  } else if (qform_code > 0) {
    const float qfac_raw = h.get<float>(76);
    const double qfac = qfac_raw < 0 ? -1.0 : 1.0;  // 0 means 1, by the standard
    const double b = h.get<float>(256), c = h.get<float>(260), d = h.get<float>(264);
    // (b, c, d) is the vector part of a unit quaternion, a = sqrt(1 - b^2 - c^2 - d^2). Past
    // float rounding (a unit quaternion stored as float32 reaches 1 + 1e-6) it is no rotation:
    // niftilib rescales it silently; guessing the patient's orientation is refused instead.
    const double norm2 = b * b + c * c + d * d;
    GIMM_CHECK_AS(FormatError, std::isfinite(norm2) && norm2 <= 1 + 1e-4,
                  "'" << what << "': the qform quaternion (b, c, d) = (" << b << ", " << c << ", "
                      << d << ") has b^2 + c^2 + d^2 = " << norm2
                      << " > 1: not a rotation (the file's orientation is corrupt)");
    const Eigen::Matrix3d R = nifti_quaternion_to_rotation(b, c, d);
    A.leftCols<3>() = R * Eigen::Vector3d(pixdim.x(), pixdim.y(), qfac * pixdim.z()).asDiagonal();
    A.col(3) = Eigen::Vector3d(h.get<float>(268), h.get<float>(272), h.get<float>(276));
    source = "qform";
  } else {
    A.leftCols<3>() = pixdim.asDiagonal();
    source = "pixdim";
  }
  GIMM_CHECK_AS(FormatError, A.allFinite(),
                "'" << what << "': the " << source << " affine has non-finite entries:\n"
                    << A);
  return A;
}

/// The file size a header implies: its voxel offset plus the voxel data.
inline std::uint64_t nifti_file_size(const NiftiHeader& h) {
  return h.vox_offset + static_cast<std::uint64_t>(h.geometry.voxel_count()) *
                            static_cast<std::uint64_t>(nifti_bytes_per_voxel(h.datatype));
}

/// Parses and validates a header: `head` holds the file's first `head_size` bytes (at least
/// the 348 of the header, when the file has them) and `file_size` is the whole (decompressed)
/// file's size, against which the data size is checked.
inline NiftiHeader parse_nifti_header(const unsigned char* head, std::size_t head_size,
                                      std::uint64_t file_size, const std::string& what,
                                      bool check_size = true) {
  GIMM_CHECK_AS(
      FormatError, head_size >= kNiftiHeaderSize,
      "'" << what << "': " << file_size << " bytes is too short for a NIfTI-1 header (348 bytes)");
  std::int32_t sizeof_hdr;
  std::memcpy(&sizeof_hdr, head, 4);
  NiftiHeader out;
  if (sizeof_hdr != 348) {
    std::int32_t swapped = sizeof_hdr;
    swap_bytes(reinterpret_cast<unsigned char*>(&swapped), 4);
    // NIfTI-2 says 540 here, in either byte order.
    const bool nifti2 = sizeof_hdr == 540 || swapped == 540;
    sizeof_hdr = swapped;
    GIMM_CHECK_AS(FormatError, sizeof_hdr == 348,
                  "'" << what << "': not a NIfTI-1 file (sizeof_hdr is not 348"
                      << (nifti2 ? "; it is a NIfTI-2 file (540), which gimm does not read: "
                                   "convert it to NIfTI-1, e.g. with nibabel or plastimatch"
                                 : "")
                      << ")");
    out.byte_swapped = true;
  }
  const char* magic = reinterpret_cast<const char*>(head) + 344;
  GIMM_CHECK_AS(FormatError, std::memcmp(magic, "ni1", 4) != 0,
                "'" << what << "': two-file NIfTI (.hdr/.img) is not supported");
  GIMM_CHECK_AS(FormatError, std::memcmp(magic, "n+1", 4) == 0,
                "'" << what << "': bad NIfTI-1 magic '" << std::string(magic, strnlen(magic, 4))
                    << "' (expected 'n+1')");
  const HeaderFields h(head, out.byte_swapped);

  const int ndim = h.get<std::int16_t>(40);
  GIMM_CHECK_AS(FormatError, ndim >= 1 && ndim <= 7,
                "'" << what << "': dim[0] must be in 1..7, got " << ndim);
  for (int a = 0; a < 7; ++a) {
    const int n = a < ndim ? h.get<std::int16_t>(42 + 2 * a) : 1;
    if (a < 3) {
      GIMM_CHECK_AS(FormatError, n >= 1,
                    "'" << what << "': dim[" << a + 1 << "] must be >= 1, got " << n);
      out.geometry.dims[a] = n;
    } else {
      GIMM_CHECK_AS(
          FormatError, n == 1,
          "'" << what << "': only 3D volumes are supported, dim[" << a + 1 << "] = " << n);
    }
  }

  out.datatype = h.get<std::int16_t>(70);
  out.bitpix = h.get<std::int16_t>(72);
  const int bytes_per_voxel = nifti_bytes_per_voxel(out.datatype);
  GIMM_CHECK_AS(FormatError, bytes_per_voxel > 0,
                "'" << what << "': unsupported NIfTI datatype " << out.datatype
                    << " (supported: uint8, int8, int16, uint16, int32, uint32, float32, "
                       "float64)");
  GIMM_CHECK_AS(
      FormatError, out.bitpix == 8 * bytes_per_voxel,
      "'" << what << "': bitpix " << out.bitpix << " does not match datatype " << out.datatype);

  const float vox_offset = h.get<float>(108);
  GIMM_CHECK_AS(FormatError, std::isfinite(vox_offset) && vox_offset >= 348 && vox_offset < 1e9,
                "'" << what << "': vox_offset must be >= 348, got " << vox_offset);
  out.vox_offset = static_cast<std::size_t>(vox_offset);

  const double slope = h.get<float>(112), inter = h.get<float>(116);
  if (std::isfinite(slope) && slope != 0.0) {
    out.scl_slope = slope;
    out.scl_inter = std::isfinite(inter) ? inter : 0.0;
  }

  const Eigen::Matrix<double, 3, 4> ras = nifti_affine(h, what, out.affine_source);
  const Eigen::Matrix<double, 3, 4> lps = Eigen::Vector3d(-1, -1, 1).asDiagonal() * ras;
  for (int a = 0; a < 3; ++a) {
    const double s = lps.col(a).norm();
    GIMM_CHECK_AS(FormatError, std::isfinite(s) && s > 0,
                  "'" << what << "': voxel spacing " << a << " from the " << out.affine_source
                      << " must be finite and > 0, got " << s);
    out.geometry.spacing[a] = s;
    out.geometry.direction.col(a) = lps.col(a) / s;
  }
  out.geometry.origin = lps.col(3);
  try {
    out.geometry.validate(("'" + what + "'").c_str());
  } catch (const Error& e) {
    throw FormatError(e.what());
  }

  const std::uint64_t expected = nifti_file_size(out);
  if (!check_size) return out;
  GIMM_CHECK_AS(FormatError, file_size >= expected,
                "'" << what << "': truncated: dims " << out.geometry.dims[0] << "x"
                    << out.geometry.dims[1] << "x" << out.geometry.dims[2] << " of "
                    << bytes_per_voxel << "-byte voxels need " << expected << " bytes, file has "
                    << file_size);
  GIMM_CHECK_AS(FormatError, file_size == expected,
                "'" << what << "': " << file_size - expected
                    << " bytes beyond the voxel data: dims " << out.geometry.dims[0] << "x"
                    << out.geometry.dims[1] << "x" << out.geometry.dims[2]
                    << " do not match the data size");
  return out;
}

/// The same for a whole file in memory.
inline NiftiHeader parse_nifti_header(const std::vector<unsigned char>& bytes,
                                      const std::string& what) {
  return parse_nifti_header(bytes.data(), bytes.size(), bytes.size(), what);
}

/// Inflates a .nii.gz no further than the size its header implies: a small file that inflates
/// to gigabytes (or a header whose dims do not match the data) stops there, with an error
/// naming both sizes, instead of allocating what the stream would give.
inline std::vector<unsigned char> inflate_nifti(const std::vector<unsigned char>& gz,
                                                const std::string& what) {
  const std::vector<unsigned char> head = gzip_prefix(gz, what, kNiftiHeaderSize);
  const NiftiHeader h = parse_nifti_header(head.data(), head.size(), head.size(), what, false);
  const std::uint64_t implied = nifti_file_size(h);
  // + 1: zlib may need room to see the end of a stream of exactly the implied size.
  return gzip_decompress(gz, what, implied + 1,
                         ": the header implies " + std::to_string(implied) + " bytes (dims " +
                             std::to_string(h.geometry.dims[0]) + "x" +
                             std::to_string(h.geometry.dims[1]) + "x" +
                             std::to_string(h.geometry.dims[2]) + ")");
}

/// Rotation (det +1) to NIfTI quaternion (b, c, d) with a >= 0.
inline Eigen::Vector3d nifti_rotation_to_quaternion(const Eigen::Matrix3d& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;
  return Eigen::Vector3d(q.x(), q.y(), q.z());
}

template <class T>
void put(std::vector<unsigned char>& bytes, std::size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof(T));
}

}  // namespace detail

namespace detail {
/// The fast path of read_nifti: an uncompressed file whose voxels are stored as T, unscaled,
/// in host byte order, is read with one fread into the volume (no whole-file buffer, no second
/// copy: half the memory traffic of a 64 MB CT). Anything else: nullopt, and the general path.
template <class T>
std::optional<Volume<T>> read_nifti_in_place(const std::filesystem::path& path) {
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec || size < kNiftiHeaderSize) return std::nullopt;
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) return std::nullopt;
  unsigned char head[kNiftiHeaderSize];
  if (std::fread(head, 1, sizeof head, f.get()) != sizeof head ||
      (head[0] == 0x1f && head[1] == 0x8b))
    return std::nullopt;
  const NiftiHeader header = parse_nifti_header(head, sizeof head, size, path.string());
  if (header.datatype != nifti_datatype_of<T>() || header.byte_swapped || header.scl_slope != 1.0 ||
      header.scl_inter != 0.0)
    return std::nullopt;
  Volume<T> volume(header.geometry);
  const std::size_t count = volume.size();
  GIMM_CHECK_AS(IoError,
                std::fseek(f.get(), static_cast<long>(header.vox_offset), SEEK_SET) == 0 &&
                    std::fread(volume.data(), sizeof(T), count, f.get()) == count,
                "error reading the voxels of '" << path.string() << "'");
  return volume;
}
}  // namespace detail

/// Reads the header only (the whole file is still read and, if gzipped, inflated).
inline NiftiHeader read_nifti_header(const std::filesystem::path& path) {
  auto bytes = read_file_bytes(path);
  if (is_gzip(bytes)) bytes = detail::inflate_nifti(bytes, path.string());
  return detail::parse_nifti_header(bytes, path.string());
}

/// A NIfTI-1 volume from the bytes of a .nii or .nii.gz file already in memory; `what` names
/// them in errors (gimm::FormatError).
template <class T>
Volume<T> nifti_from_bytes(std::vector<unsigned char> bytes, const std::string& what) {
  if (is_gzip(bytes)) bytes = detail::inflate_nifti(bytes, what);
  const NiftiHeader header = detail::parse_nifti_header(bytes, what);
  Volume<T> volume(header.geometry);
  const unsigned char* src = bytes.data() + header.vox_offset;
  detail::decode_voxels(detail::nifti_stored_type(header.datatype), src, header.byte_swapped,
                        header.scl_slope, header.scl_inter, what, volume.data(), volume.size());
  return volume;
}

/// Reads a NIfTI-1 volume into Volume<T> (LPS world). Throws gimm::IoError if the file cannot
/// be read, gimm::FormatError (naming the file) if it is malformed.
template <class T>
Volume<T> read_nifti(const std::filesystem::path& path) {
  if (auto direct = detail::read_nifti_in_place<T>(path)) return std::move(*direct);
  return nifti_from_bytes<T>(read_file_bytes(path), path.string());
}

/// Writes `volume` as NIfTI-1, gzipped if the name ends in ".gz", atomically (a temporary file
/// renamed into place). Output bytes depend only on the volume (no timestamps).
template <class T>
void write_nifti(const std::filesystem::path& path, const Volume<T>& volume,
                 const std::string& description = "gimm", int gzip_level = 1) {
  constexpr int datatype = detail::nifti_datatype_of<T>();
  static_assert(datatype != 0, "write_nifti: unsupported voxel type");
  const VolumeGeometry& g = volume.geometry();
  g.validate(path.string().c_str());
  GIMM_CHECK(g.dims[0] <= 32767 && g.dims[1] <= 32767 && g.dims[2] <= 32767,
             "write_nifti: '" << path.string() << "': NIfTI-1 dims are int16, got " << g.dims[0]
                              << "x" << g.dims[1] << "x" << g.dims[2]);
  constexpr std::size_t offset = 352;
  std::vector<unsigned char> bytes;
  resize_huge(bytes, offset + volume.size() * sizeof(T));
  using detail::put;
  put<std::int32_t>(bytes, 0, 348);
  bytes[39] = 0;  // dim_info
  put<std::int16_t>(bytes, 40, 3);
  for (int a = 0; a < 3; ++a) put<std::int16_t>(bytes, 42 + 2 * a, g.dims[a]);
  for (int a = 3; a < 7; ++a) put<std::int16_t>(bytes, 42 + 2 * a, 1);
  put<std::int16_t>(bytes, 70, datatype);
  put<std::int16_t>(bytes, 72, 8 * sizeof(T));

  const Eigen::Matrix3d ras_axes = Eigen::Vector3d(-1, -1, 1).asDiagonal() * g.direction;
  const Eigen::Vector3d ras_origin = Eigen::Vector3d(-1, -1, 1).asDiagonal() * g.origin;
  // qform: a rotation and qfac = -1 when the axes are left-handed (the third column flips).
  const double qfac = ras_axes.determinant() < 0 ? -1.0 : 1.0;
  Eigen::Matrix3d rotation = ras_axes;
  rotation.col(2) *= qfac;
  put<float>(bytes, 76, static_cast<float>(qfac));
  for (int a = 0; a < 3; ++a) put<float>(bytes, 80 + 4 * a, static_cast<float>(g.spacing[a]));
  put<float>(bytes, 108, static_cast<float>(offset));
  put<float>(bytes, 112, 1.0f);  // scl_slope
  put<float>(bytes, 116, 0.0f);  // scl_inter
  bytes[123] = 2;                // xyzt_units: mm
  std::strncpy(reinterpret_cast<char*>(bytes.data()) + 148, description.c_str(), 79);
  put<std::int16_t>(bytes, 252, 2);  // qform_code: aligned anatomical
  put<std::int16_t>(bytes, 254, 2);  // sform_code
  const Eigen::Vector3d q = detail::nifti_rotation_to_quaternion(rotation);
  for (int a = 0; a < 3; ++a) {
    put<float>(bytes, 256 + 4 * a, static_cast<float>(q[a]));
    put<float>(bytes, 268 + 4 * a, static_cast<float>(ras_origin[a]));
  }
  const Eigen::Matrix3d A = ras_axes * g.spacing.asDiagonal();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      put<float>(bytes, 280 + 16 * r + 4 * c, static_cast<float>(A(r, c)));
    put<float>(bytes, 280 + 16 * r + 12, static_cast<float>(ras_origin[r]));
  }
  std::memcpy(bytes.data() + 344, "n+1\0", 4);
  std::memcpy(bytes.data() + offset, volume.data(), volume.size() * sizeof(T));

  const std::string name = path.filename().string();
  if (name.size() > 3 && name.compare(name.size() - 3, 3, ".gz") == 0) {
    const auto packed = gzip_compress(bytes.data(), bytes.size(), gzip_level);
    write_file_atomic(path, packed.data(), packed.size());
  } else {
    write_file_atomic(path, bytes.data(), bytes.size());
  }
}

}  // namespace gimm
