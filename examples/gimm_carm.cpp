// gimm-carm: prints C-arm cameras as JSON, the 11 routine views, or F between two cameras.
// From an X-ray angiography DICOM file: gimm-carm --dicom F.dcm [--reference R.dcm] [--explain]
// (io/dicom.hpp): the camera of its geometry tags; --reference makes R's table position the one
// of the isocentre (--isocenter, default 0); --explain lists every tag read and every one missing.
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli_common.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/dicom.hpp"
#include "gimm/io/files.hpp"
#include "gimm/labels/views.hpp"

int main(int argc, char** argv) {
  CLI::App app{"gimm-carm: C-arm cameras (P = K[R|t]) as JSON", "gimm-carm"};
  gimm::CArm carm;
  gimm::cli::CArmFlags flags;
  flags.add(app, carm, false);
  bool routine = false;
  std::vector<std::string> pair;
  app.add_flag("--routine", routine, "print the 11 routine views at their range centres");
  app.add_option("--pair", pair, "two camera JSON files: print F (x_b^T F x_a = 0)")
      ->expected(2)
      ->check(CLI::ExistingFile);
  std::string dicom, reference;
  bool explain = false;
  app.add_option("--dicom", dicom, "XA/XRF DICOM file: print the camera of its geometry tags")
      ->check(CLI::ExistingFile);
  app.add_option("--reference", reference,
                 "--dicom: the DICOM view whose table position the isocentre is given at")
      ->check(CLI::ExistingFile);
  app.add_flag("--explain", explain,
               "--dicom: list every tag read (value, use) and every one missing, not the JSON");
  gimm::cli::option_flags() = {{"DicomReadOptions::pitch_mm", "--pixel"}};
  return gimm::cli::run(app, argc, argv, [&] {
    if (!dicom.empty()) {
      for (const char* flag : {"--primary", "--secondary", "--sid", "--sod", "--rows", "--cols",
                               "--model", "--routine", "--pair", "--principal-point"})
        GIMM_USAGE_CHECK(app.count(flag) == 0, "--dicom takes its geometry from the file; "
                                                   << flag << " cannot be given");
      gimm::DicomReadOptions read;
      if (app.count("--pixel")) read.pitch_mm = carm.pixel_mm;
      gimm::XaFrame frame = gimm::read_xa_dicom(dicom, read);
      if (!reference.empty())
        gimm::set_table_reference(frame, gimm::read_xa_dicom(reference, read));
      flags.finish(frame.carm);  // --isocenter only (the rest was refused above)
      for (const auto& w : frame.warnings) std::cerr << "gimm-carm: warning: " << w << "\n";
      if (explain) {
        std::cout << gimm::explain(frame);
        return 0;
      }
      nlohmann::json j = gimm::to_json(frame.carm);
      j["dicom"] = {{"file", dicom},
                    {"frame", frame.frame},
                    {"frames", frame.frames},
                    {"table_source", frame.table_source}};
      std::cout << j.dump(2) << "\n";
      return 0;
    }
    GIMM_USAGE_CHECK(reference.empty() && !explain, "--reference and --explain go with --dicom");
    if (!pair.empty()) {
      for (const char* flag :
           {"--primary", "--secondary", "--sid", "--sod", "--rows", "--cols", "--pixel", "--model",
            "--routine", "--isocenter", "--principal-point", "--table"})
        GIMM_USAGE_CHECK(app.count(flag) == 0, "--pair reads both cameras from their files; "
                                                   << flag << " cannot be given");
      const auto a = gimm::camera_from_json(gimm::read_json_file(pair[0]), pair[0]);
      const auto b = gimm::camera_from_json(gimm::read_json_file(pair[1]), pair[1]);
      nlohmann::json out;
      try {
        out["F"] = gimm::matrix_to_json(gimm::fundamental_from_cameras(a, b));
      } catch (const gimm::Error& e) {  // name the two files
        throw gimm::Error(std::string(e.what()) + " (--pair " + pair[0] + " " + pair[1] + ")");
      }
      out["convention"] = "x_b^T F x_a = 0, pixels, A = " + pair[0] + ", B = " + pair[1];
      std::cout << out.dump(2) << "\n";
      return 0;
    }
    GIMM_USAGE_CHECK(routine || (app.count("--primary") && app.count("--secondary")),
                     "gimm-carm: give --primary and --secondary, or --routine, or --pair");
    GIMM_USAGE_CHECK(!routine || (app.count("--primary") == 0 && app.count("--secondary") == 0),
                     "--routine sets every view's angles; --primary/--secondary cannot be given");
    flags.finish(carm);
    if (!routine) {
      std::cout << gimm::to_json(carm).dump(2) << "\n";
      return 0;
    }
    nlohmann::json views = nlohmann::json::array();
    for (const auto& view : gimm::routine_views()) {
      gimm::CArm v = carm;
      v.primary_deg = view.primary.centre();
      v.secondary_deg = view.secondary.centre();
      nlohmann::json j = gimm::to_json(v);
      j["view_class"] = view.id;
      j["view_name"] = view.name;
      j["system"] = gimm::to_string(view.system);
      views.push_back(j);
    }
    std::cout << views.dump(2) << "\n";
    return 0;
  });
}
