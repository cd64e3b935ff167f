// Volumes and images from files, the procedural phantom, the LCA/RCA split, centerlines, the
// view protocol.
#include <pybind11/stl.h>

#include <filesystem>

#include "common.hpp"
#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/isocenter.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/skeleton.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/png.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/labels/protocol.hpp"
#include "gimm/labels/views.hpp"

namespace gimm::python {

py::dict centerlines_dict(const CenterlineTree& tree, std::optional<CoronarySystem> system) {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> radius;
  std::vector<std::int32_t> branch, index;
  for (std::size_t b = 0; b < tree.branches.size(); ++b) {
    const auto& br = tree.branches[b];
    if (system && br.system != *system) continue;
    for (std::size_t n = 0; n < br.points.size(); ++n) {
      points.push_back(br.points[n]);
      radius.push_back(br.radii[n]);
      branch.push_back(static_cast<std::int32_t>(b));
      index.push_back(static_cast<std::int32_t>(n));
    }
  }
  py::list names, systems;
  std::vector<std::int32_t> parents;
  for (const auto& br : tree.branches) {
    names.append(br.name);
    systems.append(to_string(br.system));
    parents.push_back(br.parent);
  }
  py::dict d;
  d["points"] = rows_to_numpy<3>(points);
  d["radius"] = adopt_vector(std::move(radius));
  d["branch"] = adopt_vector(std::move(branch));
  d["index"] = adopt_vector(std::move(index));
  d["branch_names"] = names;
  d["branch_systems"] = systems;
  d["branch_parents"] = adopt_vector(std::move(parents));
  return d;
}

namespace {

std::optional<CoronarySystem> optional_system(const py::object& system) {
  if (system.is_none()) return std::nullopt;
  return parse_coronary_system(system.cast<std::string>());
}

template <class T>
py::tuple read_as(const std::string& path) {
  Volume<T> v;
  {
    py::gil_scoped_release release;
    v = read_volume<T>(path);
  }
  py::dict geometry = geometry_dict(v.geometry());
  return py::make_tuple(adopt_volume(std::move(v)), geometry);
}

template <class T>
void write_as(const std::string& path, const py::handle& array, const VolumeGeometry& g,
              Accept accept, const std::string& description) {
  const Volume<T> v = volume_from<T>(array, g, accept, "write_nifti: volume");
  py::gil_scoped_release release;
  write_nifti(path, v, description);
}

py::dict view_class_dict(const ViewClass& v) {
  py::dict d;
  d["id"] = v.id;
  d["system"] = to_string(v.system);
  d["name"] = v.name;
  d["primary_deg"] = py::make_tuple(v.primary.lo, v.primary.hi);
  d["secondary_deg"] = py::make_tuple(v.secondary.lo, v.secondary.hi);
  return d;
}

}  // namespace

void bind_volumes(py::module_& m) {
  const char* geometry_doc =
      "geometry: dict(spacing (3,) mm, origin (3,) world mm of voxel (0, 0, 0), direction (3, 3) "
      "columns = world axes of i, j, k), e.g. as read_volume returns it; missing entries: 1 mm, "
      "0, identity.";
  // ---- files -------------------------------------------------------------------------------
  m.def(
      "read_volume",
      [](const std::filesystem::path& path, const std::string& dtype) {
        const std::string p = path.string();
        if (dtype == "float32") return read_as<float>(p);
        if (dtype == "int16") return read_as<std::int16_t>(p);
        if (dtype == "uint8") return read_as<std::uint8_t>(p);
        throw py::value_error("read_volume: dtype must be 'float32', 'int16' or 'uint8', got '" +
                              dtype + "'");
      },
      py::arg("path"), py::arg("dtype") = "float32", R"doc(
Reads a volume (NIfTI .nii/.nii.gz, NRRD .nrrd/.nhdr, MetaImage .mha/.mhd) into the LPS world.

Returns (array, geometry): array (nx, ny, nz) indexed [i, j, k], Fortran order, of dtype
'float32' (default), 'int16' or 'uint8' (converted from the file's type, scaled by the NIfTI
slope/intercept), a view of gimm's own buffer (no copy: array.base is the owning capsule);
geometry dict(dims, spacing (3,) mm, origin (3,) world mm of voxel (0, 0, 0), direction (3, 3)).
Raises gimm.IoError naming the file when it cannot be read, gimm.FormatError when malformed.)doc");
  m.def(
      "write_nifti",
      [](const std::filesystem::path& path, const py::handle& array, const py::object& geometry,
         const std::string& description) {
        const VolumeGeometry g = geometry_from(geometry);
        const py::array a = checked_array(array, 3, Accept::real, "write_nifti: volume");
        const std::string p = path.string();
        if (a.dtype().is(py::dtype::of<std::int16_t>()))
          write_as<std::int16_t>(p, a, g, Accept::real, description);
        else if (a.dtype().is(py::dtype::of<std::uint8_t>()) || a.dtype().is(py::dtype::of<bool>()))
          write_as<std::uint8_t>(p, a, g, Accept::mask, description);
        else
          write_as<float>(p, a, g, Accept::real, description);
      },
      py::arg("path"), py::arg("volume"), py::arg("geometry") = py::none(),
      py::arg("description") = "gimm",
      (std::string("Writes a volume [i, j, k] as NIfTI-1 (gzipped for .gz), atomically: int16 and "
                   "uint8/bool keep their type, anything else is written as float32. ") +
       geometry_doc)
          .c_str());
  m.def(
      "read_png",
      [](const std::filesystem::path& path) {
        Image<float> image;
        {
          py::gil_scoped_release release;
          image = read_png_unit(path);
        }
        return adopt_image(std::move(image));
      },
      py::arg("path"),
      "Reads an 8- or 16-bit PNG (grey or colour, made grey) as float32 (rows, cols) in [0, 1], as "
      "gimm-match reads its images (no copy of the decoded image).");
  m.def(
      "read_camera",
      [](const std::filesystem::path& path) {
        return camera_from_json(read_json_file(path), path.string());
      },
      py::arg("path"),
      "Reads a camera JSON file (as gimm-drr and gimm-dataset write them) into a Camera.");

  // ---- the phantom and the anatomy ---------------------------------------------------------
  m.def(
      "make_phantom",
      [](std::uint64_t seed, const std::string& size, const std::string& dominance,
         double noise_hu) {
        PhantomOptions o;
        o.seed = seed;
        o.size = parse_phantom_size(size);
        o.dominance = parse_dominance(dominance);
        o.noise_hu = noise_hu;
        Phantom p;
        {
          py::gil_scoped_release release;
          p = make_phantom(o);
        }
        py::dict d;
        d["geometry"] = geometry_dict(p.hu.geometry());
        d["hu"] = adopt_volume(std::move(p.hu));
        d["label"] = adopt_volume(std::move(p.label));
        py::dict lines;
        lines["LCA"] = centerlines_dict(p.centerlines, CoronarySystem::LCA);
        lines["RCA"] = centerlines_dict(p.centerlines, CoronarySystem::RCA);
        d["centerlines"] = lines;
        py::dict anatomy;
        anatomy["dominance"] = to_string(p.anatomy.dominance);
        anatomy["lumen_hu"] = p.anatomy.lumen_hu;
        anatomy["height_mm"] = p.anatomy.height_mm;
        anatomy["radius_mm"] = p.anatomy.radius_mm;
        anatomy["base_centre"] = to_numpy(p.anatomy.base_centre);
        anatomy["long_axis"] = to_numpy(p.anatomy.long_axis);
        d["anatomy"] = anatomy;
        return d;
      },
      py::arg("seed") = 0, py::arg("size") = "small", py::arg("dominance") = "auto",
      py::arg("noise_hu") = 15.0, R"doc(
A procedural CCTA patient (as gimm-phantom): size 'small' (128 x 128 x 64, 1.6 x 1.6 x 2 mm) or
'imagecas' (512 x 512 x 256, 0.4 x 0.4 x 0.5 mm); dominance 'auto' | 'right' | 'left' |
'codominant'; scanner noise sigma noise_hu (HU). Returns dict(hu int16 [i, j, k], label uint8
(1 = coronary), geometry, centerlines dict(LCA=..., RCA=...) of the analytic trees (see
extract_centerlines for the fields), anatomy dict). Arrays are views of gimm's buffers (no copy).)doc");
  m.def(
      "split_coronary_systems",
      [](const py::handle& label, const py::object& geometry, std::int64_t min_voxels,
         bool allow_single) {
        const Volume<std::uint8_t> v =
            volume_from<std::uint8_t>(label, geometry_from(geometry), Accept::mask, "label");
        SplitOptions o;
        o.min_voxels = min_voxels;
        o.allow_single = allow_single;
        CoronarySplit s;
        {
          py::gil_scoped_release release;
          s = split_coronary_systems(v, o, "label");
        }
        py::dict d;
        d["lca"] = adopt_volume(std::move(s.lca));
        d["rca"] = adopt_volume(std::move(s.rca));
        d["lca_voxels"] = s.lca_voxels;
        d["rca_voxels"] = s.rca_voxels;
        d["dropped_voxels"] = s.dropped_voxels;
        d["label_voxels"] = s.label_voxels;
        d["components"] = s.components;
        return d;
      },
      py::arg("label"), py::arg("geometry") = py::none(), py::kw_only(), py::arg("min_voxels") = 20,
      py::arg("allow_single") = false,
      (std::string("Splits a coronary label [i, j, k] (0/1) into the left and right trees (the two "
                   "largest 26-connected components; the LCA is the one further to the patient's "
                   "left, +x). Returns dict(lca, rca uint8 [i, j, k], lca_voxels, rca_voxels, "
                   "dropped_voxels, label_voxels, components). ") +
       geometry_doc)
          .c_str());
  m.def(
      "vessel_isocenter",
      [](const py::handle& mask, const py::object& geometry) {
        return to_numpy(vessel_isocenter(
            volume_from<std::uint8_t>(mask, geometry_from(geometry), Accept::mask, "mask"),
            "mask"));
      },
      py::arg("mask"), py::arg("geometry") = py::none(),
      "The centroid of a vessel mask's nonzero voxels, world mm (3,): gimm's C-arm isocentre "
      "(gimm-drr's and the dataset's default).");
  m.def(
      "extract_centerlines",
      [](const py::handle& mask, const py::object& geometry, const std::string& system,
         double min_spur_mm, double spur_radius_factor) {
        const Volume<std::uint8_t> v =
            volume_from<std::uint8_t>(mask, geometry_from(geometry), Accept::mask, "mask");
        SkeletonOptions o;
        o.system = parse_coronary_system(system);
        o.min_spur_mm = min_spur_mm;
        o.spur_radius_factor = spur_radius_factor;
        CenterlineTree tree;
        {
          py::gil_scoped_release release;
          tree = extract_centerlines(v, o, "mask");
        }
        return centerlines_dict(tree, std::nullopt);
      },
      py::arg("mask"), py::arg("geometry") = py::none(), py::kw_only(), py::arg("system") = "LCA",
      py::arg("min_spur_mm") = 3.0, py::arg("spur_radius_factor") = 2.5, R"doc(
Centerlines of one vessel system's mask [i, j, k] (thinning, branch graph, spurs pruned).

Centerline dicts (here and in make_phantom) hold every point of the tree, branch by branch from
proximal to distal: points (N, 3) world mm (LPS), radius (N,) lumen radius mm, branch (N,) int32
index into the branch lists, index (N,) int32 position within its branch; and per branch:
branch_names, branch_systems ('LCA'/'RCA') and branch_parents (int32, -1 for a root).)doc");

  // ---- the view protocol -------------------------------------------------------------------
  m.def(
      "routine_views",
      [] {
        py::list out;
        for (const auto& v : routine_views()) out.append(view_class_dict(v));
        return out;
      },
      "The 11 routine view classes: dicts(id 1..11, system, name, primary_deg (lo, hi), "
      "secondary_deg (lo, hi)) in degrees (+LAO/-RAO, +cranial/-caudal).");
  m.def(
      "view_class_from_angles",
      [](double primary_deg, double secondary_deg, const py::object& system) {
        const ViewClassMatch v =
            view_class_from_angles(optional_system(system), primary_deg, secondary_deg);
        return py::make_tuple(v.id, v.distance_deg);
      },
      py::arg("primary_deg"), py::arg("secondary_deg"), py::arg("system") = py::none(),
      "The routine view class nearest to a C-arm pose (degrees), among those of system 'LCA' or "
      "'RCA' (all eleven when None): (id 1..11, distance_deg), 0 inside the class's ranges.");
  m.def(
      "sample_view",
      [](int view_class_id, std::uint64_t seed, double jitter_deg) {
        Rng rng(seed);
        const SampledView v = sample_view(view_class(view_class_id), rng, jitter_deg);
        return py::make_tuple(v.primary_deg, v.secondary_deg);
      },
      py::arg("view_class"), py::arg("seed") = 0, py::arg("jitter_deg") = kViewJitterDeg,
      "Random angles (primary_deg, secondary_deg) of view class 1..11, uniform over its ranges "
      "widened by jitter_deg on both sides; deterministic per seed.");
  m.def(
      "plan_views",
      [](const std::string& system, const std::string& mode, std::uint64_t seed,
         double jitter_deg) {
        Rng rng(seed);
        const ViewPlan plan =
            plan_views(parse_coronary_system(system), parse_view_mode(mode), rng, jitter_deg);
        py::list views, pairs;
        for (const SampledView& v : plan.views)
          views.append(py::dict(py::arg("view_class") = v.view_class,
                                py::arg("primary_deg") = v.primary_deg,
                                py::arg("secondary_deg") = v.secondary_deg));
        for (const ViewPairIndex& p : plan.pairs) pairs.append(py::make_tuple(p.a, p.b));
        return py::dict(py::arg("views") = views, py::arg("pairs") = pairs);
      },
      py::arg("system"), py::kw_only(), py::arg("mode") = "shared", py::arg("seed") = 0,
      py::arg("jitter_deg") = kViewJitterDeg, R"doc(
The renders and pairs of one system, as gimm-dataset plans them (labels/protocol.hpp).
system: 'LCA' or 'RCA'; mode: 'shared' (one view per routine class of the system, every pair of
them: LCA 7 views / 21 pairs, RCA 4 / 6) or 'per_pair' (two fresh views for each pair).
Returns dict(views: [dict(view_class, primary_deg, secondary_deg)], pairs: [(a, b)] indices
into views, class A < class B). Deterministic per seed (gimm-dataset seeds each patient's plan
from its own stream).)doc");
}

}  // namespace gimm::python
