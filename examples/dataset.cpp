// gimm-dataset: the DRR dataset (angiograms, masks, cameras, dense 3D-2D pair labels).
//   gimm-dataset (--input DIR | --phantom COUNT) --out DIR [--seed S] [--phantom-size
//   small|imagecas]
//                [--view-mode shared|per_pair] [--shard I/N] [camera flags] [--recipe R]
//                [--allow-single-system] [--warn-dropped FRACTION] [--export reference]
//   gimm-dataset merge --out DIR        joins the shard manifests of DIR into manifest.json
// --input DIR is searched with its sub-folders for <id>.img<ext> + <id>.label<ext>.
// Shards: --shard I/N, else SLURM_ARRAY_TASK_ID + SLURM_ARRAY_TASK_COUNT, else
// JOB_COMPLETION_INDEX (Kubernetes Indexed Job) + GIMM_SHARD_COUNT. Patient k (in id order)
// belongs to shard k mod N. A killed run started again skips finished patients (done.json).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "cli_common.hpp"
#include "gimm/pipeline/dataset.hpp"
#include "gimm/pipeline/reference_export.hpp"

namespace fs = std::filesystem;

namespace {

struct Shard {
  int index = 0, count = 1;
  bool sharded() const { return count > 1; }
  std::string manifest_name() const {
    return sharded() ? "manifest.shard-" + std::to_string(index) + "-of-" + std::to_string(count) +
                           ".json"
                     : "manifest.json";
  }
};

int parse_int(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  int value = 0;
  try {
    value = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  GIMM_CHECK(used == text.size() && !text.empty(),
             what << " must be an integer, got '" << text << "'");
  return value;
}

Shard resolve_shard(const std::string& flag) {
  Shard s;
  auto env = [](const char* name) -> std::string {
    const char* v = std::getenv(name);
    return v ? v : "";
  };
  if (!flag.empty()) {
    const auto slash = flag.find('/');
    GIMM_CHECK(slash != std::string::npos, "--shard must be I/N, got '" << flag << "'");
    s.index = parse_int(flag.substr(0, slash), "--shard index");
    s.count = parse_int(flag.substr(slash + 1), "--shard count");
  } else if (!env("SLURM_ARRAY_TASK_ID").empty()) {
    s.index = parse_int(env("SLURM_ARRAY_TASK_ID"), "SLURM_ARRAY_TASK_ID");
    GIMM_CHECK(!env("SLURM_ARRAY_TASK_COUNT").empty(),
               "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not");
    s.count = parse_int(env("SLURM_ARRAY_TASK_COUNT"), "SLURM_ARRAY_TASK_COUNT");
    const std::string min = env("SLURM_ARRAY_TASK_MIN");
    if (!min.empty()) s.index -= parse_int(min, "SLURM_ARRAY_TASK_MIN");
  } else if (!env("JOB_COMPLETION_INDEX").empty()) {
    s.index = parse_int(env("JOB_COMPLETION_INDEX"), "JOB_COMPLETION_INDEX");
    GIMM_CHECK(!env("GIMM_SHARD_COUNT").empty(),
               "JOB_COMPLETION_INDEX is set but GIMM_SHARD_COUNT is not");
    s.count = parse_int(env("GIMM_SHARD_COUNT"), "GIMM_SHARD_COUNT");
  }
  GIMM_CHECK(s.count >= 1 && s.index >= 0 && s.index < s.count,
             "shard " << s.index << "/" << s.count << " is out of range (need 0 <= I < N)");
  return s;
}

void write_splits(const fs::path& out, const nlohmann::json& patients) {
  fs::create_directories(out / "splits");
  for (const char* split : {"train", "val", "test"}) {
    std::string text;
    for (const auto& p : patients)
      if (p.value("status", "") == "ok" && p.value("split", "") == split)
        text += p["id"].get<std::string>() + "\n";
    gimm::write_file_atomic(out / "splits" / (std::string(split) + ".txt"), text);
  }
}

/// A killed run can leave "<file>.tmp.<host>.<pid>" behind (write_file_atomic's temporaries);
/// they are never read, and removing them makes a resumed tree equal to an uninterrupted one.
/// Only under `dir` and only files this process would write: other shards may be writing theirs
/// into the same output folder right now.
void remove_stale_temporaries(const fs::path& dir, const std::string& name_prefix = "") {
  if (!fs::is_directory(dir)) return;
  std::vector<fs::path> stale;
  const auto is_stale = [&](const fs::path& p) {
    const std::string name = p.filename().string();
    return name.rfind(name_prefix, 0) == 0 && name.find(".tmp.") != std::string::npos;
  };
  const auto scan = [&](auto entries) {
    for (const auto& e : entries)
      if (e.is_regular_file() && is_stale(e.path())) stale.push_back(e.path());
  };
  // A prefix names top-level outputs only; without one, the whole (patient) folder.
  if (name_prefix.empty())
    scan(fs::recursive_directory_iterator(dir));
  else
    scan(fs::directory_iterator(dir));
  for (const auto& p : stale) fs::remove(p);
}

/// The outputs written once per run (not per patient): the manifest, and when not sharded the
/// splits and the reference export.
void remove_stale_run_temporaries(const fs::path& out, const std::string& manifest_name,
                                  bool sharded) {
  remove_stale_temporaries(out, manifest_name + ".tmp.");
  if (sharded) return;
  remove_stale_temporaries(out / "splits");
  remove_stale_temporaries(out / "reference");
}

/// The first difference between two JSON values, as "path: stored vs wanted".
std::string first_difference(const nlohmann::json& stored, const nlohmann::json& wanted) {
  const nlohmann::json patch = nlohmann::json::diff(stored, wanted);
  if (patch.empty()) return "";
  const std::string path = patch[0].at("path").get<std::string>();
  const nlohmann::json::json_pointer pointer(path);
  const std::string was = stored.contains(pointer) ? stored.at(pointer).dump() : "(none)";
  const std::string now = wanted.contains(pointer) ? wanted.at(pointer).dump() : "(none)";
  return path + ": " + was + " there, " + now + " here";
}

/// --export reference needs ids the reference layout can name: checked before any work.
void check_export_ids(const std::string& format, const std::vector<std::string>& ids) {
  if (!format.empty()) gimm::reference_format::check_patient_ids(ids, "--export " + format);
}

/// --export reference: the released dataset's layout in OUT/reference.
void export_if_asked(const std::string& format, const fs::path& out) {
  if (format.empty()) return;
  gimm::export_reference(out, out / "reference");
  std::printf("gimm-dataset: reference layout -> %s\n", (out / "reference").c_str());
}

int merge(const fs::path& out, const std::string& export_format) {
  GIMM_CHECK(fs::is_directory(out), "merge: '" << out.string() << "' is not a directory");
  remove_stale_run_temporaries(out, "manifest.json", false);
  std::vector<fs::path> shards;
  for (const auto& e : fs::directory_iterator(out)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("manifest.shard-", 0) == 0) shards.push_back(e.path());
  }
  GIMM_CHECK(!shards.empty(), "merge: no manifest.shard-*.json in '" << out.string() << "'");
  std::sort(shards.begin(), shards.end());
  nlohmann::json merged, patients = nlohmann::json::array();
  int count = -1;
  std::vector<int> seen;
  for (const auto& path : shards) {
    const auto m = gimm::read_json_file(path);
    if (merged.is_null()) merged = m;
    GIMM_CHECK(m.at("parameters") == merged.at("parameters") && m.at("input") == merged.at("input"),
               "merge: '" << path.string() << "' was made with other parameters than '"
                          << shards[0].string() << "'");
    count = m.at("shard").at("count").get<int>();
    seen.push_back(m.at("shard").at("index").get<int>());
    for (const auto& p : m.at("patients")) patients.push_back(p);
  }
  std::sort(seen.begin(), seen.end());
  for (int i = 0; i < count; ++i)
    GIMM_CHECK(
        std::binary_search(seen.begin(), seen.end(), i),
        "merge: shard " << i << " of " << count << " is missing in '" << out.string() << "'");
  std::sort(patients.begin(), patients.end(), [](const auto& a, const auto& b) {
    return a["id"].template get<std::string>() < b["id"].template get<std::string>();
  });
  std::vector<std::string> ok_ids;
  for (const auto& p : patients)
    if (p.value("status", "") == "ok") ok_ids.push_back(p["id"].get<std::string>());
  check_export_ids(export_format, ok_ids);
  merged["patients"] = patients;
  merged.erase("shard");
  gimm::write_json_file(out / "manifest.json", merged);
  write_splits(out, patients);
  for (const auto& path : shards) fs::remove(path);
  std::printf("gimm-dataset merge: %zu shards, %zu patients -> %s\n", shards.size(),
              patients.size(), (out / "manifest.json").c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gimm-dataset: DRR dataset with dense 3D-2D correspondence labels"};
  app.failure_message(CLI::FailureMessage::help);
  gimm::DatasetOptions options;
  gimm::cli::CArmFlags flags;
  std::string input, out, shard_flag, view_mode = "shared", vessel_mode = "voxel",
                                      recipe = "angiography", projector = "siddon",
                                      phantom_size = "small";
  int phantom_count = 0;
  bool quiet = false;
  std::string export_format;
  app.add_option("--input", input,
                 "folder (sub-folders included) of ImageCAS-style <id>.img<ext> + "
                 "<id>.label<ext>, <ext> e.g. .nii.gz");
  app.add_option("--phantom", phantom_count, "generate COUNT phantom patients instead")
      ->check(CLI::PositiveNumber);
  app.add_option("--phantom-size", phantom_size, "small|imagecas")
      ->check(CLI::IsMember({"small", "imagecas"}))
      ->capture_default_str();
  app.add_option("--out", out, "output directory");
  app.add_option("--seed", options.seed, "run seed (views, splits, sparse labels, phantoms)")
      ->capture_default_str();
  app.add_option("--view-mode", view_mode, "shared (11 renders) | per_pair (54 renders)")
      ->check(CLI::IsMember({"shared", "per_pair"}))
      ->capture_default_str();
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
                 "voxel (label voxels) | mesh (Embree chords, anti-aliased)")
      ->check(CLI::IsMember({"voxel", "mesh"}))
      ->capture_default_str();
  app.add_option("--shard", shard_flag, "I/N: this process does patients k with k mod N = I");
  app.add_flag("--allow-single-system", options.allow_single_system,
               "a label of one tree: make that system only (assigned by the volume centre), "
               "record the other as absent");
  app.add_option("--warn-dropped", options.warn_dropped_fraction,
                 "warn when the LCA/RCA split drops more than this fraction of a label's voxels")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_flag("--quiet", quiet, "no progress line, no per-patient timings");
  flags.add(app, options.carm, false);
  app.add_option("--export", export_format,
                 "also write OUT/reference in the released dataset's layout")
      ->check(CLI::IsMember({"reference"}));
  auto* merge_cmd = app.add_subcommand("merge", "join shard manifests into manifest.json");
  merge_cmd->add_option("--out", out, "the dataset directory the shards wrote to")->required();
  merge_cmd->add_option("--export", export_format, "also write OUT/reference (reference layout)")
      ->check(CLI::IsMember({"reference"}));
  return gimm::cli::run(app, argc, argv, [&] {
    if (*merge_cmd) {
      const int status = merge(out, export_format);
      export_if_asked(export_format, out);
      return status;
    }
    GIMM_CHECK(!out.empty(), "gimm-dataset: --out is required");
    GIMM_CHECK(input.empty() != (phantom_count == 0),
               "gimm-dataset: give exactly one of --input and --phantom");
    flags.finish(options.carm);
    options.view_mode = gimm::parse_view_mode(view_mode);
    options.recipe = gimm::parse_contrast_preset(recipe);
    options.projector = gimm::parse_projector(projector);
    options.vessel_mode = gimm::parse_vessel_mode(vessel_mode);
    const Shard shard = resolve_shard(shard_flag);
    GIMM_CHECK(!shard.sharded() || export_format.empty(),
               "--export with --shard " << shard.index << "/" << shard.count
                                        << ": export after `gimm-dataset merge --export`");
    std::vector<gimm::PatientSource> sources;
    if (!input.empty()) {
      sources = gimm::scan_imagecas_folder(input);
    } else {
      for (int n = 0; n < phantom_count; ++n) {
        gimm::PatientSource s;
        char id[32];
        std::snprintf(id, sizeof id, "phantom-%04d", n);
        s.id = id;
        s.phantom_seed = options.seed * 1000003ull + static_cast<std::uint64_t>(n);
        s.phantom_size = gimm::parse_phantom_size(phantom_size);
        sources.push_back(s);
      }
    }
    {
      std::vector<std::string> ids;
      for (const auto& s : sources) ids.push_back(s.id);
      check_export_ids(export_format, ids);
    }
    gimm::assign_splits(sources, options);
    fs::create_directories(out);
    {  // fail early, before any work, if the output is not writable
      const fs::path probe = fs::path(out) / (".write-test." + gimm::detail::process_tag());
      gimm::write_file_atomic(probe, std::string("ok"));
      fs::remove(probe);
    }
    std::vector<const gimm::PatientSource*> mine;
    for (std::size_t k = 0; k < sources.size(); ++k)
      if (static_cast<int>(k % shard.count) == shard.index) mine.push_back(&sources[k]);
    // Resuming: finished patients must have been made with these parameters (else the manifest
    // would describe files it did not make); unfinished ones lose their temporaries.
    remove_stale_run_temporaries(out, shard.manifest_name(), shard.sharded());
    std::vector<nlohmann::json> finished(mine.size());  // done.json of each, or null
    for (std::size_t m = 0; m < mine.size(); ++m) {
      const fs::path dir = fs::path(out) / "patients" / mine[m]->id;
      remove_stale_temporaries(dir);
      if (!fs::exists(dir / "done.json")) continue;
      finished[m] = gimm::read_json_file(dir / "done.json");
      const nlohmann::json stored = finished[m].value("run", nlohmann::json());
      finished[m].erase("run");
      const std::string difference = first_difference(stored, gimm::patient_run(*mine[m], options));
      GIMM_CHECK(difference.empty(), "gimm-dataset: '"
                                         << dir.string() << "' was made with other parameters ("
                                         << difference << "); use another --out, or the parameters "
                                         << "it was made with");
    }

    nlohmann::json patients = nlohmann::json::array();
    const auto t0 = std::chrono::steady_clock::now();
    std::size_t done = 0, failed = 0, resumed = 0;
    gimm::PatientTimings made_timings;  // the patients made in this run
    int progress_width = 0;             // of the progress line on screen, to overwrite it
    const auto log_line = [&](const std::string& text) {
      if (progress_width > 0)
        std::fprintf(stderr, "\r%-*s\n", progress_width, text.c_str());
      else
        std::fprintf(stderr, "%s\n", text.c_str());
    };
    for (std::size_t m = 0; m < mine.size(); ++m) {
      const gimm::PatientSource* src = mine[m];
      nlohmann::json record;
      if (!finished[m].is_null()) {
        record = finished[m];
        ++resumed;
      } else {
        try {
          gimm::PatientTimings t;
          record = gimm::generate_patient(*src, options, out, &t);
          made_timings += t;
          if (!quiet) log_line("gimm-dataset: patient " + src->id + ": " + t.summary());
          const std::string warning = gimm::dropped_voxels_warning(record, options);
          if (!warning.empty()) log_line("gimm-dataset: warning: " + warning);
        } catch (const std::exception& e) {
          record = {{"id", src->id}, {"status", "failed"}, {"error", e.what()}};
          ++failed;
          log_line("gimm-dataset: patient " + src->id + " failed: " + e.what());
        }
      }
      patients.push_back(record);
      ++done;
      if (!quiet) {
        // The rate counts the patients made in this run, not the ones found finished.
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const std::size_t made = done - resumed;
        const double rate = made / std::max(s, 1e-9);
        std::string eta = "?";
        if (made > 0) eta = std::to_string(std::llround((mine.size() - done) / rate)) + " s";
        char line[200];
        std::snprintf(line, sizeof line,
                      "gimm-dataset: %zu/%zu patients (%zu resumed, %zu failed), %.3f patients/s, "
                      "ETA %s   ",
                      done, mine.size(), resumed, failed, rate, eta.c_str());
        std::fprintf(stderr, "\r%s", line);
        progress_width = static_cast<int>(std::strlen(line));
      }
    }
    if (!quiet) std::fprintf(stderr, "\n");
    nlohmann::json manifest = {
        {"format", "gimm-dataset/1"},
        {"parameters", options.to_json()},
        {"input", input.empty()
                      ? nlohmann::json{{"phantom", phantom_count}, {"phantom_size", phantom_size}}
                      : nlohmann::json{{"folder", input}}},
        {"patients", patients}};
    if (shard.sharded()) {
      manifest["shard"] = {{"index", shard.index}, {"count", shard.count}};
    } else {
      write_splits(out, patients);
    }
    gimm::write_json_file(fs::path(out) / shard.manifest_name(), manifest);
    if (!shard.sharded()) export_if_asked(export_format, out);
    std::size_t views = 0, pairs = 0, labels = 0;
    for (const auto& p : patients)
      if (p.value("status", "") == "ok")
        for (const auto& [name, sys] : p["systems"].items()) {
          views += sys["views"].get<std::size_t>();
          pairs += sys["pairs"].get<std::size_t>();
          labels += sys["dense_labels"].get<std::size_t>();
        }
    std::printf(
        "gimm-dataset: %zu patients (%zu failed): %zu views, %zu pairs, %zu dense labels -> %s\n",
        patients.size(), failed, views, pairs, labels,
        (fs::path(out) / shard.manifest_name()).c_str());
    if (made_timings.view_count > 0) {  // everything per view: render, vessel mask, labels, files
      std::printf("gimm-dataset: %zu views made in %.2f s, %.3f s per view\n",
                  made_timings.view_count, made_timings.views,
                  made_timings.views / static_cast<double>(made_timings.view_count));
      std::printf("gimm-dataset: time by stage (patients made in this run): %s\n",
                  made_timings.summary().c_str());
    }
    return failed == patients.size() && failed > 0 ? 1 : 0;
  });
}
