#pragma once
/// Running a dataset in pieces: which shard a process is, the temporaries a killed run leaves,
/// whether a finished patient was made with the same parameters, and merging shard manifests.
/// Patient k (in id order) belongs to shard k mod N; a killed run started again skips finished
/// patients (their done.json), so any interleaving of kills, restarts and shards ends with the
/// same tree as one uninterrupted run.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/dataset/layout.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/dataset/writer.hpp"
#include "gimm/io/files.hpp"

namespace gimm {

namespace detail {
inline int parse_shard_int(const std::string& text, const std::string& what) {
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

inline std::string env_or_empty(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}
}  // namespace detail

/// This process's shard: `flag` ("I/N") if given, else SLURM_ARRAY_TASK_ID (minus
/// SLURM_ARRAY_TASK_MIN) of SLURM_ARRAY_TASK_COUNT, else JOB_COMPLETION_INDEX (Kubernetes
/// Indexed Job) of GIMM_SHARD_COUNT, else 0 of 1.
inline Shard resolve_shard(const std::string& flag) {
  using detail::env_or_empty;
  using detail::parse_shard_int;
  Shard s;
  if (!flag.empty()) {
    const auto slash = flag.find('/');
    GIMM_CHECK(slash != std::string::npos, "a shard must be I/N, got '" << flag << "'");
    s.index = parse_shard_int(flag.substr(0, slash), "shard index");
    s.count = parse_shard_int(flag.substr(slash + 1), "shard count");
  } else if (!env_or_empty("SLURM_ARRAY_TASK_ID").empty()) {
    s.index = parse_shard_int(env_or_empty("SLURM_ARRAY_TASK_ID"), "SLURM_ARRAY_TASK_ID");
    GIMM_CHECK(!env_or_empty("SLURM_ARRAY_TASK_COUNT").empty(),
               "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not");
    s.count = parse_shard_int(env_or_empty("SLURM_ARRAY_TASK_COUNT"), "SLURM_ARRAY_TASK_COUNT");
    const std::string min = env_or_empty("SLURM_ARRAY_TASK_MIN");
    if (!min.empty()) s.index -= parse_shard_int(min, "SLURM_ARRAY_TASK_MIN");
  } else if (!env_or_empty("JOB_COMPLETION_INDEX").empty()) {
    s.index = parse_shard_int(env_or_empty("JOB_COMPLETION_INDEX"), "JOB_COMPLETION_INDEX");
    GIMM_CHECK(!env_or_empty("GIMM_SHARD_COUNT").empty(),
               "JOB_COMPLETION_INDEX is set but GIMM_SHARD_COUNT is not");
    s.count = parse_shard_int(env_or_empty("GIMM_SHARD_COUNT"), "GIMM_SHARD_COUNT");
  }
  GIMM_CHECK(s.count >= 1 && s.index >= 0 && s.index < s.count,
             "shard " << s.index << "/" << s.count << " is out of range (need 0 <= I < N)");
  return s;
}

/// A killed run can leave "<file>.tmp.<host>.<pid>" behind (write_file_atomic's temporaries,
/// and staging folders: a patient's, the reference export's); they are never read, and removing
/// them makes a resumed tree equal to an uninterrupted one. Only under `dir` and only what this
/// process would write: other shards may be writing theirs into the same output folder right
/// now. A prefix names top-level outputs only (files and staging folders); without one, the
/// files of the whole folder (a patient's) are swept.
inline void remove_stale_temporaries(const std::filesystem::path& dir,
                                     const std::string& name_prefix = "") {
  namespace fs = std::filesystem;
  if (!fs::is_directory(dir)) return;
  std::vector<fs::path> stale;
  const auto is_stale = [&](const fs::directory_entry& e) {
    const std::string name = e.path().filename().string();
    const bool kind = e.is_regular_file() || (!name_prefix.empty() && e.is_directory());
    return kind && name.rfind(name_prefix, 0) == 0 && is_temporary_name(name);
  };
  const auto scan = [&](auto entries) {
    for (const auto& e : entries)
      if (is_stale(e)) stale.push_back(e.path());
  };
  if (name_prefix.empty())
    scan(fs::recursive_directory_iterator(dir));
  else
    scan(fs::directory_iterator(dir));
  for (const auto& p : stale) fs::remove_all(p);
}

/// The outputs written once per run (not per patient): the manifest, and when not sharded the
/// splits and the reference export (its files, and its staging folder beside or inside it).
inline void remove_stale_run_temporaries(const DatasetLayout& layout, const Shard& shard) {
  remove_stale_temporaries(layout.root(),
                           layout.manifest(shard).filename().string() + kTemporaryMark);
  if (shard.sharded()) return;
  remove_stale_temporaries(layout.splits_dir());
  remove_stale_temporaries(layout.root(),
                           layout.reference_dir().filename().string() + kTemporaryMark);
  remove_stale_temporaries(layout.reference_dir(), StagedFolder::kInsidePrefix);
  remove_stale_temporaries(layout.reference_dir());
}

/// The first difference between two JSON values, as "path: stored there, wanted here"; empty
/// when they are equal.
inline std::string first_json_difference(const nlohmann::json& stored,
                                         const nlohmann::json& wanted) {
  const nlohmann::json patch = nlohmann::json::diff(stored, wanted);
  if (patch.empty()) return "";
  const std::string path = patch[0].at("path").get<std::string>();
  const nlohmann::json::json_pointer pointer(path);
  const std::string was = stored.contains(pointer) ? stored.at(pointer).dump() : "(none)";
  const std::string now = wanted.contains(pointer) ? wanted.at(pointer).dump() : "(none)";
  return path + ": " + was + " there, " + now + " here";
}

/// The record of a finished patient (its done.json without "run"), or null when it is not
/// finished. Its stale temporaries are removed either way. Throws when it was made with other
/// parameters than `run` (the manifest would describe files this run did not make).
inline nlohmann::json finished_patient(const DatasetLayout& layout, const std::string& patient,
                                       const nlohmann::json& run) {
  namespace fs = std::filesystem;
  const fs::path dir = layout.patient_dir(patient);
  remove_stale_temporaries(layout.patients_dir(), patient + kTemporaryMark);  // its staging folders
  remove_stale_temporaries(dir);  // files of a patient folder written in place (before staging)
  if (!fs::exists(layout.done_record(patient))) return nullptr;
  const std::string where = layout.done_record(patient).string();
  nlohmann::json record = read_json_file(layout.done_record(patient));
  GIMM_CHECK_AS(FormatError, record.is_object() && record.contains("run"),
                where << ": not a finished patient's record (an object with 'run'); remove the "
                         "patient's folder to make it again");
  const nlohmann::json stored = record.at("run");
  record.erase("run");
  const std::string difference = first_json_difference(stored, run);
  GIMM_CHECK(difference.empty(), "'" << dir.string() << "' was made with other parameters ("
                                     << difference << "); make this run into another folder, or "
                                     << "with the parameters it was made with");
  // It goes into the manifest as it is: the record must be this patient's, and finished.
  GIMM_CHECK_AS(
      FormatError,
      record.contains("id") && record.at("id") == patient && record.contains("status") &&
          record.at("status") == "ok",
      where << ": the record is not patient '" << patient << "' finished (id "
            << (record.contains("id") ? record.at("id").dump() : std::string("none")) << ", status "
            << (record.contains("status") ? record.at("status").dump() : std::string("none"))
            << "); remove the patient's folder to make it again");
  return record;
}

/// The shard manifests of `root` joined into one manifest (patients sorted by id, no "shard"),
/// nothing written yet (stale run temporaries aside). They must all be of one run: the same
/// parameters, input and shard count, every shard present once.
namespace detail {
/// The fields of a shard manifest that merge reads, with their types; patient records with a
/// folder-name id and a known split. (nlohmann::json's own exceptions name no file: the caller
/// adds it.)
inline void check_shard_fields(const nlohmann::json& m, const std::string& where) {
  GIMM_CHECK_AS(FormatError, m.contains("parameters") && m.contains("input"),
                where << ": a shard manifest needs 'parameters' and 'input'");
  const int count = m.at("shard").at("count").get<int>();
  const int index = m.at("shard").at("index").get<int>();
  GIMM_CHECK_AS(FormatError, count >= 1 && index >= 0 && index < count,
                where << ": shard " << index << " of " << count << " is out of range");
  const auto& list = m.at("patients");
  GIMM_CHECK_AS(FormatError, list.is_array(),
                where << ": 'patients' must be an array, got " << list.dump());
  for (std::size_t k = 0; k < list.size(); ++k) {
    const auto& p = list[k];
    const std::string at = where + ": 'patients'[" + std::to_string(k) + "]";
    GIMM_CHECK_AS(FormatError, p.is_object() && p.contains("id") && p.at("id").is_string(),
                  at << " must be an object with a string 'id', got " << p.dump());
    check_patient_name(p.at("id").get<std::string>(), at);
    if (p.contains("split")) {
      const auto& split = p.at("split");
      GIMM_CHECK_AS(FormatError,
                    split.is_string() && (split == "train" || split == "val" || split == "test"),
                    at << ": split must be train, val or test, got " << split.dump());
    }
  }
}
}  // namespace detail

struct MergedShards {
  nlohmann::json manifest;
  std::size_t shards = 0;
  std::vector<std::filesystem::path> shard_files;  ///< the shard manifests joined
};

inline MergedShards join_shards(const std::filesystem::path& root) {
  namespace fs = std::filesystem;
  GIMM_CHECK(fs::is_directory(root), "merge: '" << root.string() << "' is not a directory");
  const DatasetLayout layout(root);
  remove_stale_run_temporaries(layout, Shard{});
  std::vector<fs::path> shards;
  for (const auto& e : fs::directory_iterator(root)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(DatasetLayout::kShardManifestPrefix, 0) == 0 && !is_temporary_name(name))
      shards.push_back(e.path());
  }
  GIMM_CHECK(!shards.empty(), "merge: no manifest.shard-*.json in '" << root.string() << "'");
  std::sort(shards.begin(), shards.end());
  nlohmann::json merged, patients = nlohmann::json::array();
  int count = -1;
  std::vector<int> seen;
  std::map<std::string, std::pair<int, fs::path>> shard_of;  // patient id -> its shard, file
  for (const auto& path : shards) {
    const auto m = read_json_file(path);
    check_dataset_format(m, path.string());
    try {
      detail::check_shard_fields(m, path.string());
    } catch (const nlohmann::json::exception& e) {
      GIMM_FAIL("merge: '" << path.string() << "' is no shard manifest: " << e.what());
    }
    if (merged.is_null()) merged = m;
    GIMM_CHECK(m.at("parameters") == merged.at("parameters") &&
                   m.at("input") == merged.at("input") && m.at("format") == merged.at("format"),
               "merge: '" << path.string() << "' was made with other parameters than '"
                          << shards[0].string() << "'");
    const int this_count = m.at("shard").at("count").get<int>();
    GIMM_CHECK(count < 0 || this_count == count,
               "merge: '" << path.string() << "' is a shard of " << this_count << ", '"
                          << shards[0].string() << "' of " << count
                          << " (a stale manifest of another sharding? remove it)");
    count = this_count;
    const int index = m.at("shard").at("index").get<int>();
    GIMM_CHECK(std::find(seen.begin(), seen.end(), index) == seen.end(),
               "merge: shard " << index << " appears twice in '" << root.string() << "'");
    seen.push_back(index);
    for (const auto& p : m.at("patients")) {
      const std::string id = p.at("id").get<std::string>();
      const auto [it, fresh] = shard_of.emplace(id, std::pair{index, path});
      GIMM_CHECK_AS(FormatError, fresh,
                    "merge: patient '" << id << "' is in '" << it->second.second.string()
                                       << "' and in '" << path.string() << "'");
      patients.push_back(p);
    }
  }
  std::sort(seen.begin(), seen.end());
  for (int i = 0; i < count; ++i)
    GIMM_CHECK(
        std::binary_search(seen.begin(), seen.end(), i),
        "merge: shard " << i << " of " << count << " is missing in '" << root.string() << "'");
  std::sort(patients.begin(), patients.end(), [](const auto& a, const auto& b) {
    return a["id"].template get<std::string>() < b["id"].template get<std::string>();
  });
  // Patient k (in id order) is shard k mod N's: a patient lost from one shard's manifest, or
  // one its shard did not make, shows as the first patient out of place.
  for (std::size_t k = 0; k < patients.size(); ++k) {
    const std::string id = patients[k]["id"].get<std::string>();
    const auto& [index, path] = shard_of.at(id);
    GIMM_CHECK_AS(FormatError, index == static_cast<int>(k % static_cast<std::size_t>(count)),
                  "merge: patient '" << id << "' (number " << k << " in id order) belongs to shard "
                                     << k % static_cast<std::size_t>(count) << " of " << count
                                     << ", but '" << path.string() << "' (shard " << index
                                     << ") lists it: a patient is missing or misplaced");
  }
  merged["patients"] = patients;
  merged.erase("shard");
  return {merged, shards.size(), shards};
}

}  // namespace gimm
