// Internal: the trajectory target format shared by the ball and pear tasks — CSV rows of t, then
// x y z of each tracked point [s, m]; '#' and header lines are skipped.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace topo_gaussian::io {

/// Throws TopoError naming the file and row for unreadable files, wrong column counts or no rows.
void readTrajectoryCsv(const std::string& path, std::size_t points, std::vector<double>* t,
                       std::vector<std::vector<Eigen::Vector3d>>* samples);

}  // namespace topo_gaussian::io
