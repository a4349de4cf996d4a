#include "topo_gaussian/io/run_files.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <numeric>

#include <nlohmann/json.hpp>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

namespace {

const char* const kReportFix = "give the report.json that topo infer wrote next to interior.ply";

std::string trim(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  std::string t = s.substr(a, b - a);
  if (t.size() >= 2 && t.front() == '"' && t.back() == '"') t = t.substr(1, t.size() - 2);
  return t;
}

bool parseCell(const std::string& cell, double* v) {
  if (cell.empty()) return false;
  char* end = nullptr;
  *v = std::strtod(cell.c_str(), &end);
  return end == cell.c_str() + cell.size();
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

}  // namespace

std::vector<LossPoint> lossHistoryFromReport(const std::string& text, const std::string& source) {
  const nlohmann::json report = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (report.is_discarded()) throw TopoError(source, "is not valid JSON (truncated or not a report)", kReportFix);
  const auto history = report.find("loss_history");
  if (!report.is_object() || history == report.end() || !history->is_array())
    throw TopoError(source, "has no \"loss_history\" array, so it is not a report of topo infer", kReportFix);
  std::vector<LossPoint> out;
  for (const auto& entry : *history) {
    const auto loss = entry.is_object() ? entry.find("loss") : entry.end();
    if (!entry.is_object() || loss == entry.end() || !(loss->is_number() || loss->is_null()))
      throw TopoError(
          source, "has a \"loss_history\" entry without a numeric \"loss\" (entry " + std::to_string(out.size()) + ")",
          kReportFix);
    LossPoint p;
    p.loss = loss->is_null() ? std::numeric_limits<double>::quiet_NaN() : loss->get<double>();
    const auto it = entry.find("iteration");
    p.iteration = it != entry.end() && it->is_number() ? it->get<int>() : int(out.size());
    out.push_back(p);
  }
  return out;
}

std::string jsonStringField(const std::string& text, const std::string& key) {
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return "";
  const auto v = j.find(key);
  return v != j.end() && v->is_string() ? v->get<std::string>() : "";
}

std::vector<SignalSeries> readSignalCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in)
    throw TopoError(path, "cannot open the signal file",
                    "give a CSV of time and values (topo simulate --signal writes one)");
  const std::string fix =
      "write one row per sample: time, then one value per series (blank where a series has no sample)";
  std::vector<SignalSeries> series;
  std::string line;
  std::size_t line_no = 0;
  bool data_seen = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::vector<std::string> cells = splitCsv(line);
    double time = 0.0;
    if (!parseCell(cells[0], &time)) {
      if (data_seen || !series.empty())
        throw TopoError(
            path, "line " + std::to_string(line_no) + ": time '" + cells[0].substr(0, 30) + "' is not a number", fix);
      for (std::size_t c = 1; c < cells.size(); ++c)  // header row
        series.push_back({cells[c].empty() ? "column " + std::to_string(c + 1) : cells[c], {}, {}});
      if (series.empty())
        throw TopoError(path, "line " + std::to_string(line_no) + ": the header names no value column", fix);
      continue;
    }
    if (cells.size() < 2)
      throw TopoError(path, "line " + std::to_string(line_no) + " has a time but no value column", fix);
    if (!std::isfinite(time))
      throw TopoError(path, "line " + std::to_string(line_no) + ": the time is not finite", fix);
    while (series.size() < cells.size() - 1) series.push_back({"column " + std::to_string(series.size() + 2), {}, {}});
    for (std::size_t c = 1; c < cells.size(); ++c) {
      if (cells[c].empty()) continue;
      double v = 0.0;
      if (!parseCell(cells[c], &v))
        throw TopoError(path,
                        "line " + std::to_string(line_no) + ", column " + std::to_string(c + 1) + ": '" +
                            cells[c].substr(0, 30) + "' is not a number",
                        fix);
      series[c - 1].t.push_back(time);
      series[c - 1].value.push_back(v);
    }
    data_seen = true;
  }
  series.erase(std::remove_if(series.begin(), series.end(), [](const SignalSeries& s) { return s.t.empty(); }),
               series.end());
  if (series.empty()) throw TopoError(path, "has no data rows", fix);
  return series;
}

double rmsDifference(const SignalSeries& a, const SignalSeries& b, std::size_t* overlap) {
  std::vector<std::size_t> order(b.t.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) { return b.t[i] < b.t[j]; });
  std::vector<double> bt, bv;
  for (std::size_t i : order) bt.push_back(b.t[i]), bv.push_back(b.value[i]);
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < a.t.size() && bt.size() >= 2; ++k) {
    const double t = a.t[k];
    if (t < bt.front() || t > bt.back() || !std::isfinite(a.value[k])) continue;
    std::size_t j = std::size_t(std::upper_bound(bt.begin(), bt.end(), t) - bt.begin());
    j = std::clamp<std::size_t>(j, 1, bt.size() - 1);
    const double dt = bt[j] - bt[j - 1];
    const double w = dt > 0.0 ? (t - bt[j - 1]) / dt : 0.0;
    const double d = bv[j - 1] + w * (bv[j] - bv[j - 1]) - a.value[k];
    if (!std::isfinite(d)) continue;
    sum += d * d;
    ++n;
  }
  if (overlap) *overlap = n;
  return n >= 2 ? std::sqrt(sum / double(n)) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace topo_gaussian::io
