// Uses gimm::dicom from the installed package: writes an XA file and reads its camera back.
#include <gimm/io/dicom.hpp>
#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  gimm::CArm carm;
  carm.primary_deg = 30;
  carm.secondary_deg = -20;
  carm.rows = carm.cols = 64;
  carm.pixel_mm = 1.5;
  gimm::Image<float> image(64, 64);
  for (int r = 0; r < 64; ++r)
    for (int c = 0; c < 64; ++c) image(r, c) = float(r + c) / 128.0f;
  gimm::write_xa_dicom(argv[1], image, carm);
  const gimm::XaFrame frame = gimm::read_xa_dicom(argv[1]);
  const double diff = (frame.carm.camera().P() - carm.camera().P()).cwiseAbs().maxCoeff();
  std::cout << "dicom consumer: P differs by " << diff << "\n";
  return diff < 1e-6 ? 0 : 1;
}
