// Tests that need a container OpenCV's writer cannot make (a display matrix, per-frame timestamps):
// the video stream of a file OpenCV wrote is copied, without re-encoding, into a new container with
// libavformat. Only with TOPO_HAVE_AVFORMAT (CMakeLists.txt links libavformat to those tests).
#pragma once

#ifdef TOPO_HAVE_AVFORMAT
#include <functional>
#include <string>

extern "C" {
#include <libavformat/avformat.h>
}

namespace topo_test {

/// Copies the video stream of `in_path` into `out_path` (container `format`, e.g. "mp4", "matroska").
/// `stream(out, in)` may set the new stream's time base or side data (its time base starts as the
/// input's); `packet(p, k)` may set packet k's times, in the new stream's time base as set before the
/// header was written (then rescaled to the muxer's), and returns false to leave the packet out.
/// Returns an empty string or what failed.
inline std::string remuxVideo(const std::string& in_path, const std::string& out_path, const char* format,
                              const std::function<void(AVStream*, const AVStream*)>& stream,
                              const std::function<bool(AVPacket*, int)>& packet) {
  AVFormatContext* in = nullptr;
  if (avformat_open_input(&in, in_path.c_str(), nullptr, nullptr) < 0) return "cannot open " + in_path;
  avformat_find_stream_info(in, nullptr);
  AVFormatContext* out = nullptr;
  avformat_alloc_output_context2(&out, nullptr, format, out_path.c_str());
  int vi = -1;
  AVRational tb{1, 1};
  for (unsigned i = 0; out && i < in->nb_streams && vi < 0; ++i) {
    if (in->streams[i]->codecpar->codec_type != AVMEDIA_TYPE_VIDEO) continue;
    vi = static_cast<int>(i);
    AVStream* s = avformat_new_stream(out, nullptr);
    avcodec_parameters_copy(s->codecpar, in->streams[i]->codecpar);
    s->codecpar->codec_tag = 0;
    s->time_base = in->streams[i]->time_base;
    if (stream) stream(s, in->streams[i]);
    tb = s->time_base;
  }
  std::string err;
  if (!out) err = "no " + std::string(format) + " muxer";
  if (err.empty() && vi < 0) err = "no video stream";
  if (err.empty() && avio_open(&out->pb, out_path.c_str(), AVIO_FLAG_WRITE) < 0) err = "cannot write " + out_path;
  if (err.empty() && avformat_write_header(out, nullptr) < 0) err = "cannot write the header";
  if (err.empty()) {
    AVPacket* p = av_packet_alloc();
    int k = 0;
    while (av_read_frame(in, p) >= 0) {
      if (p->stream_index == vi) {
        p->stream_index = 0;
        av_packet_rescale_ts(p, in->streams[vi]->time_base, tb);
        if (!packet || packet(p, k++)) {
          av_packet_rescale_ts(p, tb, out->streams[0]->time_base);
          p->pos = -1;
          if (av_interleaved_write_frame(out, p) < 0) err = "cannot write a packet";
        }
      }
      av_packet_unref(p);
    }
    av_packet_free(&p);
    av_write_trailer(out);
  }
  if (out && out->pb) avio_closep(&out->pb);
  if (out) avformat_free_context(out);
  avformat_close_input(&in);
  return err;
}

}  // namespace topo_test
#endif
