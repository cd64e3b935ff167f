#pragma once
/// The match room: every matcher behind one interface (match/matcher.hpp), the predictions
/// format, the learned matcher with its gating, and the training-free baselines.
#include "gimm/match/baselines.hpp"
#include "gimm/match/learned.hpp"
#include "gimm/match/matcher.hpp"
#include "gimm/match/matches.hpp"
