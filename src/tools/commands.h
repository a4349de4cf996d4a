// The `topo` subcommands; each returns the process exit code and throws UsageError/TopoError.
#pragma once

#include <string>
#include <vector>

namespace topo_gaussian::tools {

int exportCommand(const std::vector<std::string>& args);
int fillCommand(const std::vector<std::string>& args);
int generateCommand(const std::vector<std::string>& args);
int inferCommand(const std::vector<std::string>& args);
int shapeCommand(const std::vector<std::string>& args);
int simulateCommand(const std::vector<std::string>& args);
int tasksCommand(const std::vector<std::string>& args);
int trackCommand(const std::vector<std::string>& args);

}  // namespace topo_gaussian::tools
