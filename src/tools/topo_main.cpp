// `topo`: the command-line front end. Subcommands: fill, generate, shape, infer, simulate, tasks, track, export.
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include "args.h"
#include "commands.h"
#include "topo_gaussian/common/error.h"

namespace {

const char* kUsage =
    "usage: topo <command> [options]\n"
    "\n"
    "commands:\n"
    "  fill       surface file in (3DGS .ply, .ply/.pcd points, .obj/.off/.stl/.ply mesh), volume .ply out\n"
    "  generate   write a closed test mesh (sphere, torus, box) as .obj\n"
    "  shape      write a soft-body task's default shape (finger, pear, beam, tumbler) as .obj [+ volume .ply]\n"
    "  infer      find an interior whose simulated behaviour matches observed targets\n"
    "  simulate   print the simulated features of a given interior\n"
    "  tasks      list the inference tasks; --markdown: their parameters as tables\n"
    "  track      track an object in a video: period, amplitude, bounces, bending angle\n"
    "  export     an inferred interior as a watertight STL, slice and loss pictures, export.json\n"
    "\n"
    "`topo <command> --help` describes each command's options.\n"
    "exit codes: 0 success, 1 bad input or failed computation, 2 bad command line\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace topo_gaussian::tools;
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h" || std::string(argv[1]) == "help") {
    std::cout << kUsage;
    return argc < 2 ? 2 : 0;
  }
  const std::string cmd = argv[1];
  const std::vector<std::string> rest(argv + 2, argv + argc);
  try {
    if (cmd == "fill") return fillCommand(rest);
    if (cmd == "generate") return generateCommand(rest);
    if (cmd == "infer") return inferCommand(rest);
    if (cmd == "shape") return shapeCommand(rest);
    if (cmd == "simulate") return simulateCommand(rest);
    if (cmd == "tasks") return tasksCommand(rest);
    if (cmd == "track") return trackCommand(rest);
    if (cmd == "export") return exportCommand(rest);
    std::cerr << "topo: unknown command '" << cmd << "'\n\n" << kUsage;
    return 2;
  } catch (const UsageError& e) {
    std::cerr << "topo " << cmd << ": " << e.what() << " (see `topo " << cmd << " --help`)\n";
    return 2;
  } catch (const topo_gaussian::TopoError& e) {
    std::cerr << "topo " << cmd << ": error: " << e.what() << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "topo " << cmd
              << ": error: out of memory: the input or the grids it needs did not fit in this machine's memory. "
                 "Fix: use a larger --spacing or a smaller --count, downsample or crop the input, or run on a "
                 "machine with more memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "topo " << cmd << ": unexpected error: " << e.what() << "\n";
    return 1;
  }
}
