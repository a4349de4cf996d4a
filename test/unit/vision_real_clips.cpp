// The tracker on real footage, as a user runs it: every case of test/real_clips/cases.yaml
// runs `topo track --video CLIP ARGS --json` and compares the features with the clip's ground truth
// (test/real_clips/<clip>.yaml, measured without this tracker: own frame decoding, colour masks and
// fits in numpy, checked by eye; see test/real_clips/README.md). The rule for every checked feature:
//   a value outside its tolerance must come with confidence < 0.3 (never a confident wrong answer),
//   so a confidence >= 0.5 means "within the stated tolerance" on every clip;
// and per case, `expect: answer` also requires every feature within tolerance at confidence >= 0.5,
// `expect: refusal` every confidence < 0.3, `expect: either` only the rule, `expect: within` every feature
// within tolerance at any confidence. `suggests: marker|silhouette`: the refusal names that method and
// its options found the object in at least half the sampled frames; `suggested_by: CASE` runs with the
// options CASE's refusal suggested, before its own.
// Adversarial clips are made here from the real pendulum clip (its truth carries over): its wall
// replaced by parquet or brick textures, rotated by 90°, a shaking camera, low light.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <random>
#include <string>
#include <vector>

#include "shared_data.h"
#include "test_util.h"

namespace {

const std::string kClipDir = std::string(TOPO_SOURCE_DIR) + "/test/real_clips";

struct Measured {
  bool present = false;        ///< the JSON has the key
  std::vector<double> values;  ///< one (scalar) or many (list); NaN for null
  double confidence = 0.0;
};

double numberOr(const nlohmann::json& j, double fallback) { return j.is_number() ? j.get<double>() : fallback; }

/// The feature `name` and its confidence from `topo track --json` output.
Measured measured(const nlohmann::json& doc, const std::string& name) {
  Measured m;
  const double nan = std::nan("");
  const nlohmann::json& tr = doc.at("tracker");
  auto conf = [&](const nlohmann::json& c, const char* key) {
    return c.contains(key) ? numberOr(c.at(key), 0.0) : 0.0;
  };
  auto scalar = [&](const nlohmann::json& v) {
    m.present = true;
    m.values = {v.is_number() ? v.get<double>() : nan};
  };
  auto list = [&](const nlohmann::json& v) {
    m.present = true;
    for (const auto& x : v) m.values.push_back(x.is_number() ? x.get<double>() : nan);
  };
  if (name == "period_s" || name == "amplitude_deg") {
    scalar(doc.at("features").value(name, nlohmann::json()));
    m.confidence = conf(doc.at("confidence"), name.c_str());
  } else if (name == "bounce_times_s" || name == "apex_heights_px") {
    if (tr.contains(name)) list(tr.at(name));
    m.confidence = conf(tr.at("confidence"), "bounces");
  } else if (name == "restitution") {
    if (tr.contains("restitution_heights_mean")) scalar(tr.at("restitution_heights_mean"));
    m.confidence = conf(tr.at("confidence"), "restitution");
  } else if (name == "bend_max_deg" || name == "bend_t_max_s") {
    if (tr.contains(name)) scalar(tr.at(name));
    m.confidence = conf(tr.at("confidence"), "bend_deg");
  }
  return m;
}

/// The truth of feature `name` from the clip's YAML (empty: none exists, e.g. no period in a rolling clip).
std::vector<double> truthOf(const YAML::Node& truth, const std::string& name) {
  static const std::map<std::string, std::string> key{{"period_s", "period_s"},
                                                      {"amplitude_deg", "amplitude_deg"},
                                                      {"bounce_times_s", "bounce_times_s"},
                                                      {"apex_heights_px", "apex_heights_px"},
                                                      {"restitution", "restitution"},
                                                      {"bend_max_deg", "finger_max_bend_deg"},
                                                      {"bend_t_max_s", "finger_t_max_s"}};
  std::vector<double> v;
  const auto it = key.find(name);
  if (it == key.end() || !truth[it->second] || !truth[it->second].IsMap()) return v;  // null: no such feature
  const YAML::Node value = truth[it->second]["value"];
  if (value.IsSequence())
    for (const auto& x : value) v.push_back(x.as<double>());
  else if (value.IsScalar())
    v.push_back(value.as<double>());
  return v;
}

// ---- adversarial clips from the real pendulum clip -------------------------------------------------

/// A procedural texture (BGR) of the frame's size: "parquet" (orange-brown planks with grain) or "brick"
/// (red bricks, grey mortar) — both inside or next to the default red colour range.
cv::Mat texture(const std::string& kind, const cv::Size& size, std::mt19937& rng) {
  cv::Mat hsv(size, CV_8UC3);
  std::uniform_real_distribution<double> u(0, 1);
  if (kind == "parquet") {
    const int plank_h = 28, plank_w = 160;
    for (int y = 0; y < size.height; ++y) {
      const int row = y / plank_h;
      for (int x = 0; x < size.width; ++x) {
        const int col = (x + (row % 2) * plank_w / 2) / plank_w;
        const double grain = 0.5 + 0.5 * std::sin(0.35 * x + 3.0 * std::sin(0.05 * x + row) + col * 1.7);
        const double hue = 9 + 4 * std::sin(1.3 * col + row);  // 5..13: red to orange
        const bool seam = y % plank_h == 0 || (x + (row % 2) * plank_w / 2) % plank_w == 0;
        hsv.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(hue), cv::saturate_cast<uchar>(150 + 60 * grain),
                                            cv::saturate_cast<uchar>(seam ? 50 : 120 + 60 * grain));
      }
    }
  } else {  // brick
    const int bh = 24, bw = 64;
    std::vector<double> shade(4096);
    for (double& s : shade) s = u(rng);
    for (int y = 0; y < size.height; ++y) {
      const int row = y / bh;
      for (int x = 0; x < size.width; ++x) {
        const int xs = x + (row % 2) * bw / 2;
        const bool mortar = y % bh < 3 || xs % bw < 3;
        const double s = shade[(row * 97 + xs / bw) % shade.size()];
        hsv.at<cv::Vec3b>(y, x) =
            mortar ? cv::Vec3b(20, 20, 170)
                   : cv::Vec3b(cv::saturate_cast<uchar>(2 + 5 * s), cv::saturate_cast<uchar>(150 + 70 * s),
                               cv::saturate_cast<uchar>(110 + 60 * s));
      }
    }
  }
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  return bgr;
}

/// Writes the clip `src` changed by `how` (parquet | brick | rotate90 | shake | lowlight) to `out`
/// (MJPG .avi, the source's frame rate). The bob is kept where it is red (R > 80, R > 1.6 G, R > 1.6 B,
/// dilated 6 px); everything else is the wall, which the textures replace.
bool makeAdversarial(const std::string& src, const std::string& how, const std::string& out) {
  cv::VideoCapture cap(src, cv::CAP_FFMPEG);
  if (!cap.isOpened()) return false;
  const double fps = cap.get(cv::CAP_PROP_FPS);
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0.0, 1.0);
  cv::VideoWriter w;
  cv::Mat frame, tex;
  cv::Point2d shake(0, 0);
  while (cap.read(frame)) {
    cv::Mat f = frame.clone();
    if (how == "parquet" || how == "brick") {
      if (tex.empty()) tex = texture(how, f.size(), rng);
      std::vector<cv::Mat> ch;
      cv::split(f, ch);
      cv::Mat r16, g16, b16, bob;
      ch[2].convertTo(r16, CV_32F);
      ch[1].convertTo(g16, CV_32F);
      ch[0].convertTo(b16, CV_32F);
      bob = (r16 > 80) & (r16 > 1.6 * g16) & (r16 > 1.6 * b16);
      cv::dilate(bob, bob, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(13, 13)));
      cv::Mat composite = tex.clone();
      f.copyTo(composite, bob);
      f = composite;
    } else if (how == "rotate90") {
      cv::rotate(f, f, cv::ROTATE_90_CLOCKWISE);
    } else if (how == "shake") {
      // a hand-held camera: a random walk of ±8 px, pulled back to the centre
      shake = 0.8 * shake + cv::Point2d(2.5 * gauss(rng), 2.5 * gauss(rng));
      const cv::Matx23d m(1, 0, shake.x, 0, 1, shake.y);
      cv::warpAffine(f, f, m, f.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    } else if (how == "lowlight") {
      // a quarter of the light, with sensor noise
      cv::Mat noise(f.size(), CV_32FC3);
      cv::randn(noise, 0.0, 3.0);
      cv::Mat g;
      f.convertTo(g, CV_32FC3, 0.25);
      g += noise;
      g.convertTo(f, CV_8UC3);
    } else {
      return false;
    }
    if (!w.isOpened() && !w.open(out, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, f.size()))
      return false;
    w.write(f);
  }
  return w.isOpened();
}

struct Row {
  std::string case_name, feature, truth, value;
  double confidence;
  std::string verdict;
};

std::string listText(const std::vector<double>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) {
    char b[32];
    std::snprintf(b, sizeof(b), "%s%.3g", i ? " " : "", v[i]);
    s += b;
  }
  return v.empty() ? "none" : s;
}

/// `topo track --video shared/data/videos/<clip> ARGS --json` as a user runs it; skips without the data.
nlohmann::json trackClip(const std::string& clip, const std::string& args) {
  const std::string video = topo_test::sharedDataDir() + "/videos/" + clip;
  const topo_test::ToolRun run =
      topo_test::runTopo("track --video " + video + " " + args + " --json", topo_test::Stderr::Discard);
  EXPECT_EQ(run.code, 0) << run.out;
  return run.code == 0 ? nlohmann::json::parse(run.out) : nlohmann::json::object();
}

// The ping-pong ball's first drop is 3 blurred frames that start in the fingers, so its first bounce has
// no free-flight arc before it. The tracker then either places that bounce from the arc rising after it
// and the floor line (every bounce of the truth, in order), or says that a bounce before the first one it
// found is missing and gives no release height; never the apex after the missed bounce as a "release".
TEST(VisionRealClips, AMissedFirstBounceIsFoundOrNamed) {
  TOPO_SHARED_FILE(video, "videos/pingpong_bounce_table.mp4");
  const YAML::Node truth = YAML::LoadFile(kClipDir + "/pingpong_bounce_table.yaml")["truth"];
  const std::vector<double> tb = truthOf(truth, "bounce_times_s");
  const nlohmann::json doc = trackClip("pingpong_bounce_table.mp4", "--kind trajectory --hsv-lower 5,125,150 --hsv-upper 25,255,255");
  ASSERT_TRUE(doc.contains("tracker")) << doc.dump();
  const nlohmann::json& tr = doc.at("tracker");
  const std::string message = doc.value("message", "");
  std::printf("ping-pong: %s\n", message.c_str());
  std::vector<double> found;
  for (const auto& v : tr.at("bounce_times_s")) found.push_back(v.get<double>());
  ASSERT_FALSE(found.empty()) << message;
  const bool all = found.size() == tb.size() && std::abs(found.front() - tb.front()) <= 0.04;
  const bool named = found.size() < tb.size() && tr.at("release_height_px").is_null() &&
                     message.find("before the first bounce found") != std::string::npos;
  EXPECT_TRUE(all || named) << found.size() << " bounces from " << found.front() << " s against the truth's "
                            << tb.size() << " from " << tb.front() << " s; release height "
                            << tr.at("release_height_px").dump() << "\n"
                            << message;
  for (std::size_t k = 0; all && k < tb.size(); ++k) EXPECT_NEAR(found[k], tb[k], 0.04) << "bounce " << k;
}

// The tennis clip from 1.3 s on (after its first bounce, at 1.186 s): the ball rises in the first frame,
// so it was not let go in view and there is no release height; the one bounce in the window (2.923 s)
// is found.
TEST(VisionRealClips, ABallAlreadyRisingHasNoReleaseHeight) {
  TOPO_SHARED_FILE(video, "videos/tennis_ball_drop.mp4");
  const YAML::Node truth = YAML::LoadFile(kClipDir + "/tennis_ball_drop.yaml")["truth"];
  const std::vector<double> tb = truthOf(truth, "bounce_times_s");
  const nlohmann::json doc =
      trackClip("tennis_ball_drop.mp4", "--kind trajectory --hsv-lower 35,45,150 --hsv-upper 65,255,255 --min-area 300 --start 1.3");
  ASSERT_TRUE(doc.contains("tracker")) << doc.dump();
  const nlohmann::json& tr = doc.at("tracker");
  const std::string message = doc.value("message", "");
  std::printf("tennis from 1.3 s: %s\n", message.c_str());
  ASSERT_EQ(tr.at("bounce_times_s").size(), 1u) << message;
  EXPECT_NEAR(tr.at("bounce_times_s")[0].get<double>(), tb.back(), 0.04) << message;
  EXPECT_TRUE(tr.at("release_height_px").is_null()) << tr.at("release_height_px").dump() << "\n" << message;
  EXPECT_NE(message.find("already rising"), std::string::npos) << message;
}

TEST(VisionRealClips, NeverAConfidentWrongAnswer) {
  const YAML::Node cases = YAML::LoadFile(kClipDir + "/cases.yaml")["cases"];
  ASSERT_TRUE(cases && cases.IsSequence());
  std::vector<Row> rows;
  int answered = 0, refused = 0;
  std::map<std::string, std::string> suggested;  ///< case name -> the options its refusal suggested
  for (const auto& c : cases) {
    const std::string name = c["name"].as<std::string>();
    const YAML::Node clip = YAML::LoadFile(kClipDir + "/" + c["truth"].as<std::string>());
    const std::string rel = clip["clip"].as<std::string>();
    const std::string shared = topo_test::sharedDataDir() + "/" + rel;
    if (!topo_test::fileExists(shared)) {
      if (topo_test::sharedDataRequired()) FAIL() << "missing shared data file " << shared;
      GTEST_SKIP() << "no shared data at " << shared;
    }
    std::string video = shared;
    if (c["generate"]) {
      const std::string how = c["generate"].as<std::string>();
      video = testing::TempDir() + "/adversarial_" + how + ".avi";
      ASSERT_TRUE(makeAdversarial(shared, how, video)) << name << ": cannot make the " << how << " clip";
    }
    std::string args = c["args"] ? c["args"].as<std::string>() : "";
    if (c["suggested_by"]) {
      // the options an earlier case's refusal suggested (the default colour found nothing), as a user
      // would paste them
      const std::string by = c["suggested_by"].as<std::string>();
      ASSERT_TRUE(suggested.count(by)) << name << ": case '" << by << "' (earlier in cases.yaml) gave no suggestion";
      args = suggested.at(by) + " " + args;
    }
    const topo_test::ToolRun run =
        topo_test::runTopo("track --video " + video + " " + args + " --json", topo_test::Stderr::Discard);
    ASSERT_EQ(run.code, 0) << name << ": topo track " << args << "\n" << run.out;
    const nlohmann::json doc = nlohmann::json::parse(run.out);
    const std::string expect = c["expect"].as<std::string>();
    std::printf("[%s] %s\n", name.c_str(), doc.value("message", "").c_str());
    const nlohmann::json& suggestion = doc.at("tracker").value("suggestion", nlohmann::json());
    if (suggestion.is_object()) suggested[name] = suggestion.at("args").get<std::string>();
    if (c["suggests"]) {
      // a refusal of the default colour says what would find the object, and it has tried that
      ASSERT_TRUE(suggestion.is_object()) << name << ": expected a suggestion\n" << doc.value("message", "");
      EXPECT_EQ(suggestion.at("method").get<std::string>(), c["suggests"].as<std::string>()) << name;
      EXPECT_GE(2 * suggestion.at("frames_found").get<int>(), suggestion.at("frames_tried").get<int>()) << name;
    }
    bool all_answered = true, all_refused = true, all_within = true;
    const double tol_bounce = c["check"]["bounce_times_s"] && c["check"]["bounce_times_s"].as<std::string>() != "none"
                                  ? c["check"]["bounce_times_s"].as<double>()
                                  : 0.04;
    for (const auto& chk : c["check"]) {
      const std::string feature = chk.first.as<std::string>();
      const double tol = chk.second.IsNull() || chk.second.as<std::string>() == "none" ? 0.0 : chk.second.as<double>();
      const std::vector<double> truth = truthOf(clip["truth"], feature);
      Measured m = measured(doc, feature);
      std::vector<double> truth_used = truth;
      if (c["subset"] && (feature == "bounce_times_s" || feature == "apex_heights_px")) {
        // the tracker may miss bounces (not invent them): pair each reported bounce with the next truth
        // bounce within tolerance, in order; an apex goes with the bounce it rose from
        const std::vector<double> tb = truthOf(clip["truth"], "bounce_times_s");
        const Measured mb = measured(doc, "bounce_times_s");
        std::vector<int> pair;
        std::size_t j = 0;
        for (double v : mb.values) {
          while (j < tb.size() && tb[j] < v - tol_bounce) ++j;
          pair.push_back(j < tb.size() && std::abs(tb[j] - v) <= tol_bounce ? static_cast<int>(j++) : -1);
        }
        truth_used.clear();
        if (feature == "bounce_times_s") {
          for (int p : pair) truth_used.push_back(p >= 0 ? tb[p] : std::nan(""));
          const int need = c["subset"][feature] ? c["subset"][feature].as<int>() : 1;
          if (static_cast<int>(m.values.size()) < need) truth_used.push_back(std::nan(""));  // too few: wrong
        } else {
          // an apex after a bounce the truth lists but whose apex it does not (the clip's last hops) is not checked
          std::vector<double> kept;
          for (std::size_t k = 0; k < m.values.size() && k < pair.size(); ++k) {
            if (pair[k] >= static_cast<int>(truth.size())) continue;
            truth_used.push_back(pair[k] >= 0 ? truth[pair[k]] : std::nan(""));
            kept.push_back(m.values[k]);
          }
          m.values = kept;
        }
      }
      bool within = !truth_used.empty() && m.present && m.values.size() == truth_used.size();
      for (std::size_t i = 0; within && i < truth_used.size(); ++i)
        within =
            std::isfinite(m.values[i]) && std::isfinite(truth_used[i]) && std::abs(m.values[i] - truth_used[i]) <= tol;
      const bool confident = m.confidence >= 0.5, low = m.confidence < 0.3;
      all_answered = all_answered && within && confident;
      all_within = all_within && within;
      all_refused = all_refused && low;
      // the rule: wrong only with confidence < 0.3
      EXPECT_TRUE(within || low) << name << ": " << feature << " = " << listText(m.values) << " against "
                                 << listText(truth) << " ± " << tol << " with confidence " << m.confidence
                                 << " (a confident wrong answer)\n"
                                 << doc.value("message", "");
      rows.push_back({name, feature, listText(truth_used) + (tol > 0 ? " ± " + std::to_string(tol).substr(0, 5) : ""),
                      listText(m.values), m.confidence,
                      within ? (confident ? "right" : "right, unsure") : (low ? "refused" : "WRONG")});
    }
    if (expect == "answer") {
      EXPECT_TRUE(all_answered) << name << ": expected every feature within tolerance at confidence >= 0.5\n"
                                << doc.value("message", "");
      ++answered;
    } else if (expect == "refusal") {
      EXPECT_TRUE(all_refused) << name << ": expected a refusal (confidence < 0.3)\n" << doc.value("message", "");
      ++refused;
    } else if (expect == "within") {
      EXPECT_TRUE(all_within) << name << ": expected every feature within tolerance (any confidence)\n"
                              << doc.value("message", "");
    } else {
      ASSERT_EQ(expect, "either") << name;
    }
  }
  std::printf("\n| case | feature | truth | tracker | confidence | verdict |\n| --- | --- | --- | --- | --- | --- |\n");
  for (const auto& r : rows)
    std::printf("| %s | %s | %s | %s | %.2f | %s |\n", r.case_name.c_str(), r.feature.c_str(), r.truth.c_str(),
                r.value.c_str(), r.confidence, r.verdict.c_str());
  EXPECT_GE(answered, 4) << "the cases must include clips the tracker answers";
  EXPECT_GE(refused, 4) << "the cases must include clips the tracker refuses";
}

}  // namespace
