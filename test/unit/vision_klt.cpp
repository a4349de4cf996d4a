// KLT accuracy: a textured patch translating at a known velocity (sub-pixel per frame) over a plain
// background; every KLT track that starts inside the texture must follow it within 0.3 px over the
// clip (measured: 0.03–0.06 px).
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "topo_gaussian/vision/motion_tracker.h"

using namespace topo_gaussian::vision;

TEST(Klt, TracksFollowATranslatingTexture) {
  cv::RNG rng(5);
  // A 120 x 120 random texture (blurred so corners are well conditioned).
  cv::Mat tex(120, 120, CV_8UC3);
  rng.fill(tex, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(tex, tex, cv::Size(0, 0), 1.5);
  const cv::Point2d start(150, 160), velocity(37.3, -11.9);  // px/s: 1.24 and −0.40 px per frame at 30 fps
  const double fps = 30.0;
  TrackOptions o;
  o.kind = "trajectory";
  o.tracker.method = "klt";
  o.tracker.roi = cv::Rect(140, 150, 140, 140);
  o.tracker.roi_given = true;
  MotionTracker tracker(o);
  for (int k = 0; k < 60; ++k) {
    const double t = k / fps;
    const cv::Point2d p = start + velocity * t;
    cv::Mat frame(480, 640, CV_8UC3, cv::Scalar(200, 200, 200));
    // Sub-pixel placement with an affine warp of the texture.
    const cv::Matx23d A(1, 0, p.x, 0, 1, p.y);
    cv::warpAffine(tex, frame, A, frame.size(), cv::INTER_LINEAR, cv::BORDER_TRANSPARENT);
    tracker.addFrame(frame, t);
  }
  const TrackResult r = tracker.finish();
  ASSERT_FALSE(r.trajectories.empty());
  int checked = 0;
  double worst = 0;
  for (const auto& tr : r.trajectories) {
    if (tr.size() < 30) continue;
    // Corners on the patch's outline mix texture and the static background (and the warp's edge
    // blending): they are not points of the moving texture. Judge the tracks that start inside it.
    const cv::Point2d p0(tr.front().x - start.x, tr.front().y - start.y);
    if (p0.x < 16 || p0.y < 16 || p0.x > 104 || p0.y > 104) continue;  // the LK window is 21 px
    for (const auto& s : tr) {
      // Each track's displacement from its first sample must equal velocity × elapsed time.
      const cv::Point2d d(s.x - tr.front().x, s.y - tr.front().y);
      const cv::Point2d want = velocity * (s.t - tr.front().t);
      worst = std::max(worst, cv::norm(d - want));
    }
    ++checked;
  }
  EXPECT_GE(checked, 8) << "too few long KLT tracks";
  EXPECT_LT(worst, 0.3) << "worst deviation " << worst << " px";
}
