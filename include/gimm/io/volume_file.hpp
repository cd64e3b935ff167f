#pragma once
/// Volumes in any format gimm reads, chosen by the file name: NIfTI-1 (.nii, .nii.gz), NRRD
/// (.nrrd, .nhdr) and MetaImage (.mha, .mhd), all into the LPS world (see each reader).
/// A folder (a DICOM series) or another extension is an error that names the formats gimm
/// reads and how to convert.
#include <filesystem>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/metaimage.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/nrrd.hpp"

namespace gimm {

enum class VolumeFormat { nifti, nrrd, metaimage };

/// The file-name endings gimm reads, longest first (".nii.gz" before ".nii").
inline const std::vector<std::string>& volume_extensions() {
  static const std::vector<std::string> extensions = {".nii.gz", ".nii", ".nrrd",
                                                      ".nhdr",   ".mha", ".mhd"};
  return extensions;
}

/// The ending of `path` among volume_extensions(), or empty.
inline std::string volume_extension(const std::filesystem::path& path) {
  const std::string name = path.filename().string();
  for (const auto& ext : volume_extensions())
    if (name.size() > ext.size() && name.compare(name.size() - ext.size(), ext.size(), ext) == 0)
      return ext;
  return {};
}

inline std::optional<VolumeFormat> volume_format(const std::filesystem::path& path) {
  const std::string ext = volume_extension(path);
  if (ext == ".nii" || ext == ".nii.gz") return VolumeFormat::nifti;
  if (ext == ".nrrd" || ext == ".nhdr") return VolumeFormat::nrrd;
  if (ext == ".mha" || ext == ".mhd") return VolumeFormat::metaimage;
  return std::nullopt;
}

/// What gimm reads, for error messages.
inline std::string volume_formats_help() {
  return "gimm reads NIfTI-1 (.nii, .nii.gz), NRRD (.nrrd, .nhdr) and MetaImage (.mha, .mhd); "
         "convert a DICOM series with e.g. 'dcm2niix -z y -o OUT DIR' or 'plastimatch convert "
         "--input DIR --output-img ct.nii.gz'";
}

template <class T>
Volume<T> read_volume_as(const std::filesystem::path& path);

/// The volume in `path` (format by the file name). Running out of memory for its voxels is an
/// error naming the file, not a bare std::bad_alloc.
template <class T>
Volume<T> read_volume(const std::filesystem::path& path) {
  try {
    return read_volume_as<T>(path);
  } catch (const std::bad_alloc&) {
    GIMM_FAIL("'" << path.string() << "': not enough memory to read its voxels as " << sizeof(T)
                  << "-byte values (its grid is larger than this process may "
                  << "allocate: a memory limit, or a header with the wrong sizes?)");
  }
}

template <class T>
Volume<T> read_volume_as(const std::filesystem::path& path) {
  GIMM_CHECK(!std::filesystem::is_directory(path),
             "'" << path.string() << "' is a folder, not a volume file: " << volume_formats_help());
  const auto format = volume_format(path);
  GIMM_CHECK(format, "'" << path.string() << "': unknown volume format (by its name); "
                         << volume_formats_help());
  switch (*format) {
    case VolumeFormat::nrrd:
      return read_nrrd<T>(path);
    case VolumeFormat::metaimage:
      return read_metaimage<T>(path);
    case VolumeFormat::nifti:
      break;
  }
  return read_nifti<T>(path);
}

/// The file a volume's voxels are read from: `path` itself, or a detached header's data file.
inline std::filesystem::path volume_data_file(const std::filesystem::path& path) {
  const auto format = volume_format(path);
  if (format == VolumeFormat::nrrd) return read_nrrd_header(path).data.file;
  if (format == VolumeFormat::metaimage) return read_metaimage_header(path).data.file;
  return path;
}

/// For the log: "'h.nhdr' takes its voxels from '/else/where.raw', outside its folder" when a
/// detached header's data file lies outside the header's folder (an absolute path, a "..", a
/// link), else "". The formats allow it and gimm reads it; the log says which file was read.
inline std::string detached_data_note(const std::filesystem::path& path) {
  const std::filesystem::path data = volume_data_file(path);
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : ".";
  if (data == path || path_is_within(data, folder)) return {};
  return "'" + path.string() + "' takes its voxels from '" + resolved_path(data).string() +
         "', outside its folder";
}

}  // namespace gimm
