#pragma once
// The fixtures of tests/data/volumes (see README.md there): one 5x4x3 int16 volume written as
// NIfTI by nibabel and as NRRD and MetaImage by plastimatch, the geometry and values its
// generator wrote (computed here without any reader), and helpers for hand-written headers.
#include <Eigen/Geometry>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/io/files.hpp"

namespace fixtures {

namespace fs = std::filesystem;

inline fs::path dir() {
  return fs::path(GIMM_SOURCE_DIR) / "tests" / "data" / "volumes";
}

inline fs::path tmp(const std::string& name) {
  const fs::path d = fs::path(GIMM_TEST_TMP) / "volumes";
  fs::create_directories(d);
  return d / name;
}

/// make_fixtures.sh's grid in LPS: its RAS affine (30 degrees about (1, 2, 3), spacing 0.75,
/// 0.5, 1.25 mm, origin (12.5, -30.25, 101)) with x and y negated.
inline gimm::VolumeGeometry expected_geometry() {
  gimm::VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.75, 0.5, 1.25};
  const Eigen::Matrix3d ras =
      Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d(1, 2, 3).normalized())
          .toRotationMatrix();
  g.direction = Eigen::Vector3d(-1, -1, 1).asDiagonal() * ras;
  g.origin = {-12.5, 30.25, 101.0};
  return g;
}

inline double expected_value(std::size_t n) {
  const std::size_t i = n % 5, j = (n / 5) % 4, k = n / 20;
  return double(i + 10 * j + 100 * k) * 7 - 1000;
}

/// "" when `v` holds the fixture's values on its grid (spacing, origin, direction to 1e-6),
/// else what differs.
template <class T>
std::string fixture_difference(const gimm::Volume<T>& v) {
  const gimm::VolumeGeometry g = expected_geometry();
  if (v.dims() != g.dims) return "dims differ";
  for (std::size_t n = 0; n < v.size(); ++n)
    if (double(v.data()[n]) != expected_value(n))
      return "voxel " + std::to_string(n) + " is " + std::to_string(double(v.data()[n])) +
             ", expected " + std::to_string(expected_value(n));
  std::ostringstream out;
  if ((v.spacing() - g.spacing).cwiseAbs().maxCoeff() > 1e-6)
    out << "spacing " << v.spacing().transpose() << " vs " << g.spacing.transpose();
  if ((v.origin() - g.origin).cwiseAbs().maxCoeff() > 1e-6)
    out << "origin " << v.origin().transpose() << " vs " << g.origin.transpose();
  if ((v.direction() - g.direction).cwiseAbs().maxCoeff() > 1e-6)
    out << "direction\n" << v.direction() << "\nvs\n" << g.direction;
  return out.str();
}

/// The fixture's voxels as little-endian int16 (what plastimatch wrote next to ct_nhdr.nhdr).
inline std::vector<unsigned char> raw_int16() {
  return gimm::read_file_bytes(dir() / "ct_nhdr.raw");
}

/// `value(n)` for the 60 voxels stored as `Stored` in the given byte order (default: the
/// fixture's values).
template <class Stored>
std::vector<unsigned char> stored_bytes(
    bool big_endian, const std::function<double(std::size_t)>& value = expected_value) {
  std::vector<unsigned char> out;
  for (std::size_t n = 0; n < 60; ++n) {
    const Stored v = static_cast<Stored>(value(n));
    unsigned char b[sizeof(Stored)];
    std::memcpy(b, &v, sizeof(Stored));
    if (big_endian) std::reverse(b, b + sizeof(Stored));
    out.insert(out.end(), b, b + sizeof(Stored));
  }
  return out;
}

inline std::vector<unsigned char> swapped16(std::vector<unsigned char> bytes) {
  for (std::size_t n = 0; n + 1 < bytes.size(); n += 2) std::swap(bytes[n], bytes[n + 1]);
  return bytes;
}

inline void write_bytes(const fs::path& p, const std::vector<unsigned char>& bytes) {
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

inline void write_text(const fs::path& p, const std::string& text,
                       const std::vector<unsigned char>& data = {}) {
  std::vector<unsigned char> bytes(text.begin(), text.end());
  bytes.insert(bytes.end(), data.begin(), data.end());
  write_bytes(p, bytes);
}

inline std::string read_text(const fs::path& p) {
  const auto bytes = gimm::read_file_bytes(p);
  return std::string(bytes.begin(), bytes.end());
}

/// `text` with the first `from` replaced by `to` (which must be there).
inline std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

/// "(x,y,z)" with every digit a double has.
inline std::string vec(const Eigen::Vector3d& v) {
  char b[160];
  std::snprintf(b, sizeof b, "(%.17g,%.17g,%.17g)", v.x(), v.y(), v.z());
  return b;
}

/// The message of the gimm::FormatError that `read` throws; fails the test if it throws none
/// or another kind. Every message must name `file`.
inline std::string format_error(const std::function<void()>& read, const fs::path& file) {
  try {
    read();
  } catch (const gimm::FormatError& e) {
    const std::string message = e.what();
    INFO(message);
    CHECK(message.find(file.string()) != std::string::npos);
    return message;
  } catch (const std::exception& e) {
    FAIL("expected a gimm::FormatError, got: " << e.what());
  }
  FAIL("no error reading '" << file.string() << "'");
  return {};
}

}  // namespace fixtures
