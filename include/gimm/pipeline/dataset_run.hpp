#pragma once
/// A whole dataset run from C++: the patients of this shard, resumed where a killed run stopped,
/// a progress line, the manifest, the splits and, if asked, the reference export. gimm-dataset is
/// argument parsing around run_dataset and merge_dataset.
///
///   std::vector<gimm::PatientSource> sources = gimm::scan_imagecas_folder("ImageCAS/");
///   gimm::DatasetRunOptions run;
///   run.shard = gimm::resolve_shard("");          // Slurm / Kubernetes indices, or 0 of 1
///   const auto summary = gimm::run_dataset(sources, options, "out/", run);
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/dataset/run.hpp"
#include "gimm/dataset/writer.hpp"
#include "gimm/pipeline/dataset.hpp"
#include "gimm/pipeline/reference_export.hpp"

namespace gimm {

struct DatasetRunOptions {
  Shard shard;
  bool quiet = false;         ///< no progress line, no per-patient lines
  std::string export_format;  ///< "" or "reference" (OUT/reference; not with shards)
  nlohmann::json input;       ///< what the patients came from, for the manifest
};

struct DatasetRunSummary {
  std::size_t patients = 0, failed = 0, resumed = 0;
  std::size_t views = 0, pairs = 0, dense_labels = 0;
  PatientTimings made;  ///< the patients made in this run
  std::filesystem::path manifest;
};

namespace detail {
/// --export reference needs ids the reference layout can name: checked before any work.
inline void check_export_ids(const std::string& format, const std::vector<std::string>& ids) {
  if (!format.empty()) reference_format::check_patient_ids(ids, "--export " + format);
}

/// One line on stderr that overwrites itself, with log lines printed above it.
class ProgressLine {
 public:
  explicit ProgressLine(bool quiet) : quiet_(quiet) {}
  void log(const std::string& text) {
    if (width_ > 0)
      std::fprintf(stderr, "\r%-*s\n", width_, text.c_str());
    else
      std::fprintf(stderr, "%s\n", text.c_str());
  }
  void show(const std::string& text) {
    if (quiet_) return;
    std::fprintf(stderr, "\r%s", text.c_str());
    width_ = static_cast<int>(text.size());
  }
  void finish() {
    if (!quiet_) std::fprintf(stderr, "\n");
  }

 private:
  bool quiet_;
  int width_ = 0;
};
}  // namespace detail

/// --export reference: the released dataset's layout in OUT/reference (nothing for "").
inline void export_if_asked(const std::string& format, const std::filesystem::path& out) {
  if (format.empty()) return;
  const DatasetLayout layout(out);
  export_reference(out, layout.reference_dir());
  std::printf("gimm-dataset: reference layout -> %s\n", layout.reference_dir().c_str());
}

/// Makes the patients of `run.shard` among `sources` into `out` (see the file comment). A
/// patient that fails is recorded as failed with its error; the others go on.
inline DatasetRunSummary run_dataset(std::vector<PatientSource> sources,
                                     const DatasetOptions& options,
                                     const std::filesystem::path& out,
                                     const DatasetRunOptions& run) {
  namespace fs = std::filesystem;
  const Shard& shard = run.shard;
  GIMM_CHECK(!shard.sharded() || run.export_format.empty(),
             "--export with --shard " << shard.index << "/" << shard.count
                                      << ": export after `gimm-dataset merge --export`");
  {
    std::vector<std::string> ids;
    for (const auto& s : sources) ids.push_back(s.id);
    detail::check_export_ids(run.export_format, ids);
  }
  assign_splits(sources, options);
  fs::create_directories(out);
  {  // fail early, before any work, if the output is not writable
    const fs::path probe = out / (".write-test." + process_tag());
    write_file_atomic(probe, std::string("ok"));
    fs::remove(probe);
  }
  std::vector<const PatientSource*> mine;
  for (std::size_t k = 0; k < sources.size(); ++k)
    if (static_cast<int>(k % shard.count) == shard.index) mine.push_back(&sources[k]);
  // Resuming: finished patients must have been made with these parameters; unfinished ones lose
  // their temporaries.
  const DatasetLayout layout(out);
  remove_stale_run_temporaries(layout, shard);
  std::vector<nlohmann::json> finished(mine.size());
  for (std::size_t m = 0; m < mine.size(); ++m)
    finished[m] = finished_patient(layout, mine[m]->id, patient_run(*mine[m], options));

  DatasetRunSummary summary;
  nlohmann::json patients = nlohmann::json::array();
  const auto t0 = std::chrono::steady_clock::now();
  detail::ProgressLine progress(run.quiet);
  std::size_t done = 0;
  for (std::size_t m = 0; m < mine.size(); ++m) {
    const PatientSource* src = mine[m];
    nlohmann::json record;
    if (!finished[m].is_null()) {
      record = finished[m];
      ++summary.resumed;
    } else {
      try {
        PatientTimings t;
        record = generate_patient(*src, options, out, &t);
        summary.made += t;
        if (!run.quiet) progress.log("gimm-dataset: patient " + src->id + ": " + t.summary());
        const std::string warning = dropped_voxels_warning(record, options);
        if (!warning.empty()) progress.log("gimm-dataset: warning: " + warning);
      } catch (const std::exception& e) {
        record = {{"id", src->id}, {"status", "failed"}, {"error", e.what()}};
        ++summary.failed;
        progress.log("gimm-dataset: patient " + src->id + " failed: " + e.what());
      }
    }
    patients.push_back(record);
    ++done;
    // The rate counts the patients made in this run, not the ones found finished.
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::size_t made = done - summary.resumed;
    const double rate = made / std::max(s, 1e-9);
    std::string eta = "?";
    if (made > 0) eta = std::to_string(std::llround((mine.size() - done) / rate)) + " s";
    char line[200];
    std::snprintf(line, sizeof line,
                  "gimm-dataset: %zu/%zu patients (%zu resumed, %zu failed), %.3f patients/s, "
                  "ETA %s   ",
                  done, mine.size(), summary.resumed, summary.failed, rate, eta.c_str());
    progress.show(line);
  }
  progress.finish();
  nlohmann::json manifest = {{"format", kDatasetFormat},
                             {"parameters", options.to_json()},
                             {"input", run.input},
                             {"patients", patients}};
  const DatasetWriter writer(out);
  if (shard.sharded())
    manifest["shard"] = {{"index", shard.index}, {"count", shard.count}};
  else
    writer.write_splits(patients);
  writer.write_manifest(manifest, shard);
  if (!shard.sharded()) export_if_asked(run.export_format, out);
  summary.patients = patients.size();
  summary.manifest = layout.manifest(shard);
  for (const auto& p : patients)
    if (p.value("status", "") == "ok")
      for (const auto& [name, sys] : p["systems"].items()) {
        summary.views += sys["views"].get<std::size_t>();
        summary.pairs += sys["pairs"].get<std::size_t>();
        summary.dense_labels += sys["dense_labels"].get<std::size_t>();
      }
  return summary;
}

/// `gimm-dataset merge`: joins the shard manifests of `out` (dataset/run.hpp merge_shards),
/// checking first that an export of `export_format` could name every patient.
inline MergedShards merge_dataset(const std::filesystem::path& out,
                                  const std::string& export_format) {
  return merge_shards(out, [&](const nlohmann::json& patients) {
    std::vector<std::string> ok_ids;
    for (const auto& p : patients)
      if (p.value("status", "") == "ok") ok_ids.push_back(p["id"].get<std::string>());
    detail::check_export_ids(export_format, ok_ids);
  });
}

}  // namespace gimm
