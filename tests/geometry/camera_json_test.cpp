// Camera <-> JSON: round trips (in memory and through text), the schema's derived fields, and
// errors that name the bad field and the source.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "gimm/io/camera_json.hpp"

using namespace gimm;
using Catch::Matchers::Contains;

namespace {

CArm oblique(ProjectionModel model) {
  CArm carm;
  carm.primary_deg = -33.3;
  carm.secondary_deg = 21.7;
  carm.sid_mm = 1100;
  carm.sod_mm = 780;
  carm.rows = 480;
  carm.cols = 640;
  carm.pixel_mm = 0.308;
  carm.isocenter = Eigen::Vector3d(1.25, -40.5, 12);
  carm.model = model;
  return carm;
}

ProjectionModel any_model() {
  return GENERATE(ProjectionModel::perspective, ProjectionModel::orthographic);
}

void require_same(const Camerad& a, const Camerad& b) {
  CHECK(a.model() == b.model());
  CHECK(a.rows() == b.rows());
  CHECK(a.cols() == b.cols());
  CHECK(a.K() == b.K());
  CHECK(a.R() == b.R());
  CHECK(a.t() == b.t());
}

}  // namespace

TEST_CASE("Camera JSON round trips exactly", "[geometry][io][camera_json]") {
  const ProjectionModel model = any_model();
  const CArm carm = oblique(model);
  const Camerad camera = carm.camera();
  require_same(camera_from_json(to_json(camera)), camera);
  // Through text: doubles are written with round-trip precision.
  require_same(camera_from_json(nlohmann::json::parse(to_json(camera).dump())), camera);
  require_same(camera_from_json(nlohmann::json::parse(to_json(carm).dump(2))), camera);
}

TEST_CASE("Camera JSON fields follow the schema", "[geometry][io][camera_json]") {
  const ProjectionModel model = any_model();
  const CArm carm = oblique(model);
  const Camerad camera = carm.camera();
  const nlohmann::json j = to_json(carm);
  CHECK(j["model"] == to_string(model));
  CHECK(j["image_size"]["rows"] == 480);
  CHECK(j["image_size"]["cols"] == 640);
  REQUIRE(j["K"].size() == 3);
  CHECK(j["K"][1][1].get<double>() == camera.K()(1, 1));  // row-major: K[row][col]
  CHECK(j["K"][0][2].get<double>() == camera.K()(0, 2));
  CHECK(j["R"][2][0].get<double>() == camera.R()(2, 0));
  CHECK(j["t"][1].get<double>() == camera.t()(1));
  REQUIRE(j["P"].size() == 3);
  REQUIRE(j["P"][0].size() == 4);
  CHECK(j["P"][1][3].get<double>() == camera.P()(1, 3));
  for (int a = 0; a < 3; ++a) {
    CHECK(j["center"][a].get<double>() == camera.center()(a));
    CHECK(j["principal_axis"][a].get<double>() == camera.principal_axis()(a));
    CHECK(j["isocenter"][a].get<double>() == carm.isocenter(a));
  }
  CHECK(j["primary_deg"] == -33.3);
  CHECK(j["secondary_deg"] == 21.7);
  CHECK(j["sid_mm"] == 1100.0);
  CHECK(j["sod_mm"] == 780.0);
  CHECK(j["pixel_mm"] == 0.308);
  CHECK(j["principal_point"][0].get<double>() == 319.5);
  CHECK(j["principal_point"][1].get<double>() == 239.5);
  // A plain camera has no C-arm fields.
  const nlohmann::json plain = to_json(camera);
  CHECK_FALSE(plain.contains("primary_deg"));
  CHECK_FALSE(plain.contains("isocenter"));
  // P is optional on read.
  nlohmann::json no_p = plain;
  no_p.erase("P");
  require_same(camera_from_json(no_p), camera);
}

TEST_CASE("Camera JSON errors name the field and the source", "[geometry][io][camera_json]") {
  const nlohmann::json good = to_json(oblique(ProjectionModel::perspective).camera());
  const std::string where = "views/pair_007.json";
  auto fails_with = [&](const nlohmann::json& j, const std::string& text) {
    CAPTURE(text);
    CHECK_THROWS_WITH(camera_from_json(j, where), Contains(text) && Contains(where));
  };
  fails_with(nlohmann::json::array(), "JSON object");
  nlohmann::json j = good;
  j.erase("model");
  fails_with(j, "'model'");
  j = good;
  j["model"] = "fisheye";
  fails_with(j, "'fisheye'");
  j = good;
  j["image_size"]["rows"] = 12.5;
  fails_with(j, "image_size");
  j = good;
  j.erase("image_size");
  fails_with(j, "image_size");
  j = good;
  j.erase("K");
  fails_with(j, "missing field 'K'");
  j = good;
  j["R"][1] = {0, 1};
  fails_with(j, "field 'R' row 1");
  j = good;
  j["t"] = {1, 2};
  fails_with(j, "field 't'");
  j = good;
  j["t"][0] = "zero";
  fails_with(j, "non-number");
  j = good;
  j["R"][0][0] = 2.0;  // not a rotation
  fails_with(j, "rotation");
  j = good;
  j["K"][1][0] = 0.5;  // not upper triangular
  fails_with(j, "upper triangular");
  j = good;
  j["image_size"]["cols"] = 0;
  fails_with(j, "480 x 0");
  // Past int: refused with the value, not wrapped (4294967360 read as int is 64).
  j = good;
  j["image_size"]["rows"] = 4294967360ull;
  fails_with(j, "rows is out of range: 4294967360");
  j = good;
  j["image_size"]["cols"] = -4294967296ll;
  fails_with(j, "cols is out of range: -4294967296");
  j = good;
  j["P"][0][3] = j["P"][0][3].get<double>() + 1.0;
  fails_with(j, "'P' disagrees");
  CHECK_THROWS_AS(camera_from_json(j), Error);
}
