// The dataset job's image-formation stage (DatasetOptions::form_angiogram, --formation): it adds
// <view>.formed.png, <view>.field.png and camera.json "formation", makes the lumen iodine (so the
// angiogram PNG and its window change), and nothing else: masks, points and pair labels are byte
// for byte those of a run without it.
#include <catch2/catch.hpp>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/pipeline/patient.hpp"
#include "pipeline_fixtures.hpp"

namespace fs = std::filesystem;
using namespace gimm;
using nlohmann::json;

namespace {

fs::path fresh_out(const std::string& name) {
  return gimm_test::fresh_pipeline_dir("formation", name, false);
}

/// Every file under `dir`, by its path relative to `dir`, with its bytes.
std::map<std::string, std::vector<unsigned char>> files_under(const fs::path& dir) {
  std::map<std::string, std::vector<unsigned char>> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file())
      out[fs::relative(e.path(), dir).generic_string()] = read_file_bytes(e.path());
  return out;
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

TEST_CASE("Formation stage: new files and an iodine lumen, labels unchanged",
          "[pipeline][formation]") {
  // Built twice rather than copied: GCC 12 warns (falsely) of an uninitialised
  // optional<Eigen::Vector2d> in DatasetOptions' copy.
  const auto options = [](bool formation) {
    DatasetOptions d;
    d.carm.rows = d.carm.cols = 96;
    d.carm.pixel_mm = 2.5;
    d.seed = 5;
    d.form_angiogram = formation;
    return d;
  };
  const DatasetOptions o = options(false), with = options(true);
  PatientSource src;
  src.id = "phantom-0000";
  src.phantom_seed = 11;

  const fs::path plain_out = fresh_out("plain"), formed_out = fresh_out("formed"),
                 again_out = fresh_out("again");
  generate_patient(src, o, plain_out);
  generate_patient(src, with, formed_out);
  generate_patient(src, with, again_out);

  const DatasetLayout plain_layout(plain_out), formed_layout(formed_out);
  const auto plain = files_under(plain_layout.patient_dir(src.id));
  const auto formed = files_under(formed_layout.patient_dir(src.id));
  REQUIRE(plain.size() > 10);

  int views = 0;
  for (const auto& [name, bytes] : plain) {
    INFO(name);
    REQUIRE(formed.count(name) == 1);
    if (ends_with(name, ".camera.json") || name == "done.json") {
      json a = json::parse(bytes.begin(), bytes.end());
      json b = json::parse(formed.at(name).begin(), formed.at(name).end());
      if (name == "done.json") {
        CHECK(b["run"]["parameters"].contains("formation"));
        CHECK_FALSE(a["run"]["parameters"].contains("formation"));
        b["run"]["parameters"].erase("formation");
      } else {
        ++views;
        REQUIRE(b.contains("formation"));
        const AngiogramFormation f = angiogram_formation_from_json(
            [&] {
              json r = b["formation"];
              r.erase("png");
              r.erase("iodine");
              r.erase("catheter");
              return r;
            }(),
            name);
        CHECK(f.scatter_to_primary >= 0.3);
        // The system's catheter, imaged or not, recorded with every view.
        REQUIRE(b["formation"].contains("catheter"));
        CHECK(b["formation"]["catheter"]["present"].is_boolean());
        // The system's injection, drawn from the iodine ranges: a lumen far denser than the
        // recipe's fixed 3000 HU (about 0.2 / mm against blood's 0.02 / mm).
        const IodineContrast iodine = iodine_contrast_from_json(
            [&] {
              json r = b["formation"]["iodine"];
              r.erase("lumen_hu");
              return r;
            }(),
            name);
        CHECK(iodine.iodine_mg_per_ml >= with.iodine_ranges.iodine_mg_per_ml.lo);
        CHECK(iodine.iodine_mg_per_ml <= with.iodine_ranges.iodine_mg_per_ml.hi);
        CHECK(b["formation"]["iodine"]["lumen_hu"].get<double>() == Approx(iodine.lumen_hu()));
        CHECK(iodine.lumen_hu() > 5000);
        b.erase("formation");
        a.erase("intensity_window");  // the lumen is denser: the image's range moved
        b.erase("intensity_window");
      }
      CHECK(a == b);
    } else if (ends_with(name, ".png") && !ends_with(name, ".mask.png")) {
      CHECK(bytes != formed.at(name));  // the angiogram: an iodine lumen now
    } else {
      CHECK(bytes == formed.at(name));  // masks, points, pair labels, centerlines
    }
  }
  REQUIRE(views > 0);
  // The new files: a formed image and a field mask per view, nothing else.
  std::set<std::string> extra;
  for (const auto& [name, bytes] : formed)
    if (!plain.count(name)) extra.insert(name);
  CHECK(extra.size() == 2 * static_cast<std::size_t>(views));
  for (const auto& name : extra)
    CHECK((ends_with(name, ".formed.png") || ends_with(name, ".field.png")));

  // A formed view: 8-bit, vessels darker than the exposed background; the field covers
  // the vessels' centre of the image.
  int compared = 0;
  for (const auto& name : extra) {
    if (!ends_with(name, ".formed.png")) continue;
    const std::string stem = name.substr(0, name.size() - std::string(".formed.png").size());
    const fs::path dir = formed_layout.patient_dir(src.id);
    const auto decoded = detail::read_png_any(dir / name);
    CHECK(decoded.bit_depth == 8);
    const Image<std::uint8_t> image = read_png8(dir / name);
    const Image<std::uint8_t> mask = read_png8(dir / (stem + ".mask.png"));
    const Image<std::uint8_t> field = read_png8(dir / (stem + ".field.png"));
    double vessel = 0, background = 0;
    int nv = 0, nb = 0;
    for (std::size_t p = 0; p < image.size(); ++p) {
      if (!field.data()[p]) continue;
      (mask.data()[p] ? vessel : background) += image.data()[p];
      ++(mask.data()[p] ? nv : nb);
    }
    INFO(name << ": vessel mean " << vessel / std::max(nv, 1) << ", background mean "
              << background / std::max(nb, 1));
    if (nv > 0 && nb > 0) {
      CHECK(vessel / nv < background / nb);
      ++compared;
    }
  }
  CHECK(compared > 0);
  // The same seed, the same formed bytes.
  CHECK(files_under(formed_layout.patient_dir(src.id)).size() ==
        files_under(DatasetLayout(again_out).patient_dir(src.id)).size());
  const auto again = files_under(DatasetLayout(again_out).patient_dir(src.id));
  for (const auto& name : extra) CHECK(again.at(name) == formed.at(name));
}

TEST_CASE("Formation stage: the guiding catheter darkens its own path and nothing else",
          "[pipeline][formation][catheter]") {
  const PatientVolumes patient = read_patient(phantom_sources(1, 4, PhantomSize::small)[0]);
  REQUIRE(patient.anatomy);
  DatasetOptions o;
  o.carm.rows = o.carm.cols = 256;
  o.carm.pixel_mm = 1.0;
  o.catheter_probability = 1;
  ViewFormationStage plain{o.formation_ranges, Rng(5), IodineContrast{}};
  ViewFormationStage with = plain;
  add_catheter(with, patient, CoronarySystem::LCA, o, "p");
  REQUIRE(with.catheter);
  CHECK(with.catheter_record["present"] == true);
  CHECK(with.catheter_mu_per_mm > 0.2);  // 350 mgI/mL over blood: about 0.36 mm^-1 at 55 keV
  // A bare view of the phantom's line integrals (a water slab is enough for the stage).
  CArm carm;  // o.carm's values (a copy of its empty optional warns with GCC 12 -O2)
  carm.rows = carm.cols = 256;
  carm.pixel_mm = 1.0;
  carm.primary_deg = 40;
  carm.secondary_deg = 20;
  carm.isocenter = vessel_isocenter(split_coronary_systems(patient.label).lca);
  RenderedView view;
  view.line_integrals = Image<float>(256, 256, 4.0f);
  json cj_plain, cj_with;
  const FormedAngiogram a = form_view(view, carm, plain, 0, cj_plain);
  const FormedAngiogram b = form_view(view, carm, with, 0, cj_with);
  CHECK(cj_plain["formation"]["catheter"]["present"] == false);
  CHECK(cj_with["formation"]["catheter"]["present"] == true);
  // In the line integrals: exactly its chord times its attenuation, nothing elsewhere.
  const Camerad camera = carm.camera();
  const VesselProjection cath = with.catheter->project(camera);
  const Image<float> added = with_catheter(view.line_integrals, with, camera);
  std::size_t on_path = 0, wrong = 0;
  for (std::size_t p = 0; p < added.size(); ++p) {
    const double expected = 4.0 + with.catheter_mu_per_mm * cath.chord_mm.data()[p];
    on_path += cath.chord_mm.data()[p] > 0.5f;
    wrong += std::abs(added.data()[p] - expected) > 1e-5;
  }
  CHECK(on_path > 100);
  CHECK(wrong == 0);
  CHECK(with_catheter(view.line_integrals, plain, camera).storage() ==
        view.line_integrals.storage());
  // And the formed view shows it: darker on its path than the same view without it.
  double along = 0, without = 0;
  std::size_t n = 0;
  for (std::size_t p = 0; p < a.display.size(); ++p)
    if (cath.chord_mm.data()[p] > 1.2f)
      along += b.display.data()[p], without += a.display.data()[p], ++n;
  REQUIRE(n > 50);
  INFO("mean display on the catheter " << along / n << ", without it " << without / n);
  CHECK(along / n < without / n - 0.05);
  // Without a phantom's anatomy (a CT) there is no catheter.
  PatientVolumes ct{patient.hu, patient.label, std::nullopt, std::nullopt};
  ViewFormationStage none = plain;
  add_catheter(none, ct, CoronarySystem::LCA, o, "ct");
  CHECK_FALSE(none.catheter);
  o.catheter_probability = 1.5;
  CHECK_THROWS_WITH(add_catheter(none, patient, CoronarySystem::LCA, o, "p"),
                    Catch::Contains("catheter_probability must be in [0, 1], got 1.5"));
}
