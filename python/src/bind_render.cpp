// gimm.Renderer (render/view_renderer.hpp) and the per-view and per-pair labels.
#include <pybind11/stl.h>

#include "common.hpp"
#include "gimm/anatomy/attenuation.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/labels/correspondence.hpp"
#include "gimm/render/view_renderer.hpp"
#ifdef GIMM_PYTHON_HAVE_EMBREE
#include "gimm/render/vessel_mesh_projector.hpp"
#endif

namespace gimm::python {

namespace {

ContrastRecipe recipe_from(const py::handle& obj) {
  ContrastRecipe r;
  if (py::isinstance<py::str>(obj)) {
    r.preset = parse_contrast_preset(obj.cast<std::string>());
    return r;
  }
  if (!py::isinstance<py::dict>(obj))
    throw py::type_error("recipe: expected 'angiography', 'reference', 'none' or a dict");
  const py::dict d = py::reinterpret_borrow<py::dict>(obj);
  struct Field {
    const char* name;
    double ContrastRecipe::*member;
  };
  static const Field fields[] = {
      {"mu_water", &ContrastRecipe::mu_water},
      {"reference_soft_threshold_hu", &ContrastRecipe::reference_soft_threshold_hu},
      {"reference_soft_factor", &ContrastRecipe::reference_soft_factor},
      {"reference_coronary_boost", &ContrastRecipe::reference_coronary_boost},
      {"reference_bone_threshold_hu", &ContrastRecipe::reference_bone_threshold_hu},
      {"reference_bone_weight", &ContrastRecipe::reference_bone_weight},
      {"lumen_hu", &ContrastRecipe::lumen_hu},
      {"blood_pool_lo_hu", &ContrastRecipe::blood_pool_lo_hu},
      {"bone_hu", &ContrastRecipe::bone_hu},
      {"bone_shell_margin_hu", &ContrastRecipe::bone_shell_margin_hu},
      {"bone_texture_hu", &ContrastRecipe::bone_texture_hu},
      {"split_neck_mm", &ContrastRecipe::split_neck_mm},
      {"native_blood_hu", &ContrastRecipe::native_blood_hu},
      {"soft_weight", &ContrastRecipe::soft_weight},
      {"bone_weight", &ContrastRecipe::bone_weight},
  };
  for (const auto& [key, value] : d) {
    const std::string k = key.cast<std::string>();
    if (k == "preset") {
      r.preset = parse_contrast_preset(value.cast<std::string>());
      continue;
    }
    bool known = false;
    for (const Field& f : fields)
      if (k == f.name) {
        r.*(f.member) = value.cast<double>();
        known = true;
      }
    if (!known) {
      std::string names = "preset";
      for (const Field& f : fields) names += std::string(", ") + f.name;
      throw py::value_error("recipe: unknown field '" + k + "' (fields: " + names + ")");
    }
  }
  return r;
}

/// `intensity`: Beer-Lambert of the view, computed by the caller with the GIL released (empty:
/// not asked for).
py::dict rendered_dict(RenderedView&& view, Image<float>&& intensity) {
  py::dict d;
  if (!intensity.empty()) d["intensity"] = adopt_image(std::move(intensity));
  d["line_integrals"] = adopt_image(std::move(view.line_integrals));
  if (!view.vessel_mask.empty()) d["vessel_mask"] = adopt_image(std::move(view.vessel_mask));
  if (!view.overlap.empty()) d["overlap"] = adopt_image(std::move(view.overlap));
  if (!view.depth_mm.empty()) d["depth_mm"] = adopt_image(std::move(view.depth_mm));
  return d;
}

/// Centerline points from a centerline dict (points, and radius/branch/index when present) or
/// an (N, 3) array of world points.
std::vector<LabelPoint> label_points(const py::handle& obj) {
  py::object points = py::reinterpret_borrow<py::object>(obj);
  py::dict d;
  if (py::isinstance<py::dict>(obj)) {
    d = py::reinterpret_borrow<py::dict>(obj);
    if (!d.contains("points"))
      throw py::value_error("points: a centerline dict needs 'points' (N, 3)");
    points = d["points"];
  }
  const auto X = rows_of(points, 3, "points");
  std::vector<LabelPoint> out(static_cast<std::size_t>(X.rows()));
  for (Eigen::Index n = 0; n < X.rows(); ++n) out[static_cast<std::size_t>(n)].world = X.row(n);
  const auto column = [&](const char* key, auto set) {
    if (!d.contains(key)) return;
    const Eigen::VectorXd v = vector_of(d[key], key);
    if (v.size() != X.rows())
      throw py::value_error(std::string("points: '") + key + "' has " + std::to_string(v.size()) +
                            " entries for " + std::to_string(X.rows()) + " points");
    for (Eigen::Index n = 0; n < v.size(); ++n) set(out[static_cast<std::size_t>(n)], v(n));
  };
  column("radius", [](LabelPoint& p, double v) { p.radius = v; });
  column("branch", [](LabelPoint& p, double v) { p.branch = static_cast<int>(v); });
  column("index", [](LabelPoint& p, double v) { p.index = static_cast<int>(v); });
  return out;
}

std::optional<Image<std::uint8_t>> optional_mask(const py::object& obj, const char* name) {
  if (obj.is_none()) return std::nullopt;
  return image_from<std::uint8_t>(obj, Accept::mask, name);
}

py::array_t<bool> bools(const std::vector<ProjectedPoint>& v, bool ProjectedPoint::*member) {
  py::array_t<bool> out(static_cast<py::ssize_t>(v.size()));
  for (std::size_t n = 0; n < v.size(); ++n) out.mutable_data()[n] = v[n].*member;
  return out;
}

/// A CT as the renderer reads it: int16 arrays (and int16 gimm.Volumes) stay int16, read in
/// place when Fortran-ordered; everything else is float32.
using HuInput = std::variant<VolumeInput<float>, VolumeInput<std::int16_t>>;

HuInput hu_arg(const py::handle& obj, const GeometryArgs& grid, const std::string& name) {
  if (py::isinstance<PyVolume>(obj)) {
    const std::string kind = obj.cast<const PyVolume&>().dtype();
    if (kind == "int16") return volume_arg<std::int16_t>(obj, grid, Accept::real, name);
    if (kind != "float32")
      throw py::type_error(name +
                           ": expected a gimm.Volume of dtype float32 or int16, got one "
                           "of " +
                           kind);
    return volume_arg<float>(obj, grid, Accept::real, name);
  }
  const py::array a = checked_array(obj, 3, Accept::real, name);
  if (natural_dtype(a) == "int16") return volume_arg<std::int16_t>(a, grid, Accept::real, name);
  return volume_arg<float>(a, grid, Accept::real, name);
}

/// The renderer of `hu` (float or int16) with the options; the GIL is released by the caller.
template <class H>
std::unique_ptr<ViewRenderer> prepare_renderer(Volume<H>& hu, const Volume<std::uint8_t>* vessels,
                                               const RendererOptions& o, const std::string& name) {
  if constexpr (std::is_same_v<H, float>)
    if (o.recipe.preset == ContrastPreset::none && !vessels)  // a copy made already is moved in
      return std::make_unique<ViewRenderer>(ViewRenderer::from_attenuation(std::move(hu), o, name));
  std::shared_ptr<const VesselSurface> surface;
  if (o.vessels == VesselMode::mesh) {
#ifdef GIMM_PYTHON_HAVE_EMBREE
    surface = vessel_surface_from_mask(*vessels);
#else
    GIMM_CHECK(false, name << ": vessels='mesh' needs Embree, and this gimm module was built "
                              "without it (the setuptools wheel, or CMake with "
                              "GIMM_WITH_EMBREE=OFF)");
#endif
  }
  return std::make_unique<ViewRenderer>(hu, vessels, o, name, nullptr, std::move(surface));
}

}  // namespace

void bind_render(py::module_& m) {
  py::class_<ViewRenderer>(m, "Renderer", R"doc(
The prepared view renderer: prepare a patient once, render any number of C-arm views.

Renderer(volume, mask=None, *, geometry=None, spacing=None, origin=None, direction=None,
         recipe='angiography', pad_mm=80.0, projector='siddon', step_mm=0.0,
         vessel_depth=False, min_chord_mm=1e-6, vessels='voxel', smooth_voxel_steps=False,
         name='volume')

volume: CT in HU [i, j, k] (nx, ny, nz), any real dtype (float32, int16, ...), any order, or a
gimm.Volume (which carries its geometry); with recipe='none' it is attenuation in mm^-1 instead.
mask: the injected system's vessel mask on the same grid (bool or integer, nonzero = lumen; an
array or a uint8 gimm.Volume), or None for a plain DRR. Geometry of an array as read_volume
returns it (dict), or spacing (3,) mm, origin (3,) world mm of voxel (0, 0, 0), direction
(3, 3) (the explicit ones win). recipe: 'angiography' (bone told from contrast by structure),
'reference' (the released dataset's), 'none', or a dict of ContrastRecipe fields with 'preset'.
pad_mm: tissue beyond the axial coverage (copies of the edge slices), 0 = air. projector:
'siddon' (exact) or 'trilinear' (step_mm, 0 = the smallest spacing). vessels: 'voxel' (the
mask's voxels carry the contrast) or 'mesh' (the lumen as a surface mesh of the mask, traced by
Embree: anti-aliased edges and an overlap count; gimm-dataset --vessels mesh). vessel_depth:
also the vessel depth and overlap count per pixel. smooth_voxel_steps (mesh): blur the
background by half a voxel's footprint before the vessels are added (gimm-dataset
--smooth-background).

Copies: a float32 or int16 volume and a uint8 or bool mask in Fortran order (writeable) are
read in place, no copy (see gimm.Volume); other dtypes and layouts are converted into a copy first. The
renderer builds its own attenuation volume from them (with recipe='none' the attenuation itself
is kept: a copy, moved in when one was made already) and any copies are freed. The arrays are
not referenced after construction. The GIL is released while preparing and rendering; render() may be called from
several Python threads at once.)doc")
      .def(py::init([](const py::handle& volume, const py::object& mask, const py::object& geometry,
                       const py::object& spacing, const py::object& origin,
                       const py::object& direction, const py::handle& recipe, double pad_mm,
                       const std::string& projector, double step_mm, bool vessel_depth,
                       double min_chord_mm, const std::string& vessels_mode,
                       bool smooth_voxel_steps, const std::string& name) {
             RendererOptions o;
             o.recipe = recipe_from(recipe);
             o.pad_mm = pad_mm;
             o.projector = parse_projector(projector);
             o.step_mm = step_mm;
             o.vessel_depth = vessel_depth;
             if (vessels_mode != "voxel" && vessels_mode != "mesh")
               throw py::value_error("vessels must be 'voxel' or 'mesh', got '" + vessels_mode +
                                     "'");
             o.vessels = parse_vessel_mode(vessels_mode);
             if (o.vessels == VesselMode::mesh && mask.is_none())
               throw py::value_error("vessels='mesh' needs the vessel mask (mask=...)");
             o.min_chord_mm = min_chord_mm;
             o.smooth_voxel_steps = smooth_voxel_steps;
             HuInput ct = hu_arg(volume, {geometry, spacing, origin, direction}, name);
             const VolumeGeometry& grid = std::visit(
                 [](const auto& in) -> const VolumeGeometry& { return in.volume.geometry(); }, ct);
             std::optional<VolumeInput<std::uint8_t>> mask_in;
             if (!mask.is_none())
               mask_in = py::isinstance<PyVolume>(mask)
                             ? volume_arg<std::uint8_t>(mask, {}, Accept::mask, name + " mask")
                             : volume_in<std::uint8_t>(mask, grid, Accept::mask, name + " mask");
             const Volume<std::uint8_t>* vessels = mask_in ? &mask_in->volume : nullptr;
             py::gil_scoped_release release;
             return std::visit(
                 [&](auto& in) { return prepare_renderer(in.volume, vessels, o, name); }, ct);
           }),
           py::arg("volume"), py::arg("mask") = py::none(), py::kw_only(),
           py::arg("geometry") = py::none(), py::arg("spacing") = py::none(),
           py::arg("origin") = py::none(), py::arg("direction") = py::none(),
           py::arg("recipe") = "angiography", py::arg("pad_mm") = kDefaultPadMm,
           py::arg("projector") = "siddon", py::arg("step_mm") = 0.0,
           py::arg("vessel_depth") = false, py::arg("min_chord_mm") = 1e-6,
           py::arg("vessels") = "voxel", py::arg("smooth_voxel_steps") = false,
           py::arg("name") = "volume")
      .def(
          "render",
          [](const ViewRenderer& r, const py::handle& camera, bool intensity) {
            const Camerad c = camera_of(camera, "render: camera");
            RenderedView view;
            Image<float> image;
            {
              py::gil_scoped_release release;
              view = r.render(c);
              if (intensity) image = view.intensity();
            }
            return rendered_dict(std::move(view), std::move(image));
          },
          py::arg("camera"), py::arg("intensity") = true, R"doc(
Renders one view of a Camera (or CArm). Returns a dict of (rows, cols) arrays, each a view of
the buffer gimm rendered into (no copy: array.base is the capsule that owns it):
  line_integrals  float32, optical depth (unitless), the integral of attenuation along each ray
  intensity       float32, Beer-Lambert exp(-line_integrals), I0 = 1 (when intensity=True)
  vessel_mask     uint8, 1 = vessel (with a mask)
  overlap         uint8, vessel passages per pixel (with vessel_depth=True)
  depth_mm        float32, source to the first vessel, mm; inf where none (vessel_depth=True)
The GIL is released while rendering.)doc")
      .def(
          "unoccluded",
          [](const ViewRenderer& r, const py::handle& camera, const py::handle& points) {
            const Camerad c = camera_of(camera, "unoccluded: camera");
            const auto X = rows_of(points, 3, "points");
            std::vector<char> seen(static_cast<std::size_t>(X.rows()));
            {
              py::gil_scoped_release release;
              for (Eigen::Index n = 0; n < X.rows(); ++n)
                seen[static_cast<std::size_t>(n)] = r.unoccluded(c, X.row(n).transpose());
            }
            py::array_t<bool> out(X.rows());
            for (Eigen::Index n = 0; n < X.rows(); ++n)
              out.mutable_data()[n] = seen[static_cast<std::size_t>(n)] != 0;
            return out;
          },
          py::arg("camera"), py::arg("points"),
          "(N,) bool: whether each world point (N, 3) mm on a vessel centreline is seen by the "
          "camera with no other vessel passage between the source and it.")
      .def_property_readonly("has_vessels", &ViewRenderer::has_vessels,
                             "True when a vessel mask was given");

  // ---- labels ------------------------------------------------------------------------------
  m.def(
      "label_view",
      [](const py::handle& points, const py::handle& camera, const py::object& vessel_mask,
         const py::object& overlap, const py::object& renderer) {
        const std::vector<LabelPoint> pts = label_points(points);
        const Camerad c = camera_of(camera, "label_view: camera");
        const auto mask = optional_mask(vessel_mask, "vessel_mask");
        const auto over = optional_mask(overlap, "overlap");
        const ViewRenderer* r = renderer.is_none() ? nullptr : renderer.cast<const ViewRenderer*>();
        std::vector<ProjectedPoint> view;
        {
          py::gil_scoped_release release;
          view = label_view(pts, c, mask ? &*mask : nullptr, over ? &*over : nullptr);
          if (r)
            mark_occlusion(view, pts,
                           [&](const Eigen::Vector3d& X) { return r->unoccluded(c, X); });
        }
        std::vector<Eigen::Vector2d> uv;
        std::vector<double> depth;
        std::vector<std::int32_t> overlaps;
        for (const auto& p : view) {
          uv.push_back(p.uv);
          depth.push_back(p.depth);
          overlaps.push_back(p.overlap);
        }
        py::dict d;
        d["uv"] = rows_to_numpy<2>(uv);
        d["depth"] = adopt_vector(std::move(depth));
        d["in_front"] = bools(view, &ProjectedPoint::in_front);
        d["in_image"] = bools(view, &ProjectedPoint::in_image);
        d["on_mask"] = bools(view, &ProjectedPoint::on_mask);
        d["visible"] = bools(view, &ProjectedPoint::visible);
        d["overlap"] = adopt_vector(std::move(overlaps));
        py::array_t<bool> valid(static_cast<py::ssize_t>(view.size()));
        for (std::size_t n = 0; n < view.size(); ++n) valid.mutable_data()[n] = view[n].valid();
        d["valid"] = valid;
        return d;
      },
      py::arg("points"), py::arg("camera"), py::arg("vessel_mask") = py::none(),
      py::arg("overlap") = py::none(), py::arg("renderer") = py::none(), R"doc(
Projects centerline points into one view: points is a centerline dict (make_phantom,
extract_centerlines) or (N, 3) world mm. vessel_mask / overlap: that view's (rows, cols) images
(render()'s), optional; renderer: the Renderer of that system, to mark points hidden behind
another vessel. Returns dict(uv (N, 2) pixels, depth (N,) mm, in_front, in_image, on_mask,
visible, valid (N,) bool, overlap (N,) int32); valid = in front, on the detector and on the mask.)doc");
  m.def(
      "farthest_point_sampling",
      [](const py::handle& points, std::size_t count, std::uint64_t seed) {
        const auto rows = rows_of(points, 3, "points");
        std::vector<Eigen::Vector3d> world;
        for (Eigen::Index r = 0; r < rows.rows(); ++r) world.push_back(rows.row(r).transpose());
        Rng rng(seed);
        std::vector<std::size_t> chosen;
        {
          py::gil_scoped_release release;
          chosen = farthest_point_sampling(world, count, rng);
        }
        return adopt_vector(std::vector<std::int64_t>(chosen.begin(), chosen.end()));
      },
      py::arg("points"), py::arg("count"), py::arg("seed") = 0, R"doc(
Farthest-point sampling in 3D (labels/correspondence.hpp): a seeded random first point, then
repeatedly the point farthest from all chosen (ties: the lowest index). points: (N, 3) mm.
Returns the indices (at most count, all distinct) as int64: label_pair's sparse labels are
this over the pair's world_mm with the same seed, and the same works for one view's points.)doc");
  m.def(
      "label_pair",
      [](const py::handle& points, const py::handle& camera_a, const py::handle& camera_b,
         const py::object& mask_a, const py::object& mask_b, std::size_t sparse_count,
         std::uint64_t seed) {
        const std::vector<LabelPoint> pts = label_points(points);
        const Camerad a = camera_of(camera_a, "label_pair: camera_a");
        const Camerad b = camera_of(camera_b, "label_pair: camera_b");
        const auto ma = optional_mask(mask_a, "mask_a"), mb = optional_mask(mask_b, "mask_b");
        PairLabels labels;
        {
          py::gil_scoped_release release;
          const auto va = label_view(pts, a, ma ? &*ma : nullptr);
          const auto vb = label_view(pts, b, mb ? &*mb : nullptr);
          Rng rng(seed);
          labels = label_pair(pts, va, vb, a, b, sparse_count, rng);
        }
        std::vector<Eigen::Vector2d> pa, pb;
        std::vector<Eigen::Vector3d> world;
        std::vector<std::int32_t> branch, index;
        std::vector<double> radius;
        for (const auto& c : labels.dense) {
          pa.push_back(c.a);
          pb.push_back(c.b);
          world.push_back(c.world);
          branch.push_back(c.branch);
          index.push_back(c.index);
          radius.push_back(c.radius);
        }
        std::vector<std::int64_t> sparse(labels.sparse.begin(), labels.sparse.end());
        py::dict d;
        d["points_a"] = rows_to_numpy<2>(pa);
        d["points_b"] = rows_to_numpy<2>(pb);
        d["world_mm"] = rows_to_numpy<3>(world);
        d["branch"] = adopt_vector(std::move(branch));
        d["index"] = adopt_vector(std::move(index));
        d["radius"] = adopt_vector(std::move(radius));
        d["sparse"] = adopt_vector(std::move(sparse));
        d["F"] = to_numpy(labels.F);
        if (!mask_a.is_none()) d["mask_a"] = mask_a;
        if (!mask_b.is_none()) d["mask_b"] = mask_b;
        return d;
      },
      py::arg("points"), py::arg("camera_a"), py::arg("camera_b"), py::arg("mask_a") = py::none(),
      py::arg("mask_b") = py::none(), py::kw_only(), py::arg("sparse_count") = 20,
      py::arg("seed") = 0, R"doc(
Dense 3D-2D labels of a view pair: the centerline points valid in both views (in front, on the
detector, on each view's vessel mask when given). Returns dict(points_a, points_b (M, 2) pixels,
world_mm (M, 3), branch, index (M,) int32, radius (M,) mm, sparse (S,) int64 indices of
sparse_count points by farthest-point sampling in 3D from a seeded start, F (3, 3) exact,
x_b^T F x_a = 0; and mask_a / mask_b as given). The dict is a truth for gimm.evaluate.)doc");
}

}  // namespace gimm::python
