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
#include "gimm/labels/view_protocol.hpp"
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

/// read_volume (any format, by the name) or read_nifti (NIfTI only) as (array, geometry).
template <class T>
py::tuple read_as(const std::string& path, bool nifti_only) {
  Volume<T> v;
  {
    py::gil_scoped_release release;
    v = nifti_only ? read_nifti<T>(path) : read_volume<T>(path);
  }
  py::dict geometry = geometry_dict(v.geometry());
  return py::make_tuple(adopt_volume(std::move(v)), geometry);
}

template <class T>
void write_as(const std::string& path, const py::handle& array, const py::object& geometry,
              Accept accept, const std::string& description) {
  const VolumeInput<T> in = volume_arg<T>(array, {geometry}, accept, "write_nifti: volume");
  py::gil_scoped_release release;
  write_nifti(path, in.volume, description);
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

/// natural_dtype of an array or tensor; "" for anything else (the reader then names what it got).
std::string natural_dtype_of(const py::handle& obj) {
  if (!py::isinstance<py::array>(obj) && !py::hasattr(obj, "__array__")) return "";
  return natural_dtype(py::module_::import("numpy").attr("asarray")(obj));
}

/// gimm.Volume(array, geometry, ...): float32 unless dtype says uint8 or the array is a mask.
PyVolume make_py_volume(const py::handle& array, const py::object& geometry,
                        const py::object& spacing, const py::object& origin,
                        const py::object& direction, const py::object& dtype) {
  const VolumeGeometry g = geometry_from(geometry, spacing, origin, direction);
  std::string kind = dtype.is_none() ? "" : py::str(dtype).cast<std::string>();
  if (kind.empty()) kind = natural_dtype_of(array);
  if (kind.empty() || kind == "float32")
    return PyVolume{volume_in<float>(array, g, Accept::real, "Volume")};
  if (kind == "int16") return PyVolume{volume_in<std::int16_t>(array, g, Accept::real, "Volume")};
  if (kind == "uint8") return PyVolume{volume_in<std::uint8_t>(array, g, Accept::mask, "Volume")};
  throw py::value_error("Volume: dtype must be 'float32', 'int16' or 'uint8', got '" + kind + "'");
}

/// The voxels as an array: the caller's array for a view, else one over the owned copy whose
/// base is the gimm.Volume (which the array keeps alive).
py::array voxels_of(const py::object& self) {
  const PyVolume& v = self.cast<const PyVolume&>();
  if (v.is_view()) return std::visit([](const auto& in) { return in.array; }, v.in);
  return std::visit(
      [&](const auto& in) -> py::array {
        using T = std::remove_const_t<std::remove_pointer_t<decltype(in.volume.data())>>;
        const py::ssize_t s = sizeof(T), nx = in.volume.nx(), ny = in.volume.ny();
        return py::array_t<T>({nx, ny, static_cast<py::ssize_t>(in.volume.nz())},
                              {s, s * nx, s * nx * ny}, in.volume.data(), self);
      },
      v.in);
}

double voxel_at(const PyVolume& v, const py::tuple& ijk) {
  if (ijk.size() != 3) throw py::index_error("Volume: index must be (i, j, k)");
  const int i = ijk[0].cast<int>(), j = ijk[1].cast<int>(), k = ijk[2].cast<int>();
  return std::visit(
      [&](const auto& in) -> double {
        if (!in.volume.contains(i, j, k))
          throw py::index_error("Volume: voxel (" + std::to_string(i) + ", " + std::to_string(j) +
                                ", " + std::to_string(k) + ") is outside the grid");
        return static_cast<double>(in.volume(i, j, k));
      },
      v.in);
}

}  // namespace

void bind_volumes(py::module_& m) {
  const char* geometry_doc =
      "geometry: dict(spacing (3,) mm, origin (3,) world mm of voxel (0, 0, 0), direction (3, 3) "
      "columns = world axes of i, j, k), e.g. as read_volume returns it; missing entries: 1 mm, "
      "0, identity.";
  // ---- gimm.Volume: an array and its geometry, read in place ------------------------------
  py::class_<PyVolume>(m, "Volume", R"doc(
A volume with its geometry, read by gimm in place of the caller's array where the layout allows.

Volume(array, geometry=None, *, spacing=None, origin=None, direction=None, dtype=None)

array: (nx, ny, nz) indexed [i, j, k]. dtype: 'float32' (a CT in HU, or attenuation), 'int16'
(a CT in HU, as CCTAs are stored) or 'uint8' (a mask); None: 'uint8' for bool and uint8 arrays,
'int16' for int16 arrays, else 'float32'. Geometry as read_volume
returns it, or spacing (3,) mm, origin (3,) world mm of voxel (0, 0, 0), direction (3, 3).

No copy (is_view True) when the array already is gimm's layout: the dtype asked for (bool too
for uint8), Fortran order (i fastest: read_volume's arrays, numpy.asfortranarray(a), or the .T of
a C-ordered (z, y, x) ITK array) and writeable. gimm then reads the caller's buffer, which the
Volume keeps alive; writes to the array are seen by gimm. Otherwise (C order, other dtypes such
as float64, int32, or int16 asked to be float32; a read-only array) one converted copy is made,
once, here.
Renderer, split_coronary_systems and the other volume functions take a Volume or an array;
an array is read the same way at each call.)doc")
      .def(py::init(&make_py_volume), py::arg("array"), py::arg("geometry") = py::none(),
           py::kw_only(), py::arg("spacing") = py::none(), py::arg("origin") = py::none(),
           py::arg("direction") = py::none(), py::arg("dtype") = py::none())
      .def_property_readonly("is_view", &PyVolume::is_view,
                             "True when gimm reads the caller's array (no copy was made).")
      .def_property_readonly("dtype", &PyVolume::dtype, "'float32', 'int16' or 'uint8'.")
      .def_property_readonly(
          "shape",
          [](const PyVolume& v) {
            const auto& d = v.geometry().dims;
            return py::make_tuple(d[0], d[1], d[2]);
          },
          "(nx, ny, nz).")
      .def_property_readonly(
          "geometry", [](const PyVolume& v) { return geometry_dict(v.geometry()); },
          "dict(dims, spacing, origin, direction), as read_volume returns it.")
      .def_property_readonly("array", &voxels_of,
                             "The voxels gimm reads, (nx, ny, nz) Fortran order: the caller's "
                             "array for a view, else an array over gimm's copy.")
      .def("__getitem__", &voxel_at, py::arg("ijk"),
           "The voxel (i, j, k) as gimm reads it (a float).")
      .def(
          "sample",
          [](const PyVolume& v, const py::handle& world) {
            const Eigen::Vector3d x = fixed<3, 1>(world, "sample: world");
            return std::visit([&](const auto& in) { return in.volume.sample_world(x); }, v.in);
          },
          py::arg("world_mm"),
          "Trilinear value at a world point (mm, LPS); 0 outside the voxel model.")
      .def("__repr__", [](const PyVolume& v) {
        const auto& d = v.geometry().dims;
        return "gimm.Volume(" + std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" +
               std::to_string(d[2]) + ", " + v.dtype() + (v.is_view() ? ", view)" : ", copy)");
      });

  // ---- files -------------------------------------------------------------------------------
  const auto reader = [](const char* name, bool nifti_only) {
    return [name, nifti_only](const std::filesystem::path& path, const std::string& dtype) {
      const std::string p = path.string();
      if (dtype == "float32") return read_as<float>(p, nifti_only);
      if (dtype == "int16") return read_as<std::int16_t>(p, nifti_only);
      if (dtype == "uint8") return read_as<std::uint8_t>(p, nifti_only);
      throw py::value_error(std::string(name) +
                            ": dtype must be 'float32', 'int16' or 'uint8', got '" + dtype + "'");
    };
  };
  m.def("read_nifti", reader("read_nifti", true), py::arg("path"), py::arg("dtype") = "float32",
        "read_volume for NIfTI-1 files only (.nii, .nii.gz, whatever the name): (array, "
        "geometry), the same arrays and errors.");
  m.def("read_volume", reader("read_volume", false), py::arg("path"), py::arg("dtype") = "float32",
        R"doc(
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
        const std::string p = path.string();
        // A gimm.Volume keeps its dtype; an array its natural one (int16, uint8/bool, float32).
        const std::string kind = py::isinstance<PyVolume>(array)
                                     ? std::string(array.cast<const PyVolume&>().dtype())
                                     : natural_dtype_of(array);
        if (kind == "int16")
          write_as<std::int16_t>(p, array, geometry, Accept::real, description);
        else if (kind == "uint8")
          write_as<std::uint8_t>(p, array, geometry, Accept::mask, description);
        else
          write_as<float>(p, array, geometry, Accept::real, description);
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
         double noise_hu, const std::string& tree) {
        PhantomOptions o;
        o.seed = seed;
        o.size = parse_phantom_size(size);
        o.tree = parse_tree_detail(tree);
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
      py::arg("noise_hu") = 15.0, py::arg("tree") = "classic", R"doc(
A procedural CCTA patient (as gimm-phantom): size 'small' (128 x 128 x 64, 1.6 x 1.6 x 2 mm),
'imagecas' (512 x 512 x 256, 0.4 x 0.4 x 0.5 mm) or 'chest' (the whole chest around the same
heart, 224 x 165 x 190 at 1.6 x 1.6 x 2 mm; docs/phantom.md); dominance 'auto' | 'right' | 'left' |
'codominant'; scanner noise sigma noise_hu (HU); tree 'classic' (10-12 branches) or 'rich' (side
branches and Murray's-law calibres, 20-29 branches; docs/phantom.md). Returns dict(hu int16 [i, j, k], label uint8
(1 = coronary), geometry, centerlines dict(LCA=..., RCA=...) of the analytic trees (see
extract_centerlines for the fields), anatomy dict). Arrays are views of gimm's buffers (no copy).)doc");
  m.def(
      "split_coronary_systems",
      [](const py::handle& label, const py::object& geometry, std::int64_t min_voxels,
         bool allow_single) {
        const VolumeInput<std::uint8_t> in =
            volume_arg<std::uint8_t>(label, {geometry}, Accept::mask, "label");
        SplitOptions o;
        o.min_voxels = min_voxels;
        o.allow_single = allow_single;
        CoronarySplit s;
        {
          py::gil_scoped_release release;
          s = split_coronary_systems(in.volume, o, "label");
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
        const VolumeInput<std::uint8_t> in =
            volume_arg<std::uint8_t>(mask, {geometry}, Accept::mask, "mask");
        return to_numpy(vessel_isocenter(in.volume, "mask"));
      },
      py::arg("mask"), py::arg("geometry") = py::none(),
      "The centroid of a vessel mask's nonzero voxels, world mm (3,): gimm's C-arm isocentre "
      "(gimm-drr's and the dataset's default).");
  m.def(
      "extract_centerlines",
      [](const py::handle& mask, const py::object& geometry, const std::string& system,
         double min_spur_mm, double spur_radius_factor) {
        const VolumeInput<std::uint8_t> in =
            volume_arg<std::uint8_t>(mask, {geometry}, Accept::mask, "mask");
        SkeletonOptions o;
        o.system = parse_coronary_system(system);
        o.min_spur_mm = min_spur_mm;
        o.spur_radius_factor = spur_radius_factor;
        CenterlineTree tree;
        {
          py::gil_scoped_release release;
          tree = extract_centerlines(in.volume, o, "mask");
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
The renders and pairs of one system, as gimm-dataset plans them (labels/view_protocol.hpp).
system: 'LCA' or 'RCA'; mode: 'shared' (one view per routine class of the system, every pair of
them: LCA 7 views / 21 pairs, RCA 4 / 6) or 'per_pair' (two fresh views for each pair).
Returns dict(views: [dict(view_class, primary_deg, secondary_deg)], pairs: [(a, b)] indices
into views, class A < class B). Deterministic per seed (gimm-dataset seeds each patient's plan
from its own stream).)doc");
}

}  // namespace gimm::python
