#pragma once
/// A whole dataset run from C++: the patients of this shard, resumed where a killed run stopped,
/// a progress line, the manifest, the splits and, if asked, the reference export. gimm-dataset is
/// argument parsing around run_dataset and merge_dataset.
///
/// What a run leaves when it fails (all or nothing, as far as resuming allows):
///   - A patient's folder is there whole or not at all (generate_patient stages it).
///   - A bad input fails its patient only: recorded as failed, the run goes on. An output that
///     cannot be written (WriteError: a full disk, no permission) stops the run: the patient
///     being made is removed, and no manifest or split list is written.
///   - The manifest, the split lists and the reference export are written to temporaries and a
///     staging folder and renamed into place together at the end: before that, those already
///     there are as they were.
///   - The patients finished before the failure stay, as after a kill: a rerun skips them. So a
///     run that fails in its first patient leaves nothing, and the folders it made go too; a
///     dataset that was there before gains whole patients at most.
///
///   std::vector<gimm::PatientSource> sources = gimm::scan_imagecas_folder("ImageCAS/");
///   gimm::DatasetRunOptions run;
///   run.shard = gimm::resolve_shard("");          // Slurm / Kubernetes indices, or 0 of 1
///   const auto summary = gimm::run_dataset(sources, options, "out/", run);
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gimm/core/progress.hpp"
#include "gimm/dataset/run.hpp"
#include "gimm/dataset/writer.hpp"
#include "gimm/pipeline/patient.hpp"
#include "gimm/pipeline/reference_export.hpp"
#include "gimm/pipeline/run_report.hpp"

namespace gimm {

struct DatasetRunOptions {
  Shard shard;
  RunReporter report;         ///< where messages go; empty: stderr_reporter(quiet)
  bool quiet = false;         ///< no progress line, no per-patient lines
  std::string export_format;  ///< "" or "reference" (OUT/reference; not with shards)
  nlohmann::json input;       ///< what the patients came from, for the manifest
  /// "" or a file outside `out` that gets one JSON line per patient made: its id and stage
  /// seconds (appended; they vary run to run, so they stay out of the dataset).
  std::filesystem::path timings_file;
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
  if (!format.empty()) reference_format::check_patient_ids(ids, "the " + format + " export");
}

inline void check_export_views(const std::string& format, const nlohmann::json& parameters) {
  if (!format.empty())
    reference_format::check_views_exportable(parameters, "the " + format + " export");
}

}  // namespace detail

/// The run's own files, all or none: the manifest and, for a whole run (not a shard), the split
/// lists and the export asked for ("" or "reference": OUT/reference, from `manifest`). They are
/// written to temporaries and a staging folder and renamed into place together, the manifest
/// last; on a failure those already there are left as they were.
inline void write_run_files(const std::filesystem::path& out, const nlohmann::json& manifest,
                            const Shard& shard, const std::string& export_format,
                            const RunReporter& report) {
  const DatasetWriter writer(out);
  const DatasetLayout& layout = writer.layout();
  StagedFiles files;
  writer.stage_run_files(files, manifest, shard);
  std::optional<StagedFolder> reference;
  if (!export_format.empty()) {
    reference.emplace(layout.reference_dir());
    export_reference(out, manifest, layout.manifest(shard).string(), reference->dir());
    reference->commit();
  }
  files.commit();
  if (reference) report(RunMessage::info, "reference layout -> " + layout.reference_dir().string());
}

namespace detail {

/// What a run refuses before any work: an export from a shard, ids or views an export cannot
/// name, a timings file inside the (byte-reproducible) dataset.
inline void check_run(const std::vector<PatientSource>& sources, const DatasetOptions& options,
                      const std::filesystem::path& out, const DatasetRunOptions& run) {
  const Shard& shard = run.shard;
  GIMM_CHECK(!shard.sharded() || run.export_format.empty(),
             "an export (" << run.export_format << ") from shard " << shard.index << "/"
                           << shard.count << ": export after merging the shards");
  std::vector<std::string> ids;
  for (const auto& s : sources) ids.push_back(s.id);
  check_export_ids(run.export_format, ids);
  check_export_views(run.export_format, options.to_json());
  GIMM_CHECK(
      run.timings_file.empty() || !path_is_within(run.timings_file, out),
      "the timings file " << run.timings_file.string() << " lies inside the dataset "
                          << out.string()
                          << ": the dataset is byte-reproducible and wall-clock seconds are not; "
                             "write them elsewhere");
}

/// The timings file, opened for appending (closed when none is asked for).
inline std::ofstream open_timings(const std::filesystem::path& file) {
  std::ofstream timings;
  if (file.empty()) return timings;
  timings.open(file, std::ios::app);
  GIMM_CHECK_AS(WriteError, timings.good(),
                "cannot open the timings file '" << file.string()
                                                 << "' for appending: " << std::strerror(errno));
  return timings;
}

/// Makes one patient and returns its manifest record: "failed" with the error when its input
/// fails; a WriteError stops the run (rethrown after saying so).
inline nlohmann::json make_patient(const PatientSource& src, const DatasetOptions& options,
                                   const std::filesystem::path& out, const DatasetRunOptions& run,
                                   const RunReporter& report, std::ofstream& timings,
                                   DatasetRunSummary& summary) {
  try {
    PatientTimings t;
    nlohmann::json record = generate_patient(src, options, out, &t);
    summary.made += t;
    if (!run.quiet) report(RunMessage::info, "patient " + src.id + ": " + t.summary());
    if (timings.is_open()) {
      nlohmann::json line = t.to_json();
      line["id"] = src.id;
      timings << line.dump() << "\n" << std::flush;
      GIMM_CHECK_AS(WriteError, timings.good(),
                    "cannot write the timings file '" << run.timings_file.string() << "'");
    }
    const std::string warning = dropped_voxels_warning(record, options);
    if (!warning.empty()) report(RunMessage::warning, warning);
    return record;
  } catch (const WriteError&) {
    // Every later write would fail the same way: recording this patient as failed would put a
    // full disk into the manifest. Stop; the error names the file and the reason.
    report(RunMessage::info, "patient " + src.id +
                                 " not made: its files cannot be written; stopping (patients "
                                 "finished so far are kept, and a rerun resumes after them)");
    report(RunMessage::end, "");
    throw;
  } catch (const std::exception& e) {
    ++summary.failed;
    report(RunMessage::error, "patient " + src.id + " failed: " + e.what());
    return {{"id", src.id}, {"status", "failed"}, {"error", e.what()}};
  }
}

/// "done/total patients (resumed, failed), rate, ETA"; the rate counts the patients made in
/// this run, not the ones found finished.
inline std::string run_progress(std::size_t done, std::size_t total,
                                const DatasetRunSummary& summary,
                                std::chrono::steady_clock::time_point t0) {
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::size_t made = done - summary.resumed;
  const double rate = made / std::max(s, 1e-9);
  std::string eta = "?";
  if (made > 0) eta = std::to_string(std::llround((total - done) / rate)) + " s";
  char line[200];
  std::snprintf(line, sizeof line,
                "%zu/%zu patients (%zu resumed, %zu failed), %.3f patients/s, ETA %s   ", done,
                total, summary.resumed, summary.failed, rate, eta.c_str());
  return line;
}

/// The views, pairs and dense labels of the patients made ("ok").
inline void count_made(const nlohmann::json& patients, DatasetRunSummary& summary) {
  summary.patients = patients.size();
  for (const auto& p : patients)
    if (p.value("status", "") == "ok")
      for (const auto& [name, sys] : p["systems"].items()) {
        summary.views += sys["views"].get<std::size_t>();
        summary.pairs += sys["pairs"].get<std::size_t>();
        summary.dense_labels += sys["dense_labels"].get<std::size_t>();
      }
}

}  // namespace detail

/// Makes the patients of `run.shard` among `sources` into `out` (see the file comment). A
/// patient whose input fails is recorded as failed with its error; the others go on. A
/// WriteError stops the run (the file comment says what it leaves).
inline DatasetRunSummary run_dataset(std::vector<PatientSource> sources,
                                     const DatasetOptions& options,
                                     const std::filesystem::path& out,
                                     const DatasetRunOptions& run) {
  namespace fs = std::filesystem;
  const Shard& shard = run.shard;
  detail::check_run(sources, options, out, run);
  assign_splits(sources, options);
  const DatasetLayout layout(out);
  CreatedFolders folders;  // removed again (while empty) if the run fails
  folders.create(layout.patients_dir());
  {  // fail early, before any work, if the output is not writable
    const fs::path probe = out / (".write-test." + process_tag());
    write_file_atomic(probe, std::string("ok"));
    fs::remove(probe);
  }
  std::ofstream timings = detail::open_timings(run.timings_file);
  std::vector<const PatientSource*> mine;
  for (std::size_t k = 0; k < sources.size(); ++k)
    if (static_cast<int>(k % shard.count) == shard.index) mine.push_back(&sources[k]);
  // Resuming: finished patients must have been made with these parameters; unfinished ones lose
  // their temporaries.
  remove_stale_run_temporaries(layout, shard);
  std::vector<nlohmann::json> finished(mine.size());  // all checked before any work
  for (std::size_t m = 0; m < mine.size(); ++m)
    finished[m] = finished_patient(layout, mine[m]->id, patient_run(*mine[m], options));
  DatasetRunSummary summary;
  nlohmann::json patients = nlohmann::json::array();
  const auto t0 = std::chrono::steady_clock::now();
  const RunReporter report = run.report ? run.report : stderr_reporter(run.quiet);
  for (std::size_t m = 0; m < mine.size(); ++m) {
    nlohmann::json record = finished[m];
    if (!record.is_null())
      ++summary.resumed;
    else
      record = detail::make_patient(*mine[m], options, out, run, report, timings, summary);
    patients.push_back(record);
    if (!run.quiet)
      report(RunMessage::progress, detail::run_progress(m + 1, mine.size(), summary, t0));
  }
  report(RunMessage::end, "");
  nlohmann::json manifest = {{"format", kDatasetFormat},
                             {"images", dataset_images(options.form_angiogram)},
                             {"parameters", options.to_json()},
                             {"input", run.input},
                             {"patients", patients}};
  if (shard.sharded()) manifest["shard"] = {{"index", shard.index}, {"count", shard.count}};
  write_run_files(out, manifest, shard, run.export_format, report);
  folders.keep();
  summary.manifest = layout.manifest(shard);
  detail::count_made(patients, summary);
  return summary;
}

/// `gimm-dataset merge`: joins the shard manifests of `out` (dataset/run.hpp join_shards),
/// checks that an export of `export_format` could name every patient, writes the manifest, the
/// split lists and the export together (write_run_files), and only then removes the shard
/// manifests: a merge that fails leaves `out` as it was.
inline MergedShards merge_dataset(const std::filesystem::path& out,
                                  const std::string& export_format,
                                  const RunReporter& report = stderr_reporter(false)) {
  MergedShards merged = join_shards(out);
  std::vector<std::string> ok_ids;
  for (const auto& p : merged.manifest.at("patients"))
    if (p.value("status", "") == "ok") ok_ids.push_back(p["id"].get<std::string>());
  detail::check_export_ids(export_format, ok_ids);
  detail::check_export_views(export_format, merged.manifest.value("parameters", nlohmann::json{}));
  write_run_files(out, merged.manifest, Shard{}, export_format, report);
  for (const auto& path : merged.shard_files) std::filesystem::remove(path);
  return merged;
}

}  // namespace gimm
