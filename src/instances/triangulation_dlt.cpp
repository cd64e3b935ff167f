// The DLT's double instantiation (gimm/geometry/triangulation.hpp), compiled once for gimm's
// own binaries, in a file of its own: its dynamic-size SVD takes as long to compile as the rest
// of the header's instances (triangulation.cpp), and the two compile in parallel
// (docs/performance.md, "Build time").
#include "gimm/geometry/triangulation.hpp"

namespace gimm {
GIMM_TRIANGULATION_DLT_INSTANCES()
}  // namespace gimm
