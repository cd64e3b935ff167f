// gimm.read_xa_dicom / gimm.write_xa_dicom: X-ray angiography DICOM frames and their C-arm
// (io/dicom.hpp); built when the build has GDCM (GIMM_WITH_DICOM).
#include <optional>
#include <string>

#include <pybind11/stl.h>

#include "common.hpp"
#include "gimm/io/dicom.hpp"

namespace gimm::python {

void bind_dicom(py::module_& m) {
  m.def(
      "read_xa_dicom",
      [](const std::filesystem::path& path, std::optional<int> frame,
         std::optional<double> pitch_mm) {
        DicomReadOptions options;
        options.frame = frame;
        options.pitch_mm = pitch_mm;
        XaFrame f;
        {
          py::gil_scoped_release release;
          f = read_xa_dicom(path.string(), options);
        }
        py::list tags;
        for (const DicomTagUse& t : f.tags)
          tags.append(py::dict(py::arg("tag") = t.tag, py::arg("name") = t.name,
                               py::arg("value") = t.value, py::arg("use") = t.use));
        py::dict d;
        d["explain"] = explain(f);
        d["image"] = adopt_image(std::move(f.image));
        d["carm"] = f.carm;
        d["frame"] = f.frame;
        d["frames"] = f.frames;
        d["table_source"] = f.table_source;
        d["field"] = f.field.size() ? py::object(adopt_image(std::move(f.field))) : py::none();
        d["field_source"] = f.field_source;
        d["tags"] = tags;
        d["warnings"] = f.warnings;
        return d;
      },
      py::arg("path"), py::kw_only(), py::arg("frame") = py::none(),
      py::arg("pitch_mm") = py::none(), R"doc(
One frame of an X-ray angiography (XA/XRF) DICOM file and its C-arm, as gimm-match --dicom-a
reads it (docs/dicom.md). frame: 0-based (None: the middle one); pitch_mm: the detector pixel
pitch when the file's tags lack or misstate it.

Returns dict(image (rows, cols) float32 in [0, 1], MONOCHROME2 (vessels dark), in detector
orientation; carm: a gimm.CArm with the angles, distances, pitch and table position
(carm.camera() is the view's camera; its isocentre is the world origin unless set); frame,
frames; table_source; field: the shutters' exposed field, uint8 (rows, cols), 1 inside, or None
without shutter tags (gimm.exposed_field finds it in the image); field_source; tags: every tag
read (tag, name, value, use); warnings; explain: the
report gimm-carm --explain prints). Malformed files raise gimm.FormatError naming the element.)doc");
  m.def(
      "write_xa_dicom",
      [](const std::filesystem::path& path, const py::handle& image, const CArm& carm,
         bool ge_table) {
        const Image<float> im = image_from<float>(image, Accept::floating, "image");
        py::gil_scoped_release release;
        write_xa_dicom(path.string(), im, carm, ge_table);
      },
      py::arg("path"), py::arg("image"), py::arg("carm"), py::kw_only(),
      py::arg("ge_table") = false, R"doc(
Writes image ((rows, cols) float in [0, 1], MONOCHROME2) as a single-frame 16-bit XA DICOM file
with carm's angles, distances, pixel pitch and table (GE-style private tags when ge_table, else
the standard ones). The principal point must be the detector centre.)doc");
}

}  // namespace gimm::python
