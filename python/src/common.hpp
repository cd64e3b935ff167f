#pragma once
// Shared plumbing of the gimm Python module (python/src/*.cpp): numpy <-> gimm conversions.
//
// Out (gimm -> numpy), no copy: an Image<T> or Volume<T> is moved to the heap, owned by a
// py::capsule, and the returned array is a view of its buffer whose `base` is that capsule
// (adopt_image, adopt_volume). The buffer lives as long as the array (or any view of it).
// In (numpy -> gimm): a volume is a view of the array when its dtype and layout are gimm's
// (volume_in); otherwise, and for every Image<T> (which owns a std::vector), a copy converting
// the dtype and layout on the way (image_from). Small geometric arrays (points, matrices) are
// converted to Eigen by value.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Core>
#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "gimm/core/image.hpp"
#include "gimm/core/volume.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/geometry/camera.hpp"
#include "gimm/match/pair_matcher.hpp"
#include "gimm/match/matches.hpp"

namespace gimm::python {

namespace py = pybind11;

// ---- out: zero-copy arrays over gimm's own buffers ----------------------------------------

/// A (rows, cols) C-ordered array over `image`'s pixels; the image is moved into a capsule.
template <class T>
py::array_t<T> adopt_image(Image<T>&& image) {
  auto owner = std::make_unique<Image<T>>(std::move(image));
  const py::ssize_t rows = owner->rows(), cols = owner->cols();
  T* data = owner->data();
  py::capsule capsule(owner.get(), [](void* p) { delete static_cast<Image<T>*>(p); });
  owner.release();
  return py::array_t<T>(
      {rows, cols},
      {cols * static_cast<py::ssize_t>(sizeof(T)), static_cast<py::ssize_t>(sizeof(T))}, data,
      capsule);
}

/// An (nx, ny, nz) Fortran-ordered array (index [i, j, k], i fastest in memory, as gimm and
/// NIfTI store it) over `volume`'s voxels; the volume is moved into a capsule.
template <class T>
py::array_t<T> adopt_volume(Volume<T>&& volume) {
  auto owner = std::make_unique<Volume<T>>(std::move(volume));
  const py::ssize_t nx = owner->nx(), ny = owner->ny(), nz = owner->nz();
  const py::ssize_t s = static_cast<py::ssize_t>(sizeof(T));
  T* data = owner->data();
  py::capsule capsule(owner.get(), [](void* p) { delete static_cast<Volume<T>*>(p); });
  owner.release();
  return py::array_t<T>({nx, ny, nz}, {s, s * nx, s * nx * ny}, data, capsule);
}

/// A 1D array over a vector's elements, the vector moved into a capsule.
template <class T>
py::array_t<T> adopt_vector(std::vector<T>&& values) {
  auto owner = std::make_unique<std::vector<T>>(std::move(values));
  const py::ssize_t n = static_cast<py::ssize_t>(owner->size());
  T* data = owner->data();
  py::capsule capsule(owner.get(), [](void* p) { delete static_cast<std::vector<T>*>(p); });
  owner.release();
  return py::array_t<T>({n}, {static_cast<py::ssize_t>(sizeof(T))}, data, capsule);
}

// ---- small arrays: points, vectors, matrices (copied, converted to float64) ---------------

/// make() run with its option checks raised as ValueError (a bad argument, not a failed run),
/// the message led by `function`.
template <class Make>
auto options_checked(const std::string& function, Make&& make) {
  try {
    return make();
  } catch (const gimm::Error& e) {
    throw py::value_error(function + ": " + e.what());
  }
}

inline std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d)
    s += (d ? ", " : "") + std::to_string(a.shape(d)) + (a.ndim() == 1 ? "," : "");
  return s + ")";
}

/// `obj` as a C-ordered float64 array (converting lists and other numeric dtypes); TypeError
/// naming `name` when it is not numeric.
inline py::array_t<double, py::array::c_style | py::array::forcecast> as_doubles(
    const py::handle& obj, const std::string& name) {
  if (py::isinstance<py::array>(obj)) {
    const char kind = py::reinterpret_borrow<py::array>(obj).dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u')
      throw py::type_error(name + ": expected a real numeric array, got dtype " +
                           std::string(py::str(py::reinterpret_borrow<py::array>(obj).dtype())));
  }
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a) {
    PyErr_Clear();
    throw py::type_error(name + ": expected an array of numbers, got " +
                         std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  }
  return a;
}

/// An (N, cols) array of float64 as rows (e.g. points (N, 2) in pixels, (N, 3) in mm).
inline Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows_of(
    const py::handle& obj, Eigen::Index cols, const std::string& name) {
  const auto a = as_doubles(obj, name);
  if (a.ndim() != 2 || a.shape(1) != cols)
    throw py::value_error(name + ": expected shape (N, " + std::to_string(cols) + "), got " +
                          shape_of(a));
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> m(a.shape(0), cols);
  if (m.size() > 0) std::memcpy(m.data(), a.data(), sizeof(double) * m.size());
  return m;
}

/// (N, 2) pixel points as gimm's (2, N) Points2.
inline Eigen::Matrix<double, 2, Eigen::Dynamic> points2(const py::handle& obj,
                                                        const std::string& name) {
  return rows_of(obj, 2, name).transpose();
}

/// A fixed-size matrix or vector (R x C; C == 1: a vector of R entries).
template <int R, int C>
Eigen::Matrix<double, R, C> fixed(const py::handle& obj, const std::string& name) {
  const auto a = as_doubles(obj, name);
  const bool ok = C == 1 ? (a.ndim() == 1 && a.shape(0) == R)
                         : (a.ndim() == 2 && a.shape(0) == R && a.shape(1) == C);
  if (!ok)
    throw py::value_error(name + ": expected shape " +
                          (C == 1 ? "(" + std::to_string(R) + ",)"
                                  : "(" + std::to_string(R) + ", " + std::to_string(C) + ")") +
                          ", got " + shape_of(a));
  Eigen::Matrix<double, R, C> m;
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < C; ++c) m(r, c) = a.data()[r * C + c];
  // A camera, an F or a position with a NaN in it gives NaN or inf everywhere downstream.
  if (!m.allFinite())
    throw py::value_error(name + ": must be finite, got " + py::repr(obj).cast<std::string>());
  return m;
}

/// A (N,) float64 vector.
inline Eigen::VectorXd vector_of(const py::handle& obj, const std::string& name) {
  const auto a = as_doubles(obj, name);
  if (a.ndim() != 1) throw py::value_error(name + ": expected shape (N,), got " + shape_of(a));
  Eigen::VectorXd v(a.shape(0));
  if (v.size() > 0) std::memcpy(v.data(), a.data(), sizeof(double) * v.size());
  return v;
}

/// Copies of Eigen results as new numpy arrays (small: points, matrices).
template <class Derived>
py::array_t<double> to_numpy(const Eigen::MatrixBase<Derived>& m) {
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rm = m;
  py::array_t<double> out(m.cols() == 1 ? std::vector<py::ssize_t>{rm.rows()}
                                        : std::vector<py::ssize_t>{rm.rows(), rm.cols()});
  if (rm.size() > 0) std::memcpy(out.mutable_data(), rm.data(), sizeof(double) * rm.size());
  return out;
}

/// (N, D) float64 array from N Eigen vectors of D entries.
template <int D>
py::array_t<double> rows_to_numpy(const std::vector<Eigen::Matrix<double, D, 1>>& rows) {
  py::array_t<double> out({static_cast<py::ssize_t>(rows.size()), static_cast<py::ssize_t>(D)});
  auto w = out.mutable_unchecked<2>();
  for (std::size_t n = 0; n < rows.size(); ++n)
    for (int d = 0; d < D; ++d) w(static_cast<py::ssize_t>(n), d) = rows[n][d];
  return out;
}

// ---- in: images and volumes, copied into gimm's own storage -------------------------------

/// Calls f(pointer-type tag) for the element type of `a`; false when the dtype is not one of
/// the real numeric types below.
template <class F>
bool dispatch_dtype(const py::array& a, F&& f) {
  const py::dtype dt = a.dtype();
  if (dt.is(py::dtype::of<float>())) return f(static_cast<const float*>(nullptr)), true;
  if (dt.is(py::dtype::of<double>())) return f(static_cast<const double*>(nullptr)), true;
  if (dt.is(py::dtype::of<std::int16_t>()))
    return f(static_cast<const std::int16_t*>(nullptr)), true;
  if (dt.is(py::dtype::of<std::uint16_t>()))
    return f(static_cast<const std::uint16_t*>(nullptr)), true;
  if (dt.is(py::dtype::of<std::uint8_t>()))
    return f(static_cast<const std::uint8_t*>(nullptr)), true;
  if (dt.is(py::dtype::of<std::int8_t>())) return f(static_cast<const std::int8_t*>(nullptr)), true;
  if (dt.is(py::dtype::of<std::int32_t>()))
    return f(static_cast<const std::int32_t*>(nullptr)), true;
  if (dt.is(py::dtype::of<std::uint32_t>()))
    return f(static_cast<const std::uint32_t*>(nullptr)), true;
  if (dt.is(py::dtype::of<std::int64_t>()))
    return f(static_cast<const std::int64_t*>(nullptr)), true;
  if (dt.is(py::dtype::of<bool>())) return f(static_cast<const bool*>(nullptr)), true;
  return false;
}

/// What the input of a function may hold.
enum class Accept { real, floating, mask };

inline py::array checked_array(const py::handle& obj, int ndim, Accept accept,
                               const std::string& name) {
  py::array a;
  if (py::isinstance<py::array>(obj))
    a = py::reinterpret_borrow<py::array>(obj);
  else if (py::hasattr(obj, "__array__"))  // a CPU torch tensor: numpy's view of its memory
    a = py::module_::import("numpy").attr("asarray")(obj);
  else
    throw py::type_error(name + ": expected a numpy array (or a CPU tensor), got " +
                         std::string(py::str(py::type::handle_of(obj).attr("__name__"))));
  const char kind = a.dtype().kind();
  const std::string dtype = py::str(a.dtype());
  if (accept == Accept::floating && kind != 'f')
    throw py::type_error(
        name + ": expected a floating-point array (float32 or float64), got " + dtype +
        (kind == 'u' || kind == 'i' ? " (an 8-bit image in [0, 255]: pass image / 255.0)" : ""));
  if (accept == Accept::mask && kind != 'b' && kind != 'u' && kind != 'i')
    throw py::type_error(name + ": expected a bool or integer mask (nonzero = inside), got " +
                         dtype + " (convert with (mask > 0.5).astype(numpy.uint8))");
  if (accept == Accept::real && kind != 'f' && kind != 'u' && kind != 'i')
    throw py::type_error(name + ": expected a real numeric array, got " + dtype);
  if (a.ndim() != ndim)
    throw py::value_error(name + ": expected a " + std::to_string(ndim) + "D array, got shape " +
                          shape_of(a));
  for (py::ssize_t d = 0; d < a.ndim(); ++d)
    if (a.shape(d) == 0) throw py::value_error(name + ": the array is empty: " + shape_of(a));
  py::array out = a;
  bool known = dispatch_dtype(a, [](auto) {});
  if (!known)  // float16, longdouble, ...: converted to float64 first
    out = py::array_t<double, py::array::forcecast>::ensure(a);
  return out;
}

/// One element as T; a mask's values must fit uint8 (0 = outside), else `out_of_range` is set.
template <class T, class S>
T convert(S v, Accept accept, bool& out_of_range) {
  if (accept == Accept::mask && !(static_cast<double>(v) >= 0.0 && static_cast<double>(v) <= 255.0))
    out_of_range = true;
  return static_cast<T>(v);
}

/// Copies a 2D array (any strides, any real dtype) into an Image<T>, converting to T. Masks
/// (bool or integer) keep their values, which must be in [0, 255].
template <class T>
Image<T> image_from(const py::handle& obj, Accept accept, const std::string& name) {
  const py::array a = checked_array(obj, 2, accept, name);
  Image<T> image(static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)));
  const char* base = static_cast<const char*>(a.data());
  const py::ssize_t s0 = a.strides(0), s1 = a.strides(1);
  bool out_of_range = false;
  dispatch_dtype(a, [&](auto tag) {
    using S = std::remove_const_t<std::remove_pointer_t<decltype(tag)>>;
    for (int r = 0; r < image.rows(); ++r)
      for (int c = 0; c < image.cols(); ++c)
        image(r, c) =
            convert<T>(*reinterpret_cast<const S*>(base + r * s0 + c * s1), accept, out_of_range);
  });
  if (out_of_range) throw py::value_error(name + ": mask values must be in [0, 255]");
  return image;
}

/// A 3D array indexed [i, j, k] as a gimm Volume<T> on `geometry` (its dims are taken from the
/// array). `volume` is a view of the array's buffer, no copy, when the layout allows: dtype T (or
/// bool for a uint8 mask: one byte, 0 or 1), Fortran order (i fastest, as gimm stores voxels) and
/// writeable (gimm's Volume may write). Otherwise it is a copy converted from any strides and
/// real dtype. `array` keeps the buffer alive while `volume` is used.
template <class T>
struct VolumeInput {
  py::array array;
  Volume<T> volume;
  bool is_view() const { return !volume.owns_data(); }
};

template <class T>
VolumeInput<T> volume_in(const py::handle& obj, VolumeGeometry geometry, Accept accept,
                         const std::string& name);

/// An array's geometry, given as a dict and/or spacing, origin, direction (geometry_from).
struct GeometryArgs {
  py::object geometry, spacing = py::none(), origin = py::none(), direction = py::none();
  bool given() const {
    for (const py::object* o : {&geometry, &spacing, &origin, &direction})
      if (*o && !o->is_none()) return true;
    return false;
  }
};
VolumeGeometry geometry_from(const py::object& geometry, const py::object& spacing = {},
                             const py::object& origin = {}, const py::object& direction = {});

/// volume_in for what a function takes: a gimm.Volume (read in place; it carries its geometry,
/// so `args` must give none) or an array on the geometry `args` gives.
template <class T>
VolumeInput<T> volume_arg(const py::handle& obj, const GeometryArgs& args, Accept accept,
                          const std::string& name);

template <class T>
VolumeInput<T> volume_in(const py::handle& obj, VolumeGeometry geometry, Accept accept,
                         const std::string& name) {
  VolumeInput<T> in{checked_array(obj, 3, accept, name), {}};
  const py::array& a = in.array;
  for (int d = 0; d < 3; ++d) {
    if (a.shape(d) > 65536)
      throw py::value_error(name + ": dimension " + std::to_string(d) + " is " +
                            std::to_string(a.shape(d)) + ", more than 65536");
    geometry.dims[static_cast<std::size_t>(d)] = static_cast<int>(a.shape(d));
  }
  geometry.validate("Volume");  // gimm.Error naming "Volume", before any copy
  const bool same_type = a.dtype().is(py::dtype::of<T>()) ||
                         (std::is_same_v<T, std::uint8_t> && a.dtype().is(py::dtype::of<bool>()));
  if (same_type && (a.flags() & py::array::f_style) && a.writeable()) {
    in.volume = Volume<T>::view(geometry, static_cast<T*>(const_cast<void*>(a.data())));
    return in;
  }
  in.volume = Volume<T>(geometry);
  const char* base = static_cast<const char*>(a.data());
  const py::ssize_t s0 = a.strides(0), s1 = a.strides(1), s2 = a.strides(2);
  bool out_of_range = false;
  dispatch_dtype(a, [&](auto tag) {
    using S = std::remove_const_t<std::remove_pointer_t<decltype(tag)>>;
    T* out = in.volume.data();
    for (int k = 0; k < geometry.dims[2]; ++k)
      for (int j = 0; j < geometry.dims[1]; ++j) {
        const char* row = base + j * s1 + k * s2;
        for (int i = 0; i < geometry.dims[0]; ++i)
          *out++ = convert<T>(*reinterpret_cast<const S*>(row + i * s0), accept, out_of_range);
      }
  });
  if (out_of_range) throw py::value_error(name + ": mask values must be in [0, 255]");
  return in;
}

/// The dtype gimm keeps an array's volume as when nothing says otherwise: uint8 for a mask (bool
/// or uint8), int16 for an int16 CT, float32 for everything else.
inline std::string natural_dtype(const py::array& a) {
  const py::dtype t = a.dtype();
  if (t.is(py::dtype::of<bool>()) || t.is(py::dtype::of<std::uint8_t>())) return "uint8";
  return t.is(py::dtype::of<std::int16_t>()) ? "int16" : "float32";
}

inline const char* dtype_name(const Volume<float>&) {
  return "float32";
}
inline const char* dtype_name(const Volume<std::uint8_t>&) {
  return "uint8";
}
inline const char* dtype_name(const Volume<std::int16_t>&) {
  return "int16";
}

/// gimm.Volume: a float32 (CT, attenuation), int16 (CT) or uint8 (mask) volume and its geometry,
/// over the caller's array when volume_in allows, holding the array (python/src/bind_volumes.cpp).
struct PyVolume {
  std::variant<VolumeInput<float>, VolumeInput<std::uint8_t>, VolumeInput<std::int16_t>> in;

  const VolumeGeometry& geometry() const {
    return std::visit([](const auto& v) -> const VolumeGeometry& { return v.volume.geometry(); },
                      in);
  }
  bool is_view() const {
    return std::visit([](const auto& v) { return v.is_view(); }, in);
  }
  const char* dtype() const {
    return std::visit([](const auto& v) { return dtype_name(v.volume); }, in);
  }
};

// ---- volume geometry as a dict ------------------------------------------------------------

/// {"dims": (nx, ny, nz), "spacing": (3,) mm, "origin": (3,) mm, "direction": (3, 3)}.
inline py::dict geometry_dict(const VolumeGeometry& g) {
  py::dict d;
  d["dims"] = py::make_tuple(g.dims[0], g.dims[1], g.dims[2]);
  d["spacing"] = to_numpy(g.spacing);
  d["origin"] = to_numpy(g.origin);
  d["direction"] = to_numpy(g.direction);
  return d;
}

/// A geometry from a dict like geometry_dict's (dims ignored: they come from the array) and/or
/// explicit spacing, origin, direction (which win). Missing entries: spacing 1 mm, origin 0,
/// direction identity.
inline VolumeGeometry geometry_from(const py::object& geometry, const py::object& spacing,
                                    const py::object& origin, const py::object& direction) {
  VolumeGeometry g;
  auto entry = [&](const py::object& given, const char* key) -> py::object {
    if (given && !given.is_none()) return given;
    if (geometry && !geometry.is_none()) {
      if (!py::isinstance<py::dict>(geometry))
        throw py::type_error("geometry: expected a dict with spacing, origin and direction, got " +
                             std::string(py::str(py::type::handle_of(geometry).attr("__name__"))));
      const py::dict d = geometry;
      if (d.contains(key)) return d[key];
    }
    return py::none();
  };
  if (py::object s = entry(spacing, "spacing"); !s.is_none()) g.spacing = fixed<3, 1>(s, "spacing");
  if (py::object o = entry(origin, "origin"); !o.is_none()) g.origin = fixed<3, 1>(o, "origin");
  if (py::object d = entry(direction, "direction"); !d.is_none())
    g.direction = fixed<3, 3>(d, "direction");
  return g;
}

template <class T>
VolumeInput<T> volume_arg(const py::handle& obj, const GeometryArgs& args, Accept accept,
                          const std::string& name) {
  if (!py::isinstance<PyVolume>(obj))
    return volume_in<T>(
        obj, geometry_from(args.geometry, args.spacing, args.origin, args.direction), accept, name);
  const PyVolume& v = obj.cast<const PyVolume&>();
  if (args.given())
    throw py::value_error(name +
                          ": a gimm.Volume carries its geometry: give no geometry, "
                          "spacing, origin or direction with it");
  const auto* in = std::get_if<VolumeInput<T>>(&v.in);
  if (!in)
    throw py::type_error(name + ": expected a gimm.Volume of dtype " + dtype_name(Volume<T>()) +
                         ", got one of " + v.dtype());
  // The same voxels, viewed again; `array` keeps them alive (the caller's array, or the
  // gimm.Volume owning the copy).
  VolumeInput<T> out{obj.attr("array").cast<py::array>(), {}};
  out.volume = Volume<T>::view(in->volume.geometry(), const_cast<T*>(in->volume.data()));
  return out;
}

// ---- cameras ------------------------------------------------------------------------------

inline ProjectionModel parse_model(const std::string& name) {
  if (name == "perspective") return ProjectionModel::perspective;
  if (name == "orthographic") return ProjectionModel::orthographic;
  throw py::value_error("model must be 'perspective' or 'orthographic', got '" + name + "'");
}

/// A pair's truth (dataset/reader.hpp) as the dict evaluate() takes: id, points_a, points_b
/// (N, 2), world_mm (N, 3), F or None (unknown: all zero), mask_a, mask_b (own copies).
inline py::dict truth_dict(const PairTruth& t) {
  std::vector<Eigen::Vector2d> a, b;
  std::vector<Eigen::Vector3d> world;
  for (const Correspondence& c : t.dense) {
    a.push_back(c.a);
    b.push_back(c.b);
    world.push_back(c.world);
  }
  py::dict d;
  d["id"] = t.id;
  d["points_a"] = rows_to_numpy<2>(a);
  d["points_b"] = rows_to_numpy<2>(b);
  d["world_mm"] = rows_to_numpy<3>(world);
  d["F"] = t.F.isZero() ? py::object(py::none()) : py::object(to_numpy(t.F));
  d["mask_a"] = adopt_image(Image<std::uint8_t>(*t.mask_a));
  d["mask_b"] = adopt_image(Image<std::uint8_t>(*t.mask_b));
  return d;
}

/// A Camera, or a CArm's camera (a CArm given where a camera is expected).
Camerad camera_of(const py::handle& obj, const std::string& name);

/// Matches as the module returns them: dict(points_a, points_b, confidence, F, F_source, pair).
py::dict matches_dict(PairMatches m);

/// Every matcher's result as the module returns it: matches_dict without the pair, F_source
/// 'none' when there is no F, and candidates, dropped_in_padding, dropped_by_gate,
/// dropped_outside_field, seconds.
py::dict result_dict(PairMatchResult r);

/// An exposed field given to a matcher (`given`, nonzero = exposed) as a mask of its image's
/// size; None: nullopt. Raises ValueError naming `name` for another size.
std::optional<Image<std::uint8_t>> optional_field(const py::object& given, const Image<float>& image,
                                                  const char* name);

// ---- the parts of the module, one per source file -----------------------------------------

void bind_geometry(py::module_& m);
void bind_epipolar(py::module_& m);  // F, epipolar distances, gating, triangulation
void bind_volumes(py::module_& m);  // files, the phantom, anatomy, the view protocol
void bind_render(py::module_& m);   // the renderer, per-view and per-pair labels
void bind_learned(py::module_& m);  // the learned matcher
void bind_match(py::module_& m);    // baselines, metrics
void bind_geometric(py::module_& m);  // the geometric matcher
void bind_dataset(py::module_& m);  // gimm-dataset folders
void bind_dicom(py::module_& m);    // XA DICOM (built with GDCM only)

}  // namespace gimm::python
