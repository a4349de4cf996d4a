// Reading back what a run left in files, for the export: the loss history (and task name) in a
// report.json written by `topo infer`, and time series from a CSV such as `topo simulate --signal`
// writes (time, value) or a table of observed and simulated values.
#pragma once

#include <string>
#include <vector>

namespace topo_gaussian::io {

struct LossPoint {
  int iteration = 0;
  double loss = 0.0;  ///< NaN where the report says null
};

/// The "loss_history" array of a report.json text (each entry's "iteration" and "loss").
/// `source` names the file in messages. Throws TopoError when the text is not a report (no
/// "loss_history" array, malformed entries).
std::vector<LossPoint> lossHistoryFromReport(const std::string& json, const std::string& source);

/// The string value of a top-level "key": "value" in a JSON text, or "" when absent.
std::string jsonStringField(const std::string& json, const std::string& key);

struct SignalSeries {
  std::string label;             ///< the column's header (or "column N")
  std::vector<double> t, value;  ///< time [s] and value, rows where the column has a number
};

/// A CSV whose first column is time and whose every other column is one series (e.g.
/// "time_s,observed,simulated", or the "time_s,tilt_deg" of topo simulate --signal). An optional
/// header row names the columns; blank cells are skipped (series sampled at different times can
/// share one file); lines starting with '#' are comments. Throws TopoError naming the file and the
/// line for a cell that is not a number, a row without a value column, or no data at all.
std::vector<SignalSeries> readSignalCsv(const std::string& path);

/// Root-mean-square of (b − a) over a's samples that lie inside b's time range, with b linearly
/// interpolated (b sorted by time first); NaN when fewer than 2 samples overlap. `overlap` gets the count.
double rmsDifference(const SignalSeries& a, const SignalSeries& b, std::size_t* overlap = nullptr);

}  // namespace topo_gaussian::io
