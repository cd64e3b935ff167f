// gimm-dataset: the DRR dataset (angiograms, masks, cameras, dense 3D-2D pair labels).
//   gimm-dataset (--input DIR | --phantom COUNT) --out DIR [--seed S] [--style clinical|drr]
//                [--phantom-size small|imagecas|chest] [--tree classic|rich] [--[no-]formation]
//                [--view-mode shared|per_pair | --views FILE] [--shard I/N] [camera flags]
//                [--recipe R]
//                [--allow-single-system] [--warn-dropped FRACTION] [--export reference]
//   gimm-dataset merge --out DIR        joins the shard manifests of DIR into manifest.json
// --input DIR is searched with its sub-folders for <id>.img<ext> + <id>.label<ext>.
// Shards: --shard I/N, else SLURM_ARRAY_TASK_ID + SLURM_ARRAY_TASK_COUNT, else
// JOB_COMPLETION_INDEX (Kubernetes Indexed Job) + GIMM_SHARD_COUNT. Patient k (in id order)
// belongs to shard k mod N. A killed run started again skips finished patients (done.json).
// A failed run (a full disk) leaves no partial patient, temporary, manifest or split list: only
// the patients it finished, which a rerun skips (pipeline/dataset_run.hpp).
#include <cstdio>
#include <filesystem>
#include <string>

#include "cli_common.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/pipeline/dataset_run.hpp"
#include "gimm/pipeline/dataset_style.hpp"

namespace {
std::string detached_note_or_empty(const std::filesystem::path& file) {
  try {
    return file.empty() ? std::string() : gimm::detached_data_note(file);
  } catch (const gimm::Error&) {
    return {};
  }
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gimm-dataset: DRR dataset with dense 3D-2D correspondence labels", "gimm-dataset"};
  gimm::DatasetOptions options;
  gimm::cli::CArmFlags flags;
  std::string input, out, shard_flag, views_file,
      view_mode = "shared", vessel_mode = "voxel", recipe = "angiography", projector = "siddon",
      phantom_size = "small", tree = "classic", style_name = "clinical";
  int phantom_count = 0;
  bool quiet = false;
  gimm::LumenOptions lumen;
  gimm::TortuosityOptions tortuosity;
  std::string export_format;
  app.add_option("--input", input,
                 "folder (sub-folders included) of ImageCAS-style <id>.img<ext> + "
                 "<id>.label<ext>, <ext> e.g. .nii.gz");
  app.add_option("--phantom", phantom_count, "generate COUNT phantom patients instead")
      ->check(gimm::cli::at_least(1));
  app.add_option("--style", style_name,
                 "clinical (formed views, chest, tubes, rich tree, 0.3 mm pixels) | drr (the bare "
                 "DRR of the crop phantom at 0.5 mm, the shipped weights' images): the defaults "
                 "of --formation, --phantom-size, --tree, --vessels, --pixel (docs/dataset.md)")
      ->check(CLI::IsMember({"clinical", "drr"}))
      ->capture_default_str();
  app.add_option("--phantom-size", phantom_size,
                 "small|imagecas|chest (the whole chest, for realistic views); default: the "
                 "style's (clinical: chest, drr: small)")
      ->check(CLI::IsMember({"small", "imagecas", "chest"}));
  app.add_option("--stenoses", lumen.stenoses,
                 "phantoms: focal stenoses (30-80% of the diameter, 4-12 mm) on that many main "
                 "branches per patient, recorded in centerlines.json (anatomy/lumen.hpp)")
      ->check(CLI::Range(0, 8));
  app.add_option("--lumen-irregularity", lumen.irregularity,
                 "phantoms: sigma of the lumen's wavering along the vessels (0.05-0.1 look like "
                 "angiograms; default 0: a smooth taper)")
      ->check(gimm::cli::in_range(0, 0.3, true));
  app.add_option("--tortuosity", tortuosity.sigma_mm,
                 "phantoms: mm, sd of the vessels' irregular sideways wander on the heart (over "
                 "4 mm along them; default 0: the classic course; anatomy/tortuosity.hpp)")
      ->check(gimm::cli::in_range(0, 5, true));
  app.add_option("--tree", tree,
                 "classic|rich: the phantoms' coronary tree; rich adds septals, a conus, RV "
                 "and more branches (20-29) with Murray's-law calibres (docs/phantom.md); "
                 "default: the style's (clinical: rich, drr: classic)")
      ->check(CLI::IsMember({"classic", "rich"}));
  app.add_option("--out", out, "output directory");
  app.add_option("--seed", options.seed, "run seed (views, splits, sparse labels, phantoms)")
      ->capture_default_str();
  app.add_option("--view-mode", view_mode, "shared (11 renders) | per_pair (54 renders)")
      ->check(CLI::IsMember({"shared", "per_pair"}))
      ->capture_default_str();
  app.add_option("--views", views_file,
                 "gimm-views/1 JSON: view pairs placed on purpose instead of the protocol "
                 "(docs/dataset.md)")
      ->excludes("--view-mode");
  app.add_option("--recipe", recipe, "reference|angiography")
      ->check(CLI::IsMember({"reference", "angiography"}))
      ->capture_default_str();
  app.add_option("--pad-mm", options.pad_mm,
                 "tissue beyond the scan's axial coverage, mm on each side (copies of the edge "
                 "slices; 0 = air, as the reference)")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  app.add_option("--projector", projector, "siddon|trilinear")
      ->check(CLI::IsMember({"siddon", "trilinear"}))
      ->capture_default_str();
  app.add_option("--vessels", vessel_mode,
                 "voxel (label voxels) | mesh (Embree chords, anti-aliased) | tubes (phantoms: "
                 "the analytic tubes' mesh, and their axes as the labelled centerlines); "
                 "default: tubes for phantoms of the clinical style, else voxel")
      ->check(CLI::IsMember({"voxel", "mesh", "tubes"}));
  app.add_option("--shard", shard_flag, "I/N: this process does patients k with k mod N = I");
  app.add_flag("--line-integrals", options.write_line_integrals,
               "also write each view's float32 line integrals (<view>.npy, (rows, cols))");
  app.add_flag("--formation,!--no-formation", options.form_angiogram,
               "also form each view as a C-arm does (iodine lumen, scatter, blur, noise, "
               "shutters, log, window, edge enhancement; parameters drawn per view, "
               "docs/realism.md): <view>.formed.png (8-bit) and <view>.field.png; the lumen is "
               "iodine in <view>.png too; masks and labels unchanged. Default: the style's "
               "(clinical: on, drr: off)");
  app.add_flag("--smooth-background,!--no-smooth-background", options.smooth_voxel_steps,
               "mesh/tubes vessels: blur each view's background by half a voxel's footprint "
               "before the vessels are added (the volume's voxel steps at fine pixels are not "
               "anatomy; vessels and labels unchanged). Default: the style's (clinical: on)");
  app.add_flag("--allow-single-system", options.allow_single_system,
               "a label of one tree: make that system only (assigned by the volume centre), "
               "record the other as absent");
  app.add_option("--warn-dropped", options.warn_dropped_fraction,
                 "warn when the LCA/RCA split drops more than this fraction of a label's voxels")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_flag("--quiet", quiet, "no progress line, no per-patient timings");
  std::string timings_file;
  app.add_option("--timings", timings_file,
                 "append each made patient's stage seconds to FILE as a JSON line (outside "
                 "--out: the dataset itself holds no wall-clock times)");
  flags.add(app, options.carm, false);
  app.add_option("--export", export_format,
                 "also write OUT/reference in the released dataset's layout")
      ->check(CLI::IsMember({"reference"}));
  auto* merge_cmd = app.add_subcommand("merge", "join shard manifests into manifest.json");
  merge_cmd->add_option("--out", out, "the dataset directory the shards wrote to")->required();
  merge_cmd->add_option("--export", export_format, "also write OUT/reference (reference layout)")
      ->check(CLI::IsMember({"reference"}));
  const auto phantom_size_given = [&] { return app.count("--phantom-size") > 0; };
  app.callback([&] {  // during parsing: a usage error (exit 2)
    if (vessel_mode == "tubes" && !input.empty())
      throw CLI::ValidationError("--vessels",
                                 "tubes are a phantom's analytic vessels; with "
                                 "--input the vessels are the label (voxel|mesh)");
    if (tree != "classic" && !input.empty())
      throw CLI::ValidationError("--tree",
                                 "the tree is a phantom's; with --input it is the label's");
    for (const char* flag : {"--stenoses", "--lumen-irregularity", "--tortuosity"})
      if (app.count(flag) && !input.empty())
        throw CLI::ValidationError(flag, std::string(flag) == "--tortuosity"
                                             ? "the course is a phantom's; with --input it is "
                                               "the label's"
                                             : "the lumen is a phantom's; with --input it is "
                                               "the label's");
    if (phantom_size_given() && !input.empty())
      throw CLI::ValidationError("--phantom-size",
                                 "the size is a phantom's; with --input it is the volume's");
  });
  gimm::cli::option_flags() = {{"SplitOptions::allow_single", "--allow-single-system"},
                               {"DatasetOptions::phantom_tubes", "--vessels tubes"}};
  // The run's messages as gimm-dataset's: its name first, the flags beside the options.
  const auto reporter = [](bool quiet) {
    return gimm::stderr_reporter(quiet, "gimm-dataset: ", [](const std::string& text) {
      return gimm::cli::with_flags(text);
    });
  };
  return gimm::cli::run(app, argc, argv, [&] {
    if (*merge_cmd) {
      const gimm::MergedShards merged = gimm::merge_dataset(out, export_format, reporter(false));
      std::printf("gimm-dataset merge: %zu shards, %zu patients -> %s\n", merged.shards,
                  merged.manifest.at("patients").size(),
                  gimm::DatasetLayout(out).manifest().c_str());
      return 0;
    }
    GIMM_USAGE_CHECK(!out.empty(), "gimm-dataset: --out is required");
    GIMM_USAGE_CHECK(
        timings_file.empty() || !gimm::path_is_within(timings_file, out),
        "--timings " << timings_file << " lies inside --out " << out
                     << " (the dataset holds no wall-clock times); write it elsewhere");
    // The timings file is appended to: never one of the input folder's files (it appended JSON
    // to a patient's volume).
    GIMM_USAGE_CHECK(
        timings_file.empty() || input.empty() || !gimm::path_is_within(timings_file, input),
        "--timings " << timings_file << " lies inside --input " << input
                     << " (the run would append to its own input); write it elsewhere");
    gimm::cli::refuse_outputs_over_inputs({{"--out", out}, {"--timings", timings_file}},
                                          {{"--input", input}, {"--views", views_file}}, true);
    GIMM_USAGE_CHECK(input.empty() != (phantom_count == 0),
                     "gimm-dataset: give exactly one of --input and --phantom");
    // The view protocol picks every view's angles and the centerlines its isocentre: these
    // flags would change nothing but the manifest.
    for (const char* unused : {"--primary", "--secondary", "--isocenter"})
      GIMM_USAGE_CHECK(
          app.count(unused) == 0,
          "gimm-dataset: " << unused
                           << " sets nothing here (the view protocol picks the angles, "
                              "the centerlines the isocentre); use gimm-drr for one view");
    // The style's defaults, where the flag itself was not given (phantom settings: phantoms).
    const gimm::DatasetStyleChoices style =
        gimm::style_choices(gimm::parse_dataset_style(style_name));
    const bool phantoms = input.empty();
    if (phantoms && app.count("--phantom-size") == 0)
      phantom_size = gimm::to_string(style.phantom_size);
    if (phantoms && app.count("--tree") == 0) tree = gimm::to_string(style.tree);
    if (phantoms && app.count("--vessels") == 0 && style.phantom_tubes) vessel_mode = "tubes";
    if (app.count("--formation") == 0) options.form_angiogram = style.formation;
    if (app.count("--pixel") == 0) options.carm.pixel_mm = style.pixel_mm;
    if (app.count("--smooth-background") == 0)
      options.smooth_voxel_steps = style.smooth_voxel_steps;
    flags.finish(options.carm);
    options.view_mode = gimm::parse_view_mode(view_mode);
    if (!views_file.empty()) options.listed_views = gimm::read_view_list(views_file);
    options.preset = gimm::parse_contrast_preset(recipe);
    options.projector = gimm::parse_projector(projector);
    options.phantom_tubes = vessel_mode == "tubes";
    options.vessel_mode = gimm::parse_vessel_mode(options.phantom_tubes ? "mesh" : vessel_mode);
    gimm::DatasetRunOptions run;
    run.shard = gimm::cli::flag_value("--shard (or the array job's index variables)",
                                      [&] { return gimm::resolve_shard(shard_flag); });
    GIMM_USAGE_CHECK(export_format.empty() || !run.shard.sharded(),
                     "--export with --shard " << run.shard.index << "/" << run.shard.count
                                              << ": export after `gimm-dataset merge --export`");
    GIMM_USAGE_CHECK(export_format.empty() || views_file.empty(),
                     "--export " << export_format
                                 << " with --views: the reference layout names each pair by two "
                                    "distinct view classes, which a listed run does not keep");
    run.quiet = quiet;
    run.report = reporter(quiet);
    run.timings_file = timings_file;
    run.export_format = export_format;
    run.input = input.empty()
                    ? nlohmann::json{{"phantom", phantom_count}, {"phantom_size", phantom_size}}
                    : nlohmann::json{{"folder", input}};
    if (input.empty() && tree != "classic") run.input["phantom_tree"] = tree;
    std::vector<gimm::PatientSource> sources =
        input.empty() ? gimm::phantom_sources(phantom_count, options.seed,
                                              gimm::parse_phantom_size(phantom_size),
                                              gimm::parse_tree_detail(tree))
                      : gimm::scan_imagecas_folder(input);
    if (!lumen.none()) {
      run.input["phantom_lumen"] = {{"stenoses", lumen.stenoses},
                                    {"irregularity", lumen.irregularity}};
      for (gimm::PatientSource& s : sources) s.phantom_lumen = lumen;
    }
    if (!tortuosity.none()) {
      run.input["phantom_tortuosity"] = gimm::tortuosity_json(tortuosity);
      for (gimm::PatientSource& s : sources) s.phantom_tortuosity = tortuosity;
    }
    if (!export_format.empty()) {  // ids the export cannot name: refused before any work
      std::vector<std::string> ids;
      for (const auto& source : sources) ids.push_back(source.id);
      gimm::cli::flag_value("--export " + export_format, [&] {
        gimm::reference_format::check_patient_ids(ids, "the input's patients");
      });
    }
    // Voxels read from outside a header's folder are named (docs/conventions.md, "Detached
    // data files"); a header that cannot be read fails its patient later, by name.
    for (const auto& source : sources)
      for (const auto& file : {source.image, source.label})
        if (const std::string note = detached_note_or_empty(file); !note.empty())
          std::cerr << "gimm-dataset: note: patient " << source.id << ": " << note << "\n";
    const gimm::DatasetRunSummary s = gimm::run_dataset(sources, options, out, run);
    std::printf(
        "gimm-dataset: %zu patients (%zu failed): %zu views, %zu pairs, %zu dense labels -> %s\n",
        s.patients, s.failed, s.views, s.pairs, s.dense_labels, s.manifest.c_str());
    if (s.made.view_count > 0) {  // everything per view: render, vessel mask, labels, files
      std::printf("gimm-dataset: %zu views made in %.2f s, %.3f s per view\n", s.made.view_count,
                  s.made.views, s.made.views / static_cast<double>(s.made.view_count));
      std::printf("gimm-dataset: time by stage (patients made in this run): %s\n",
                  s.made.summary().c_str());
    }
    return s.failed == s.patients && s.failed > 0 ? 1 : 0;
  });
}
