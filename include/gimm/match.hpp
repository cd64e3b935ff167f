#pragma once
/// The match room: every matcher behind one interface (match/pair_matcher.hpp), the predictions
/// format, the learned matcher with its gating, the geometric matcher (vesselness, 2D
/// centerlines, epipolar DP) and the training-free baselines.
#include "gimm/match/baselines.hpp"
#include "gimm/match/centerline_graph.hpp"
#include "gimm/match/geometric.hpp"
#include "gimm/match/learned.hpp"
#include "gimm/match/learned_options.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/match/network_input.hpp"
#include "gimm/match/pair_matcher.hpp"
#include "gimm/match/vesselness.hpp"
