// The package test of both recipes (CMakeLists.txt): one cheap use of each component built.
// Compile time counts (package_recipes builds this once per feature set): only the headers used
// are included, not the umbrella headers, and nothing instantiates gimm's fundamental matrix or
// triangulation (slow Eigen decompositions). io is checked through PNG alone: that links zlib and
// libpng, and png.hpp compiles nlohmann_json in; a JSON round trip would add seconds.
#include <gimm/geometry/carm.hpp>
#include <gimm/version.hpp>
#include <iostream>
#include <string>
#if GIMM_TP_IO
#include <gimm/io/png.hpp>
#endif
#if GIMM_TP_EMBREE
#include <gimm/render/vessel_mesh_projector.hpp>
#endif
#if GIMM_TP_DICOM
#include <gimm/io/dicom.hpp>
#endif

namespace {
int failures = 0;
void check(bool ok, const char* what) {
  std::cout << (ok ? "ok: " : "FAILED: ") << what << "\n";
  failures += ok ? 0 : 1;
}
}  // namespace

int main(int argc, char** argv) {
  const std::string dir = argc > 1 ? argv[1] : ".";  // for the files io and dicom write
  gimm::CArm carm;
  carm.primary_deg = 30;
  carm.secondary_deg = -20;
  carm.rows = carm.cols = 64;
  const gimm::Camerad camera = carm.camera();
  // core: the isocentre is imaged at the detector centre.
  const auto iso = camera.project(carm.isocenter);
  check(iso.in_front && (iso.uv - Eigen::Vector2d(31.5, 31.5)).norm() < 1e-9,
        "core: C-arm projection");
#if GIMM_TP_IO
  gimm::Image<std::uint8_t> png(4, 5, 0);
  png(2, 3) = 200;
  gimm::write_png(dir + "/test_package.png", png);
  const auto png_back = gimm::read_png8(dir + "/test_package.png");
  check(png_back.rows() == 4 && png_back.cols() == 5 && png_back(2, 3) == 200,
        "io: PNG round trip");
#endif
#if GIMM_TP_EMBREE
  // A 10 mm cube: on each face the corners walk counter-clockwise seen from the axis' plus
  // side ((u, w, axis) is right-handed), reversed on the minus side, so every face faces out.
  gimm::TriangleMesh cube;
  for (int v = 0; v < 8; ++v)
    cube.vertices.emplace_back(10.0f * (v & 1), 10.0f * ((v >> 1) & 1), 10.0f * ((v >> 2) & 1));
  const int walk[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int axis = 0; axis < 3; ++axis)
    for (std::uint32_t side = 0; side < 2; ++side) {
      std::uint32_t c[4];
      for (int k = 0; k < 4; ++k)
        c[k] = side << axis | walk[k][0] << (axis + 1) % 3 | walk[k][1] << (axis + 2) % 3;
      if (side == 1) {
        cube.triangles.push_back({c[0], c[1], c[2]});
        cube.triangles.push_back({c[0], c[2], c[3]});
      } else {
        cube.triangles.push_back({c[0], c[2], c[1]});
        cube.triangles.push_back({c[0], c[3], c[2]});
      }
    }
  const gimm::VesselMeshProjector projector(cube);
  const auto hit = projector.trace({Eigen::Vector3d(2, 3, -20), Eigen::Vector3d(0, 0, 1)});
  check(cube.is_closed() && std::abs(cube.enclosed_volume() - 1000) < 1e-6 &&
            std::abs(hit.chord_mm - 10) < 1e-3 && std::abs(hit.first_hit_mm - 20) < 1e-3 &&
            hit.passages == 1,
        "embree: chord through a cube");
#endif
#if GIMM_TP_DICOM
  gimm::Image<float> frame(64, 64);
  for (int r = 0; r < 64; ++r)
    for (int c = 0; c < 64; ++c) frame(r, c) = float(r + c) / 128.0f;
  gimm::write_xa_dicom(dir + "/test_package.dcm", frame, carm);
  const gimm::XaFrame xa = gimm::read_xa_dicom(dir + "/test_package.dcm");
  check((xa.carm.camera().P() - camera.P()).cwiseAbs().maxCoeff() < 1e-6,
        "dicom: XA file round trip");
#endif
  std::cout << "gimm " << GIMM_VERSION_STRING << " test_package: " << failures << " failure(s)\n";
  return failures == 0 ? 0 : 1;
}
