#pragma once
/// The metrics room: the paper's evaluation protocol, ground truth from a gimm dataset, top-K
/// curves, dataset summaries and the gimm-eval/1 report (scoring only).
#include "gimm/metrics/protocol.hpp"
#include "gimm/metrics/report.hpp"
#include "gimm/metrics/summary.hpp"
#include "gimm/metrics/tree_error.hpp"
#include "gimm/metrics/truth.hpp"
#include "gimm/metrics/user_truth.hpp"
