// Render one LAO 30 / cranial 20 view of the built-in phantom's left coronary tree, with its
// exact 3D-2D labels (the README's C++ example; tests/package builds and runs it).
#include <gimm/anatomy.hpp>
#include <gimm/geometry.hpp>
#include <gimm/labels.hpp>
#include <gimm/render.hpp>
#include <iostream>

int main() {
  gimm::PhantomOptions phantom_options;  // a procedural CCTA: HU volume and coronary label
  phantom_options.seed = 7;
  const gimm::Phantom phantom = gimm::make_phantom(phantom_options);
  const gimm::Volume<float> hu = gimm::volume_cast<float>(phantom.hu);
  const gimm::CoronarySplit trees = gimm::split_coronary_systems(phantom.label);

  // Prepare once: angiography recipe, 80 mm of tissue beyond the scan, exact Siddon projector.
  const gimm::RendererOptions options;
  const gimm::ViewRenderer renderer(hu, &trees.lca, options);

  gimm::CArm carm;  // SID 1000 mm, SOD 750 mm
  carm.rows = carm.cols = 256;
  carm.pixel_mm = 1.0;
  carm.primary_deg = 30;    // LAO 30
  carm.secondary_deg = 20;  // cranial 20
  carm.isocenter = gimm::vessel_isocenter(trees.lca);
  const gimm::Camerad camera = carm.camera();
  const gimm::RenderedView view = renderer.render(camera);  // render many
  const gimm::Image<float> angiogram = view.intensity();    // Beer-Lambert, I0 = 1

  // Every centerline point projected, on the vessel mask, and not hidden behind another vessel.
  gimm::SkeletonOptions skeleton;
  skeleton.system = gimm::CoronarySystem::LCA;
  const auto points = gimm::flatten_centerlines(gimm::extract_centerlines(trees.lca, skeleton));
  auto labels = gimm::label_view(points, camera, &view.vessel_mask);
  gimm::mark_occlusion(labels, points,
                       [&](const Eigen::Vector3d& X) { return renderer.unoccluded(camera, X); });
  std::size_t vessel_pixels = 0, labelled = 0;
  for (const auto px : view.vessel_mask.storage()) vessel_pixels += px != 0;
  for (const auto& p : labels) labelled += p.valid() && p.visible;
  std::cout << "view " << angiogram.rows() << " x " << angiogram.cols() << ": " << vessel_pixels
            << " vessel pixels, " << labelled << " of " << points.size()
            << " centerline points labelled and visible\n";
  return vessel_pixels > 0 && labelled > 0 ? 0 : 1;
}
