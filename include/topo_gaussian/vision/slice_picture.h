// Cross-sections of an interior for people, as in the paper's slice figures: solid particles
// (r ≥ 0.5) in red, hollow ones (r < 0.5) in blue, the outside white. Top row: the three orthogonal
// lattice layers through the centroid (xy, xz, yz); bottom row: layers evenly spread along the
// longest axis. Every panel names its plane and position and has in-plane axis arrows and a scale
// bar; all panels of a row share one scale.
//
// With a confidence per particle (agreement of the designs that fit as well, inference/design_spread.h),
// particles whose confidence is below 1 are hatched with dark diagonal lines over their colour:
// the observations do not decide whether they are solid or hollow.
//
// Takes plain arrays (positions on a lattice of the given spacing, one r per position) so that it
// depends only on OpenCV and Eigen.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace topo_gaussian::vision {

/// The colours of the slice picture (BGR), exact so that tests can count them.
const cv::Scalar kSliceSolidBgr(40, 40, 205);      ///< red
const cv::Scalar kSliceHollowBgr(230, 170, 80);    ///< blue
const cv::Scalar kSliceOutsideBgr(255, 255, 255);  ///< white
const cv::Scalar kSliceUncertainBgr(40, 40, 40);   ///< hatching of particles with confidence < 1

struct SliceOptions {
  int along_count = 5;             ///< slices along the longest axis in the bottom row (0: none)
  double iso = 0.5;                ///< solid is r ≥ iso
  int width = 1500;                ///< image width in pixels (the height follows)
  std::vector<double> confidence;  ///< per particle, or empty (no hatching); < 1 is hatched
};

/// Throws TopoError when X and r (or a non-empty confidence) differ in size, X is empty or spacing is
/// not positive.
cv::Mat drawInteriorSlices(const std::vector<Eigen::Vector3d>& X, const std::vector<double>& r, double spacing,
                           const std::string& title, const SliceOptions& options = SliceOptions());

}  // namespace topo_gaussian::vision
