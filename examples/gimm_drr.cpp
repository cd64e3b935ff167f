// gimm-drr: renders a DRR (simulated angiogram) of a CT volume under one C-arm view.
//   gimm-drr --volume CT.nii.gz|.nrrd|.mha [--label L.nii.gz --system LCA|RCA]
//            [--recipe reference|angiography|none] --primary DEG --secondary DEG
//            [camera flags of gimm-carm] [--projector siddon|trilinear] [--step MM] --out PREFIX
// Writes PREFIX.png (16-bit Beer-Lambert intensity, min-max normalised per image),
// PREFIX.npy (float32 line integrals, (rows, cols)) and PREFIX.camera.json; with --dicom also
// PREFIX.dcm, the PNG's image as an XA file with the C-arm's geometry tags (io/dicom.hpp).
// --recipe none reads the volume as attenuation (mm^-1) instead of HU.
// Default isocentre (anatomy/isocenter.hpp, as the dataset's views): the centroid of the injected
// system's lumen voxels when --label is given, else the centre of the volume's grid.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <optional>
#include <vector>

#include "cli_common.hpp"
#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/isocenter.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/dicom.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/npy.hpp"
#include "gimm/io/png.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/labels/views.hpp"
#include "gimm/render/view_renderer.hpp"

int main(int argc, char** argv) {
  CLI::App app{"gimm-drr: a simulated angiogram of a CT volume under one C-arm view", "gimm-drr"};
  gimm::CArm carm;
  gimm::cli::CArmFlags flags;
  flags.add(app, carm, true);
  std::string volume_path, label_path, system_name, recipe_name = "angiography",
                                                    projector_name = "siddon", out_prefix;
  double step_mm = 0.0, pad_mm = gimm::kDefaultPadMm;
  bool quiet = false;
  // ExistingPath, not ExistingFile: a DICOM folder gets read_volume's advice on converting it.
  app.add_option("--volume", volume_path,
                 "CT volume (HU): NIfTI .nii/.nii.gz, NRRD .nrrd/.nhdr or MetaImage .mha/.mhd")
      ->required()
      ->check(CLI::ExistingPath);
  app.add_option("--label", label_path,
                 "coronary label (0/1), same formats, same grid as the volume")
      ->check(CLI::ExistingPath);
  app.add_option("--system", system_name, "injected system: LCA|RCA (with --label)")
      ->check(CLI::IsMember({"LCA", "RCA"}));
  app.add_option("--recipe", recipe_name, "contrast recipe: reference|angiography|none")
      ->check(CLI::IsMember({"reference", "angiography", "none"}))
      ->capture_default_str();
  app.add_option("--pad-mm", pad_mm,
                 "tissue beyond the scan's axial coverage, mm on each side (copies of the edge "
                 "slices; 0 = air, as the reference)")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  app.add_option("--projector", projector_name, "siddon (exact) | trilinear")
      ->check(CLI::IsMember({"siddon", "trilinear"}))
      ->capture_default_str();
  app.add_option("--step", step_mm, "trilinear step, mm (default: smallest voxel spacing)")
      ->check(gimm::cli::Positive);
  app.add_option("--out", out_prefix, "output prefix: PREFIX.png, PREFIX.npy, PREFIX.camera.json")
      ->required();
  app.add_flag("--quiet", quiet, "print nothing on success");
  bool dicom = false;
  app.add_flag("--dicom", dicom,
               "also write PREFIX.dcm: the image as X-ray angiography DICOM with its geometry");
  return gimm::cli::run(app, argc, argv, [&] {
    const auto t0 = std::chrono::steady_clock::now();
    GIMM_USAGE_CHECK(
        label_path.empty() == system_name.empty(),
        "gimm-drr: --label and --system go together (got "
            << (label_path.empty() ? "--system without --label" : "--label without --system")
            << ")");
    const std::filesystem::path out_dir = std::filesystem::path(out_prefix).parent_path();
    GIMM_USAGE_CHECK(out_dir.empty() || std::filesystem::is_directory(out_dir),
                     "gimm-drr: --out " << out_prefix << ": the folder '" << out_dir.string()
                                        << "' does not exist");
    std::vector<gimm::NamedPath> outputs;
    for (const char* ext : {".npy", ".png", ".camera.json", ".dcm"})
      outputs.push_back({"--out", out_prefix + ext});
    GIMM_USAGE_CHECK(app.count("--step") == 0 || projector_name == "trilinear",
                     "--step is the trilinear projector's; --projector " << projector_name
                                                                         << " walks voxel edges");
    GIMM_USAGE_CHECK(!std::filesystem::path(out_prefix).filename().empty(),
                     "--out " << out_prefix << " ends in a folder: give a prefix, e.g. "
                              << out_prefix
                              << "view (writes view.png, view.npy, view.camera.json)");
    auto inputs = gimm::cli::volume_input("--volume", volume_path);
    for (auto& label_file : gimm::cli::volume_input("--label", label_path))
      inputs.push_back(std::move(label_file));
    gimm::cli::refuse_outputs_over_inputs(outputs, inputs);
    gimm::ContrastRecipe recipe;
    recipe.preset = gimm::parse_contrast_preset(recipe_name);

    for (const std::string& file : {volume_path, label_path})
      if (const std::string note = file.empty() ? "" : gimm::detached_data_note(file);
          !note.empty())
        std::cerr << "gimm-drr: note: " << note << "\n";
    gimm::Volume<float> ct = gimm::read_volume<float>(volume_path);
    // More than 100 samples per voxel add nothing to a trilinear interpolant (1e-9 mm hung).
    GIMM_USAGE_CHECK(step_mm == 0 || step_mm >= ct.spacing().minCoeff() / 100,
                     "--step " << step_mm << " mm is below 1/100 of the smallest voxel spacing ("
                               << ct.spacing().minCoeff() << " mm of '" << volume_path << "')");
    std::optional<gimm::Volume<std::uint8_t>> injected;
    if (!label_path.empty()) {
      const auto label = gimm::read_volume<std::uint8_t>(label_path);
      // The dataset's grid check: dims, spacing, origin and direction.
      gimm::check_same_grid(ct.geometry(), label.geometry(),
                            "gimm-drr: '" + volume_path + "' and '" + label_path + "'");
      auto split = gimm::split_coronary_systems(label, {}, label_path);
      injected = gimm::parse_coronary_system(system_name) == gimm::CoronarySystem::LCA
                     ? std::move(split.lca)
                     : std::move(split.rca);
    }
    if (flags.isocenter.empty()) {
      flags.isocenter.resize(3);
      const Eigen::Vector3d centre =
          injected ? gimm::vessel_isocenter(*injected, label_path) : gimm::grid_center(ct);
      Eigen::Map<Eigen::Vector3d>(flags.isocenter.data()) = centre;
    }
    flags.finish(carm);
    gimm::RendererOptions render_options;
    render_options.recipe = recipe;
    render_options.pad_mm = pad_mm;
    render_options.projector = gimm::parse_projector(projector_name);
    render_options.step_mm = step_mm;
    // --recipe none: the volume already is attenuation; moved in rather than copied.
    const gimm::ViewRenderer renderer =
        recipe.preset == gimm::ContrastPreset::none
            ? gimm::ViewRenderer::from_attenuation(std::move(ct), render_options, volume_path)
            : gimm::ViewRenderer(ct, injected ? &*injected : nullptr, render_options, volume_path);
    const auto t_loaded = std::chrono::steady_clock::now();
    const gimm::Camerad camera = carm.camera();
    const gimm::Image<float> line_integrals = renderer.render(camera).line_integrals;
    const auto t_rendered = std::chrono::steady_clock::now();

    nlohmann::json camera_json = gimm::to_json(carm);
    camera_json["drr"] = {{"volume", volume_path},
                          {"label", label_path},
                          {"system", system_name},
                          {"recipe", recipe_name},
                          {"projector", projector_name},
                          {"pad_mm", pad_mm},
                          {"step_mm", step_mm},
                          {"mu_water_per_mm", recipe.mu_water},
                          {"png", "Beer-Lambert intensity exp(-line integral), min-max to 16 bit"},
                          {"npy", "float32 line integrals (rows, cols), unitless"}};
    gimm::IntensityWindow window;
    const gimm::Image<std::uint16_t> png =
        gimm::to_uint16_min_max(gimm::beer_lambert(line_integrals), &window);
    camera_json["intensity_window"] = gimm::intensity_window_json(window.lo, window.hi);
    // All or nothing: the files are written to temporaries and renamed into place together, so
    // a failure (a full disk) leaves the files of an earlier run at PREFIX as they were.
    gimm::write_all_or_nothing([&](const auto& at) {
      gimm::write_npy(at(out_prefix + ".npy"), line_integrals);
      gimm::write_png(at(out_prefix + ".png"), png);
      gimm::write_json_file(at(out_prefix + ".camera.json"), camera_json);
      if (dicom) {
        gimm::Image<float> unit(png.rows(), png.cols());
        for (int r = 0; r < png.rows(); ++r)
          for (int c = 0; c < png.cols(); ++c) unit(r, c) = png(r, c) / 65535.0f;
        gimm::write_xa_dicom(at(out_prefix + ".dcm").string(), unit, carm);
      }
    });
    const auto t_done = std::chrono::steady_clock::now();
    auto ms = [](auto a, auto b) {
      return std::chrono::duration<double, std::milli>(b - a).count();
    };
    if (!quiet)
      std::printf("gimm-drr: %s %dx%d, %s, load %.0f ms, render %.0f ms, write %.0f ms -> %s.*\n",
                  projector_name.c_str(), camera.rows(), camera.cols(), recipe_name.c_str(),
                  ms(t0, t_loaded), ms(t_loaded, t_rendered), ms(t_rendered, t_done),
                  out_prefix.c_str());
    return 0;
  });
}
