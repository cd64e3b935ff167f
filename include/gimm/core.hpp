#pragma once
/// The core room: errors and checks, Image, Volume, deterministic RNG, parallel-for.
#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/core/parallel.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/core/volume.hpp"
