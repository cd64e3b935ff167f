#pragma once
/// The pipeline room: the end-to-end jobs (a patient, a sharded resumable dataset run, a
/// dataset matched and scored, the reference-layout export). Needs gimm::io and gimm::embree.
#include "gimm/pipeline/dataset_run.hpp"
#include "gimm/pipeline/eval_run.hpp"
#include "gimm/pipeline/match_run.hpp"
#include "gimm/pipeline/patient.hpp"
#include "gimm/pipeline/reference_export.hpp"
