#include "topo_gaussian/io/trajectory_csv.h"

#include <cctype>
#include <fstream>
#include <sstream>

#include "topo_gaussian/common/error.h"

namespace topo_gaussian::io {

void readTrajectoryCsv(const std::string& path, std::size_t points, std::vector<double>* t,
                       std::vector<std::vector<Eigen::Vector3d>>* samples) {
  std::ifstream in(path);
  if (!in) throw TopoError(path, "cannot open the trajectory file", "check the path");
  t->clear();
  samples->clear();
  std::string line;
  int row = 0;
  while (std::getline(in, line)) {
    ++row;
    if (line.empty() || line[0] == '#' || std::isalpha(static_cast<unsigned char>(line[0]))) continue;
    for (char& ch : line)
      if (ch == ',' || ch == ';') ch = ' ';
    std::istringstream ls(line);
    std::vector<double> v;
    double x;
    while (ls >> x) v.push_back(x);
    if (v.size() != 1 + 3 * points)
      throw TopoError(path + " row " + std::to_string(row),
                      "has " + std::to_string(v.size()) + " numbers, expected 1 + 3 x " + std::to_string(points),
                      "write t then x y z for each pivot point (see pivot_points)");
    t->push_back(v[0]);
    std::vector<Eigen::Vector3d> pts;
    for (std::size_t k = 0; k < points; ++k) pts.emplace_back(v[1 + 3 * k], v[2 + 3 * k], v[3 + 3 * k]);
    samples->push_back(pts);
  }
  if (t->empty()) throw TopoError(path, "holds no samples", "write one row per observed frame");
}

}  // namespace topo_gaussian::io
