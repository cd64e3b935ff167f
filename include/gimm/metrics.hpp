#pragma once
/// The metrics room: predicted matches (JSON), ground truth from a gimm-dataset directory, the
/// reference evaluation protocol, dataset summaries, and training-free baseline matchers.
#include "gimm/match/matches.hpp"
#include "gimm/metrics/baselines.hpp"
#include "gimm/metrics/protocol.hpp"
#include "gimm/metrics/summary.hpp"
#include "gimm/metrics/truth.hpp"
