// The costly double instantiations of gimm/geometry/epipolar.hpp, compiled once for gimm's own
// binaries (tests, examples, benchmarks, the Python module). The header declares them extern
// under GIMM_EXTERN_INSTANCES, so no other translation unit re-instantiates the Eigen
// decompositions inside (docs/performance.md, "Build time"). One file per header, and the DLT
// apart (triangulation_dlt.cpp): they compile in parallel. The public headers stay header-only.
#include "gimm/geometry/epipolar.hpp"

namespace gimm {
GIMM_EPIPOLAR_INSTANCES()
}  // namespace gimm
