// `topo track`: track an object in a video and print its motion features (period, amplitude,
// equilibrium, bounces, bending angle), optionally with an overlay video and a plot of the signal.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "args.h"
#include "commands.h"
#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/io/motion_features_json.h"
#include "topo_gaussian/vision/camera_model.h"
#include "topo_gaussian/vision/figure.h"
#include "topo_gaussian/vision/frame_source.h"
#include "topo_gaussian/vision/motion_features.h"
#include "topo_gaussian/vision/motion_tracker.h"

namespace topo_gaussian::tools {
namespace {

const char* kTrackHelp =
    "usage: topo track --video FILE [options]\n"
    "       topo track --bag FILE.bag --topic TOPIC [--tag-topic TOPIC ...] [options]\n"
    "\n"
    "Tracks an object through a video (or an image sequence: a pattern with one %d or %0Nd such as\n"
    "frame_%04d.png, or a directory of images) and prints its motion features: the swing period,\n"
    "amplitude, equilibrium and damping of a pendulum or tumbler, the bounces and apex heights of a ball,\n"
    "or the bending angle of a finger.\n"
    "\n"
    "  --video FILE           video file (mp4/avi/gif) or image sequence\n"
    "  --bag FILE.bag         a ROS 1 bag instead: the images of --topic (sensor_msgs/Image, or\n"
    "                         CompressedImage: jpeg/png), timed by their header stamps (the bag's receive\n"
    "                         times when the stamps are zero; said in the message); --start/--end count from\n"
    "                         the topic's first frame. A compressed frame that does not decode is skipped,\n"
    "                         named in the message, and counts as dropped\n"
    "  --topic TOPIC          with --bag: the image topic (a wrong one lists the bag's image topics)\n"
    "  --tag-topic TOPIC      with --bag, repeatable: a std_msgs/Float64 topic of side data (e.g.\n"
    "                         /pressure_pa); the window gets the value in force, the median of its samples\n"
    "                         between the first and last frame used (else the last one before), as\n"
    "                         \"side_data\": {\"pressure_pa\": ...} in the JSON\n"
    "  --method M             marker (colour blob, default) | silhouette | klt (feature points)\n"
    "  --kind K               pendulum (default) | tilt | trajectory | finger\n"
    "  --roi x,y,w,h          region of interest in pixels (default: whole frame)\n"
    "  --start S --end S      time range in seconds (default: whole video)\n"
    "  --stride N             use every N-th frame (default 1)\n"
    "  --fps F                frame rate of an image sequence (default 30)\n"
    "  --pivot x,y            pendulum pivot in pixels (default: circle fit to the marker's path)\n"
    "  --hsv-lower h,s,v --hsv-upper h,s,v   marker colour (OpenCV HSV: H 0..180, S and V 0..255,\n"
    "                         lower <= upper; default red, both sides of H 0)\n"
    "  --foreground F         silhouette foreground: auto (default: otsu for --kind tilt/finger, mog2\n"
    "                         otherwise) | mog2 | otsu\n"
    "  --polarity P           silhouette by otsu: the object is darker | brighter than its background, or\n"
    "                         auto (default: the side that touches the frame border less)\n"
    "  --rotate D             rotate every frame clockwise by 90, 180 or 270 degrees first (a phone video\n"
    "                         held sideways); --roi and --pivot are in the rotated frame. A rotation in\n"
    "                         the file's metadata is applied anyway.\n"
    "  --gravity x,y          image direction of gravity in the (rotated) frame (default 0,1: down)\n"
    "  --tip-fraction F       finger: tip segment and the one before it, each F of the length (default\n"
    "                         0.15, the finger task's tip_fraction; the bend is that task's angle)\n"
    "  --profile-segments K   finger: the bend profile's number of equal arc-length segments from the\n"
    "                         base end to the tip, 2..64 (default 8, the finger task's profile_segments)\n"
    "  --tilt-reference DEG   tilt: the tilt the object starts near, degrees from image-up, clockwise\n"
    "                         positive (default 0: upright). A silhouette's axes are known modulo 90 deg,\n"
    "                         so an object hung off its axis (resting ~50 deg over) needs it within 45 deg\n"
    "  --min-area PX          smallest blob accepted (default 30)\n"
    "  --json                 print the features as one JSON object (the motion-features document that\n"
    "                         `topo infer --features FILE` reads; tracker details under \"tracker\");\n"
    "                         a feature that was not measured is null\n"
    "  --series               with --json: include the time series\n"
    "  --debug-video OUT      write the overlay video: every frame drawn with the final result (the\n"
    "                         JSON's pivot, signed angle or bend, bounces, or the refusal)\n"
    "  --plot OUT.png         write a plot of the angle signal (crossings and turning points marked)\n"
    "                         (--debug-video and --plot must not name an input: the video or a frame)\n"
    "  --camera fx,fy,cx,cy[,k1,k2,p1,p2[,k3]]   intrinsics (and OpenCV distortion) of the camera\n"
    "  --camera-pose x,y,z,qx,qy,qz,qw          camera optical frame in the world (default: identity)\n"
    "  --plane nx,ny,nz,d     with --camera: place the trajectories on the world plane n.x = d [m]\n"
    "                         (JSON points_on_plane), e.g. the wall the pendulum swings along\n"
    "\n"
    "Before any feature, what was tracked must behave like one object (compact, of steady size and\n"
    "colour, moving continuously) and its motion like the kind asked for (a pendulum's path is an arc\n"
    "hanging from its pivot; a bounce has free-flight arcs on both sides). Otherwise the answer is a\n"
    "refusal (\"refused: ...\" with the reason; confidences 0), never a made-up number.\n"
    "exit codes: 0 success (also for a refusal), 1 bad input (missing or unreadable file), 2 bad command\n"
    "line (unknown or contradictory options, --roi outside the frame, HSV out of range)\n";

std::vector<double> numbers(const Args& a, const std::string& name, std::size_t count) {
  std::vector<double> v;
  std::stringstream ss(a.str(name));
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw UsageError("--" + name + " expects " + std::to_string(count) + " comma-separated numbers, got '" +
                       a.str(name) + "'");
    }
  }
  if (v.size() != count)
    throw UsageError("--" + name + " expects " + std::to_string(count) + " comma-separated numbers, got '" +
                     a.str(name) + "'");
  return v;
}

cv::Scalar hsv(const Args& a, const std::string& name) {
  const auto v = numbers(a, name, 3);
  return cv::Scalar(v[0], v[1], v[2]);
}

/// The signal on a white canvas with axes, zero line, equilibrium crossings and turning points.
void writePlot(const vision::TrackResult& r, const std::string& path) {
  const int W = 1000, H = 500, L = 70, R = 20, T = 40, B = 50;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  if (r.t.size() >= 2) {
    const double t0 = r.t.front(), t1 = r.t.back();
    double y0 = *std::min_element(r.angle_deg.begin(), r.angle_deg.end());
    double y1 = *std::max_element(r.angle_deg.begin(), r.angle_deg.end());
    if (y1 - y0 < 1e-6) {
      y0 -= 1;
      y1 += 1;
    }
    const double pad = 0.05 * (y1 - y0);
    y0 -= pad;
    y1 += pad;
    auto P = [&](double t, double y) {
      return cv::Point(static_cast<int>(L + (t - t0) / (t1 - t0) * (W - L - R)),
                       static_cast<int>(H - B - (y - y0) / (y1 - y0) * (H - T - B)));
    };
    cv::rectangle(img, cv::Point(L, T), cv::Point(W - R, H - B), cv::Scalar(0, 0, 0), 1);
    for (int k = 0; k <= 5; ++k) {
      const double y = y0 + k * (y1 - y0) / 5, t = t0 + k * (t1 - t0) / 5;
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.1f", y);
      cv::putText(img, buf, cv::Point(5, P(t0, y).y + 5), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1,
                  cv::LINE_AA);
      cv::line(img, cv::Point(L - 5, P(t0, y).y), cv::Point(L, P(t0, y).y), cv::Scalar(0, 0, 0));
      std::snprintf(buf, sizeof(buf), "%.2f", t);
      cv::putText(img, buf, cv::Point(P(t, y0).x - 15, H - B + 20), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0),
                  1, cv::LINE_AA);
    }
    cv::putText(img, "time [s]", cv::Point(W / 2 - 30, H - 10), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
    const std::string ylabel = r.kind == "trajectory" ? "image y along gravity [px]"
                               : r.kind == "finger"   ? "signed bend [deg]"
                               : r.angles_known       ? "angle from gravity [deg]"
                                                      : "displacement along the path [px]";
    cv::putText(img, ylabel + "   " + r.source, cv::Point(L, T - 12), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    if (r.signal.oscillation_found) {
      const double e = r.signal.equilibrium_deg;
      cv::line(img, P(t0, e), P(t1, e), cv::Scalar(180, 180, 180), 1);
      for (double tc : r.signal.crossing_times_s) cv::line(img, P(tc, y0), P(tc, y1), cv::Scalar(200, 200, 255), 1);
    }
    for (std::size_t i = 1; i < r.t.size(); ++i)
      cv::line(img, P(r.t[i - 1], r.angle_deg[i - 1]), P(r.t[i], r.angle_deg[i]), cv::Scalar(160, 60, 0), 2,
               cv::LINE_AA);
    for (std::size_t i = 0; i < r.signal.peak_times_s.size() && i < r.signal.peak_values_deg.size(); ++i)
      cv::circle(img, P(r.signal.peak_times_s[i], r.signal.peak_values_deg[i]), 5, cv::Scalar(0, 0, 220), 2,
                 cv::LINE_AA);
    for (std::size_t i = 0; i < r.bounce_times_s.size(); ++i)
      cv::circle(img, P(r.bounce_times_s[i], r.bounce_y_px[i]), 5, cv::Scalar(0, 0, 220), 2, cv::LINE_AA);
    for (std::size_t i = 0; i < r.apex_times_s.size(); ++i)
      cv::circle(img, P(r.apex_times_s[i], r.apex_y_px[i]), 5, cv::Scalar(0, 160, 0), 2, cv::LINE_AA);
    if (r.signal.oscillation_found) {
      char buf[128];
      std::snprintf(buf, sizeof(buf), "period %.4f s, amplitude %.2f deg", r.signal.period_s, r.signal.amplitude_deg);
      cv::putText(img, buf, cv::Point(L + 10, T + 20), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 200), 1,
                  cv::LINE_AA);
    }
  } else {
    // the whole reason, wrapped (a refusal names what was seen and the fix)
    const std::string text = (r.refused ? "" : "no signal: ") + r.message;
    std::istringstream words(text);
    std::string w, line;
    int y = 60;
    while (words >> w && y < H - 20) {
      if (line.size() + w.size() + 1 > 110) {
        cv::putText(img, line, cv::Point(20, y), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
        y += 22;
        line.clear();
      }
      line += (line.empty() ? "" : " ") + w;
    }
    if (!line.empty() && y < H - 20)
      cv::putText(img, line, cv::Point(20, y), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
  }
  vision::writePng(img, path);
}

/// Refuses (before any work) an output that is an input (`what` names it: the video, a frame of the
/// sequence, the bag), as topo fill refuses --output == --input, and a --roi outside the frame.
void checkInputsAndRoi(const Args& a, const vision::TrackOptions& o, const std::vector<std::string>& inputs,
                       const std::string& what, cv::Size size) {
  for (const std::string option : {"debug-video", "plot"}) {
    if (!a.has(option)) continue;
    for (const auto& input : inputs)
      if (sameFile(input, a.str(option)))
        throw UsageError("--" + option + " " + a.str(option) + " is " + what +
                         " itself: writing it would destroy the input; give another name, e.g. --" + option + " " +
                         (option == "plot" ? "track_plot.png" : "track_overlay.mp4"));
  }
  if (a.has("debug-video") && a.has("plot") && sameFile(a.str("debug-video"), a.str("plot")))
    throw UsageError("--debug-video and --plot name the same file " + a.str("plot") + "; give two names");
  if (o.rotate_deg == 90 || o.rotate_deg == 270) size = cv::Size(size.height, size.width);
  try {
    vision::validRoi(o.tracker.roi, size, o.tracker.roi_given);
  } catch (const TopoError& e) {
    throw UsageError(e.what());
  }
}

}  // namespace

int trackCommand(const std::vector<std::string>& argv) {
  const Args a(argv, {"help", "json", "series"},
               {"video",    "method",      "kind",    "roi",          "start",          "end",
                "stride",   "fps",         "pivot",   "hsv-lower",    "hsv-upper",      "foreground",
                "polarity", "rotate",      "gravity", "min-area",     "debug-video",    "plot",
                "camera",   "camera-pose", "plane",   "tip-fraction", "tilt-reference", "profile-segments",
                "bag",      "topic"},
               {"tag-topic"});
  if (a.has("help")) {
    std::cout << kTrackHelp;
    return 0;
  }
  const bool bag = a.has("bag");
  if (bag && a.has("video")) throw UsageError("give --video FILE or --bag FILE.bag --topic TOPIC, not both");
  if (!bag && !a.has("video")) throw UsageError("--video FILE (or --bag FILE.bag --topic TOPIC) is required");
  if (bag != a.has("topic"))
    throw UsageError(bag ? "--bag needs --topic TOPIC: the image topic to track (a wrong one lists the bag's)"
                         : "--topic is for --bag (a rosbag's image topic); a video file has no topics");
  if (a.has("tag-topic") && !bag)
    throw UsageError("--tag-topic reads side data from a rosbag: give --bag FILE.bag --topic TOPIC with it");
  if (bag && a.has("fps"))
    throw UsageError("--fps is for image sequences; a bag's frames carry their own stamps: leave --fps out");
  vision::TrackOptions o;
  o.kind = a.str("kind", "pendulum");
  o.tracker.method = a.str("method", "marker");
  o.tracker.foreground = a.str("foreground", "auto");
  o.tracker.polarity = a.str("polarity", "auto");
  o.rotate_deg = static_cast<int>(a.integer("rotate", 0));
  o.tip_fraction = a.num("tip-fraction", o.tip_fraction);
  o.profile_segments = static_cast<int>(a.integer("profile-segments", o.profile_segments));
  o.tilt_reference_deg = a.num("tilt-reference", o.tilt_reference_deg);
  if (a.has("gravity")) {
    const auto v = numbers(a, "gravity", 2);
    o.gravity = cv::Vec2d(v[0], v[1]);
  }
  if (a.has("series") && !a.has("json"))
    throw UsageError("--series needs --json (it adds the time series to the JSON)");
  if (a.has("polarity") && o.tracker.method != "silhouette")
    throw UsageError("--polarity applies to --method silhouette (the marker's colour range picks its object)");
  o.tracker.min_area_px = a.num("min-area", 30.0);
  if (a.has("roi")) {
    const auto v = numbers(a, "roi", 4);
    o.tracker.roi =
        cv::Rect(static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]), static_cast<int>(v[3]));
    o.tracker.roi_given = true;
  }
  if (a.has("hsv-lower") != a.has("hsv-upper")) throw UsageError("give both --hsv-lower and --hsv-upper");
  if (a.has("hsv-lower")) o.tracker.hsv = {vision::HsvRange{hsv(a, "hsv-lower"), hsv(a, "hsv-upper")}};
  o.video.start_s = a.num("start", 0.0);
  o.video.end_s = a.num("end", -1.0);
  o.video.stride = static_cast<int>(a.integer("stride", 1));
  o.video.sequence_fps = a.num("fps", 30.0);
  if (a.has("pivot")) {
    const auto v = numbers(a, "pivot", 2);
    o.pivot_given = true;
    o.pivot = cv::Point2d(v[0], v[1]);
  }
  const std::string video = bag ? a.str("bag") : a.str("video");
  try {
    vision::validateTrackOptions(o);
  } catch (const TopoError& e) {
    throw UsageError(e.what());
  }
  cv::VideoWriter writer;
  std::string debug = a.str("debug-video");
  std::function<void(const cv::Mat&)> sink;
  double fps_out = 30.0;
  std::unique_ptr<vision::FrameSource> recording;  // --bag: the frames through the rosbag reader
  if (bag) {
    vision::RecordingRequest rq;
    rq.path = video;
    rq.topic = a.str("topic");
    rq.tag_topics = a.all("tag-topic");
    rq.video = o.video;
    recording = vision::openRecording("rosbag", rq);  // fails early naming the bag, the topic and the fix
    fps_out = recording->fps() / std::max(1, o.video.stride);
    checkInputsAndRoi(a, o, recording->inputFiles(), "the input bag " + video, recording->frameSize());
  } else {
    vision::VideoSource probe(video, o.video);  // fails early with the file's name
    fps_out = probe.fps() / std::max(1, o.video.stride);
    if (a.has("fps") && !probe.isSequence())
      throw UsageError("--fps is for image sequences; the video file " + video + " carries its own frame rate (" +
                       std::to_string(probe.fps()) + " fps): leave --fps out");
    checkInputsAndRoi(a, o, probe.inputFiles(),
                      probe.isSequence() ? "a frame of the input image sequence " + video : "the input video",
                      probe.frameSize());
  }
  if (!debug.empty()) {
    sink = [&](const cv::Mat& frame) {
      if (!writer.isOpened()) {
        const bool avi = debug.size() > 4 && debug.substr(debug.size() - 4) == ".avi";
        const int fourcc =
            avi ? cv::VideoWriter::fourcc('M', 'J', 'P', 'G') : cv::VideoWriter::fourcc('m', 'p', '4', 'v');
        if (!writer.open(debug, cv::CAP_FFMPEG, fourcc, fps_out, frame.size()))
          throw TopoError(debug, "the debug video cannot be written",
                          "give a writable .mp4 or .avi path for --debug-video");
      }
      writer.write(frame);
    };
  }
  if (a.has("plane") != a.has("camera")) throw UsageError("--plane and --camera go together");
  vision::TrackResult r = recording ? vision::trackFrames(*recording, o, sink) : vision::trackVideo(video, o, sink);
  // --tag-topic: the side data in force over the window (the frames used), by the topic's name
  std::map<std::string, double> side_data;
  if (recording)
    for (const auto& [topic, samples] : recording->tags()) {
      const vision::TagValue v = vision::tagInWindow(samples, r.t_start_s, r.t_end_s);
      const std::string name = topic.substr(topic.find_first_not_of('/'));
      side_data[name] = v.value;
      if (!v.found)
        r.message += "; the tag topic " + topic + " has no sample up to the window's end (" + fixedText(r.t_end_s, 3) +
                     " s): side_data." + name + " is null";
      else if (v.changes)
        r.message += "; the tag topic " + topic + " changes within the window (" + numberText(v.before, 6) + " to " +
                     numberText(v.after, 6) + " at " + fixedText(v.change_t_s, 3) + " s): side_data." + name +
                     " is the median of its " + std::to_string(v.samples) +
                     " samples; cut the window there with --start/--end to give each value its own";
      else if (v.samples == 0)
        r.message += "; the tag topic " + topic + " has no sample in the window: side_data." + name +
                     " is its last value before it";
    }
  writer.release();
  if (a.has("plane")) {
    std::vector<double> c;
    for (std::size_t n : {4u, 8u, 9u}) {
      try {
        c = numbers(a, "camera", n);
        break;
      } catch (const UsageError&) {
      }
    }
    if (c.empty()) throw UsageError("--camera expects fx,fy,cx,cy with 0, 4 or 5 distortion coefficients after them");
    const cv::Matx33d K(c[0], 0, c[2], 0, c[1], c[3], 0, 0, 1);
    const std::vector<double> dist(c.begin() + 4, c.end());
    cv::Matx33d R = cv::Matx33d::eye();
    cv::Vec3d t(0, 0, 0);
    if (a.has("camera-pose")) {
      const auto p = numbers(a, "camera-pose", 7);
      const double n = std::sqrt(p[3] * p[3] + p[4] * p[4] + p[5] * p[5] + p[6] * p[6]);
      if (!(n > 0)) throw UsageError("--camera-pose quaternion is zero");
      const double x = p[3] / n, y = p[4] / n, z = p[5] / n, w = p[6] / n;
      R = cv::Matx33d(1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 2 * (x * y + z * w),
                      1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 2 * (x * z - y * w), 2 * (y * z + x * w),
                      1 - 2 * (x * x + y * y));
      t = cv::Vec3d(p[0], p[1], p[2]);
    }
    const auto pl = numbers(a, "plane", 4);
    vision::placeOnPlane(vision::CameraModel(K, dist, R, t), cv::Vec3d(pl[0], pl[1], pl[2]), pl[3], r);
  }
  if (a.has("plot")) writePlot(r, a.str("plot"));
  if (a.has("json")) {
    // The motion-features document (io/motion_features_json.h, what `topo infer --features` reads),
    // with the tracker-only details under "tracker".
    motion::MotionFeatures features = vision::toMotionFeatures(r);
    features.side_data = side_data;
    nlohmann::json doc = nlohmann::json::parse(io::motionFeaturesJson(features, a.has("series")));
    doc["tracker"] = nlohmann::json::parse(vision::trackerJson(r, a.has("series")));
    std::cout << doc.dump() << "\n";
  } else {
    std::printf("source          %s (%.3f fps, frames %d..%d of %d, %.3f..%.3f s)\n", r.source.c_str(), r.fps,
                r.first_frame, r.last_frame, r.frames_total, r.t_start_s, r.t_end_s);
    std::printf("tracking        %s / %s, %d frames used, %d lost, %d dropped\n", r.method.c_str(), r.kind.c_str(),
                r.frames_used, r.lost_frames, r.dropped_frames);
    if (r.refused) {
      std::printf("refused         no feature: the reason is below\n");
    } else if (r.kind == "pendulum" || r.kind == "tilt") {
      if (r.signal.oscillation_found) {
        const auto c = r.confidence.find("period_s");
        if (c != r.confidence.end() && c->second < 0.3)
          std::printf("unreliable      confidence %.2f < 0.3: the numbers below are not a measurement\n", c->second);
        std::printf("period_s        %.5f\n", r.signal.period_s);
        std::printf("amplitude_deg   %.3f\n", r.signal.amplitude_deg);
        const char* ambiguous = r.tilt_axis_ambiguous ? " (ambiguous: modulo 90 deg, see below)" : "";
        std::printf("equilibrium_deg %.3f%s\n", r.signal.equilibrium_deg, ambiguous);
        std::printf("max_tilt_deg    %.3f%s\n", r.signal.max_tilt_deg, ambiguous);
        std::printf("damping_ratio   %.5f\n", r.signal.damping_ratio);
      } else if (std::isfinite(r.static_pose.angle_deg)) {
        std::printf("static_angle_deg %.3f (spread %.3f)%s\n", r.static_pose.angle_deg, r.static_pose.spread_deg,
                    r.tilt_axis_ambiguous ? " (ambiguous: modulo 90 deg, see below)" : "");
      }
      if (r.kind == "pendulum")
        std::printf("pivot_px        %.1f, %.1f (%s)\n", r.pivot.x, r.pivot.y,
                    r.pivot_estimated ? "estimated" : "given/assumed");
    } else if (r.kind == "trajectory") {
      for (std::size_t i = 0; i < r.bounce_times_s.size(); ++i)
        std::printf("bounce          t %.4f s  y %.1f px\n", r.bounce_times_s[i], r.bounce_y_px[i]);
      for (std::size_t i = 0; i < r.apex_times_s.size(); ++i)
        std::printf("apex            t %.4f s  height %.1f px\n", r.apex_times_s[i],
                    i < r.apex_heights_px.size() ? r.apex_heights_px[i] : 0.0);
      if (std::isfinite(r.bounces.restitution_heights_mean))
        std::printf("restitution     %.3f (heights)\n", r.bounces.restitution_heights_mean);
      if (std::isfinite(r.bounces.restitution_times_mean))
        std::printf("restitution     %.3f (flight times)\n", r.bounces.restitution_times_mean);
    } else {
      std::printf("bend_held_deg   %.3f (the bend at the full pressure: %d held frames)\n", r.bend_held_deg,
                  r.bend_held_frames);
      std::printf("bend_final_deg  %.3f\n", r.bend_final_deg);
      std::printf("bend_max_deg    %.3f at %.3f s\n", r.bend_max_deg, r.bend_t_max_s);
      std::printf("bend_profile_deg");
      if (r.bend_profile_deg.empty()) std::printf(" not measured");
      for (double v : r.bend_profile_deg) std::printf(" %.3f", v);
      std::printf(" (%d equal arc-length segments, base to tip, at the full pressure)\n", r.profile_segments);
    }
    for (const auto& kv : side_data) std::printf("side_data       %s %.6g\n", kv.first.c_str(), kv.second);
    for (const auto& kv : r.confidence) std::printf("confidence      %s %.3f\n", kv.first.c_str(), kv.second);
    std::printf("message         %s\n", r.message.c_str());
  }
  return 0;
}

}  // namespace topo_gaussian::tools
