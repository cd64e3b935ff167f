#pragma once
/// The core room: errors and checks, constants, Image, grey morphology, Volume, deterministic RNG,
/// stable hash, parallel-for.
#include "gimm/core/constants.hpp"
#include "gimm/core/distance_transform.hpp"
#include "gimm/core/error.hpp"
#include "gimm/core/hash.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/morphology.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/core/volume.hpp"
