// Frame dumper for the real-clip ground truth (decodes only; no tracking).
// Build: g++ -O2 -std=c++17 dump_frames.cpp -o /tmp/dump_frames $(pkg-config --cflags --libs opencv4)
// Usage: /tmp/dump_frames <video> <outdir> [every_n=1] [scale=1.0]
// Writes <outdir>/f%05d.ppm (binary P6, BGR->RGB by imwrite) for every N-th frame and
// <outdir>/index.txt: "fps <container fps>", "count <announced frames>", then per decoded frame
// "<index> <pos_msec> <written 0|1>", and finally "decoded <n>".
#include <opencv2/opencv.hpp>
#include <cstdio>
#include <string>
int main(int argc, char** argv) {
  if (argc < 3) { std::fprintf(stderr, "usage: %s video outdir [every_n] [scale]\n", argv[0]); return 2; }
  cv::VideoCapture cap(argv[1]);
  if (!cap.isOpened()) { std::fprintf(stderr, "cannot open %s\n", argv[1]); return 1; }
  int every = argc > 3 ? std::atoi(argv[3]) : 1; double scale = argc > 4 ? std::atof(argv[4]) : 1.0;
  std::string out = argv[2];
  FILE* idx = std::fopen((out + "/index.txt").c_str(), "w");
  std::fprintf(idx, "fps %.6f\ncount %.0f\nsize %.0f %.0f\n", cap.get(cv::CAP_PROP_FPS), cap.get(cv::CAP_PROP_FRAME_COUNT),
               cap.get(cv::CAP_PROP_FRAME_WIDTH), cap.get(cv::CAP_PROP_FRAME_HEIGHT));
  cv::Mat f; int i = 0;
  while (true) {
    double ms = cap.get(cv::CAP_PROP_POS_MSEC);
    if (!cap.read(f) || f.empty()) break;
    ms = cap.get(cv::CAP_PROP_POS_MSEC);  // timestamp of the frame just read
    bool w = (i % every) == 0;
    if (w) {
      if (scale != 1.0) cv::resize(f, f, cv::Size(), scale, scale, cv::INTER_AREA);
      char name[64]; std::snprintf(name, sizeof name, "/f%05d.ppm", i);
      cv::imwrite(out + name, f);
    }
    std::fprintf(idx, "%d %.3f %d\n", i, ms, w ? 1 : 0);
    ++i;
  }
  std::fprintf(idx, "decoded %d\n", i);
  std::fclose(idx);
  return 0;
}
