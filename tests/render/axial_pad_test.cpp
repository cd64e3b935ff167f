// The patient beyond the scan's axial coverage (render/axial_pad.hpp): the padded volume, and
// the two thick slabs that integrate exactly like it.
#include <catch2/catch.hpp>
#include <cmath>

#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/padded_attenuation.hpp"

using namespace gimm;

TEST_CASE("Axial padding: copies of the edge slices, the world grid kept", "[render][pad]") {
  for (const bool flipped : {false, true}) {
    VolumeGeometry g;
    g.dims = {3, 4, 5};
    g.spacing = Eigen::Vector3d(0.7, 0.8, 2.0);
    g.origin = Eigen::Vector3d(1, 2, 3);
    // Stored with the slices along j (a sagittal-first file), z pointing down when flipped.
    g.direction << 1, 0, 0, 0, 0, 1, 0, flipped ? -1 : 1, 0;
    Volume<float> v(g);
    for (std::size_t n = 0; n < v.size(); ++n) v.data()[n] = static_cast<float>(n);
    REQUIRE(axial_axis(g) == 1);
    const Volume<float> p = pad_axial(v, 1.7);  // ceil(1.7 / 0.8) = 3 slices each side
    REQUIRE(p.ny() == 4 + 6);
    REQUIRE(p.nx() == 3);
    REQUIRE(p.nz() == 5);
    for (int k = 0; k < 5; ++k)
      for (int j = 0; j < p.ny(); ++j)
        for (int i = 0; i < 3; ++i) {
          REQUIRE(p(i, j, k) == v(i, std::clamp(j - 3, 0, 3), k));
          if (j >= 3 && j < 7)  // the original voxels keep their world position
            REQUIRE((p.index_to_world(Eigen::Vector3d(i, j, k)) -
                     v.index_to_world(Eigen::Vector3d(i, j - 3, k)))
                        .norm() < 1e-12);
        }
    // The slabs: one voxel of 1.7 mm each, adjoining the first and last slices.
    const AxialPads<float> pads = axial_pads(v, 1.7);
    REQUIRE(pads.below.ny() == 1);
    REQUIRE(pads.above.ny() == 1);
    CHECK(pads.below(2, 0, 4) == v(2, 0, 4));
    CHECK(pads.above(2, 0, 4) == v(2, 3, 4));
    const double gap_below = (v.index_to_world(Eigen::Vector3d(0, 0, 0)) -
                              pads.below.index_to_world(Eigen::Vector3d(0, 0, 0)))
                                 .norm();
    CHECK(gap_below == Approx(0.5 * 0.8 + 0.5 * 1.7));
  }
  VolumeGeometry g;
  g.dims = {2, 2, 2};
  const Volume<float> v(g, 1.0f);
  CHECK(pad_axial(v, 0.0).nz() == 2);
  CHECK(axial_pads(v, 0.0).empty());
  CHECK_THROWS_WITH(pad_axial(v, -1.0), Catch::Contains("-1"));
  CHECK_THROWS_WITH(axial_pads(v, std::nan("")), Catch::Contains("nan"));
}

TEST_CASE("Axial padding: rays above and below the scan meet tissue, not air",
          "[render][pad][drr]") {
  // A 40 mm scan of uniform tissue seen AP by a detector 3.6x taller: without padding the top
  // and bottom rows integrate nothing (white after normalisation); with it they see the same
  // tissue as the rows through the scan, because the padding repeats it.
  VolumeGeometry g;
  g.dims = {40, 40, 20};
  g.spacing = Eigen::Vector3d(1, 1, 2);
  g.origin = Eigen::Vector3d(-19.5, -19.5, -19);
  const Volume<float> mu(g, 0.02f);
  CArm carm;
  carm.rows = 64;
  carm.cols = 16;
  carm.pixel_mm = 3.0;  // 192 mm tall at the detector, 144 mm at the isocentre
  carm.model = ProjectionModel::orthographic;
  const Camerad camera = carm.camera();
  const Image<float> air = render_line_integrals(mu, camera);
  const Image<float> padded = render_line_integrals(mu, axial_pads(mu, 60.0), camera);
  const int middle = 32, top = 2;
  CHECK(air(top, 8) == 0.0f);
  CHECK(air(middle, 8) == Approx(0.8f).epsilon(1e-5));  // 40 mm of 0.02 / mm
  CHECK(padded(top, 8) == Approx(air(middle, 8)).epsilon(1e-5));
  CHECK(padded(middle, 8) == Approx(air(middle, 8)).epsilon(1e-6));
}

TEST_CASE("Axial padding: the thick slabs integrate like the padded volume", "[render][pad][drr]") {
  // Random values (edge slices included), tilted perspective and orthographic views, both
  // projectors' exact path: the fast form (two slabs) against the reference (many copies).
  VolumeGeometry g;
  g.dims = {24, 20, 10};
  g.spacing = Eigen::Vector3d(1.2, 1.2, 2.5);
  g.origin = Eigen::Vector3d(-14, -11, -12);
  g.direction = Eigen::Vector3d(-1, -1, 1).asDiagonal();  // stored RAS first
  Volume<float> mu(g);
  Rng rng(8);
  for (auto& x : mu.storage()) x = static_cast<float>(rng.uniform(0.0, 0.03));
  const double pad_mm = 40.0;  // 16 whole slices: pad_axial pads exactly as much
  const Volume<float> reference = pad_axial(mu, pad_mm);
  const AxialPads<float> pads = axial_pads(mu, pad_mm);
  for (const auto model : {ProjectionModel::perspective, ProjectionModel::orthographic})
    for (const auto& [primary, secondary] : {std::pair{0.0, 0.0}, {35.0, 25.0}, {-40.0, -30.0}}) {
      CArm carm;
      carm.rows = carm.cols = 96;
      carm.pixel_mm = 1.6;
      carm.model = model;
      carm.primary_deg = primary;
      carm.secondary_deg = secondary;
      const Camerad camera = carm.camera();
      const Image<float> slow = render_line_integrals(reference, camera);
      const Image<float> fast = render_line_integrals(mu, pads, camera);
      const Image<float> air = render_line_integrals(mu, camera);
      int only_pads = 0;  // pixels whose ray meets the pads and not the scan
      for (int v = 0; v < camera.rows(); ++v)
        for (int u = 0; u < camera.cols(); ++u) {
          REQUIRE(fast(v, u) == Approx(slow(v, u)).epsilon(2e-5).margin(1e-6));
          only_pads += air(v, u) == 0 && slow(v, u) > 0;
        }
      CHECK(only_pads > 0);
    }
}

TEST_CASE("Axial padding: a ray in the plane where scan and pad meet is counted once",
          "[render][pad][drr]") {
  // 0.75 mm voxels centred on the origin and an orthographic AP view with 0.75 mm pixels at the
  // isocentre (1 mm at the detector, magnification 4/3) and an odd row count: rows 4 pixels
  // either side of the centre lie exactly in the scan's axial faces, the planes it shares with
  // its pads. The closed grid counted those rows in the scan and in a pad (twice the tissue);
  // the half-open rule counts them once, like the thin copies of pad_axial, where the same
  // plane is an interior face.
  VolumeGeometry g;
  g.dims = {8, 8, 8};
  g.spacing = Eigen::Vector3d::Constant(0.75);
  g.origin = Eigen::Vector3d::Constant(-3.5 * 0.75);
  Volume<float> mu(g);
  Rng rng(31);
  for (auto& x : mu.storage()) x = static_cast<float>(rng.uniform(0.01, 0.03));
  CArm carm;
  carm.rows = carm.cols = 17;
  carm.pixel_mm = 1.0;
  carm.model = ProjectionModel::orthographic;
  const Camerad camera = carm.camera();
  const Image<float> slow = render_line_integrals(pad_axial(mu, 3.0), camera);  // 4 slices
  const Image<float> fast = render_line_integrals(mu, axial_pads(mu, 3.0), camera);
  int on_shared_plane = 0;
  for (int v = 0; v < camera.rows(); ++v) {
    const IndexRay r = to_index_ray(g, camera.ray(8.0, double(v)));
    on_shared_plane += r.direction.z == 0.0 && (r.origin.z == -0.5 || r.origin.z == 7.5);
    for (int u = 0; u < camera.cols(); ++u) REQUIRE(fast(v, u) == Approx(slow(v, u)).epsilon(1e-6));
  }
  CHECK(on_shared_plane == 2);  // the case is really exercised (exact arithmetic above)
}

TEST_CASE("Axial padding: the trilinear projector gets the padded volume, not thick slabs",
          "[render][pad][drr][trilinear]") {
  // A uniform volume: the rows through the pads must see the tissue per millimetre they see in
  // the scan, with either projector (a thick slab's trilinear field fades over half its 60 mm).
  VolumeGeometry g;
  g.dims = {20, 20, 10};
  g.spacing = Eigen::Vector3d(2, 2, 4);
  g.origin = Eigen::Vector3d(-19, -19, -18);
  const Volume<float> hu(g, 40.0f);
  ContrastRecipe recipe;
  recipe.preset = ContrastPreset::none;
  CArm carm;
  carm.rows = 64;
  carm.cols = 8;
  carm.pixel_mm = 3.0;
  carm.model = ProjectionModel::orthographic;
  const Camerad camera = carm.camera();
  for (const Projector projector : {Projector::siddon, Projector::trilinear}) {
    const PaddedAttenuation p =
        padded_attenuation<std::uint8_t>(hu, nullptr, recipe, 60.0, projector);
    CHECK(p.pads.empty() == (projector == Projector::trilinear));
    DrrOptions options;
    options.projector = projector;
    const Image<float> image = render_line_integrals(p.mu, p.pads, camera, options);
    const double expected = 40.0 * hu_to_mu(40.0);  // 40 mm through the tissue, AP
    for (const int v : {2, 10, 32, 54, 61}) CHECK(image(v, 4) == Approx(expected).epsilon(0.03));
  }
  DrrOptions trilinear;
  trilinear.projector = Projector::trilinear;
  const Volume<float> mu(g, 0.02f);
  CHECK_THROWS_WITH(render_line_integrals(mu, axial_pads(mu, 60.0), camera, trilinear),
                    Catch::Contains("siddon projector only"));
}

TEST_CASE("Axial padding: the injected lumen does not carry on into the pads",
          "[render][pad][attenuation]") {
  // A coronary cut by the scan's last slice: the slices beyond it are tissue, not contrast.
  VolumeGeometry g;
  g.dims = {6, 6, 4};
  Volume<float> hu(g, 40.0f);
  Volume<std::uint8_t> lumen(g, 0);
  for (int k = 0; k < 4; ++k) {
    lumen(2, 2, k) = 1;  // through the whole scan, both edge slices included
    hu(2, 2, k) = 400.0f;
  }
  for (const auto preset : {ContrastPreset::angiography, ContrastPreset::reference}) {
    ContrastRecipe recipe;
    recipe.preset = preset;
    const Volume<std::uint8_t>* none = nullptr;
    const Volume<float> plain = make_attenuation(hu, none, recipe);
    const Volume<float> injected = make_attenuation(hu, &lumen, recipe);
    REQUIRE(injected(2, 2, 3) > 2 * plain(2, 2, 3));
    const PaddedAttenuation s = padded_attenuation(hu, &lumen, recipe, 5.0, Projector::siddon);
    CHECK(s.mu(2, 2, 3) == injected(2, 2, 3));
    CHECK(s.pads.above(2, 2, 0) == plain(2, 2, 3));
    CHECK(s.pads.below(2, 2, 0) == plain(2, 2, 0));
    CHECK(s.pads.above(0, 0, 0) == plain(0, 0, 3));
    const PaddedAttenuation t = padded_attenuation(hu, &lumen, recipe, 5.0, Projector::trilinear);
    REQUIRE(t.mu.nz() == 4 + 2 * 5);
    CHECK(t.mu(2, 2, 5 + 3) == injected(2, 2, 3));
    CHECK(t.mu(2, 2, 13) == plain(2, 2, 3));
    CHECK(t.mu(2, 2, 0) == plain(2, 2, 0));
  }
}

TEST_CASE("Axial padding: padding too thin to be a voxel is refused", "[render][pad]") {
  VolumeGeometry g;
  g.dims = {2, 2, 2};
  const Volume<float> v(g, 1.0f);
  CHECK_THROWS_WITH(axial_pads(v, 1e-320), Catch::Contains("0 or in [0.01, 1000] mm"));
  CHECK_THROWS_WITH(pad_axial(v, 0.001), Catch::Contains("0.001"));
  CHECK_NOTHROW(axial_pads(v, kMinPadMm));
}
