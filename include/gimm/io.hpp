#pragma once
/// The io room (target gimm::io): JSON records, volumes (NIfTI, NRRD, MetaImage; read_volume
/// picks by name), PNG and NPY images, gzip, atomic files.
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/gzip.hpp"
#include "gimm/io/header_text.hpp"
#include "gimm/io/metaimage.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/npy.hpp"
#include "gimm/io/nrrd.hpp"
#include "gimm/io/png.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/io/voxel_data.hpp"
