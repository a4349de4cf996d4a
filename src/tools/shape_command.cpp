// `topo shape NAME`: writes the default shape of a soft-body task (finger, pear, beam, tumbler) as a
// closed mesh, and optionally as the lattice volume .ply the tasks use.
#include <iomanip>
#include <iostream>

#include "args.h"
#include "commands.h"
#include "topo_gaussian/geometry/mesh_metrics.h"
#include "topo_gaussian/geometry/shape_generator.h"
#include "topo_gaussian/io/volume_ply.h"
#include "topo_gaussian/physics/default_shapes.h"

namespace topo_gaussian::tools {

namespace {

void printHelp() {
  std::cout << "usage: topo shape NAME [--output FILE.obj] [--resolution N] [--spacing S --volume FILE.ply]\n"
               "\n"
               "Writes the default shape that the soft-body tasks use when no surface is given, for you to\n"
               "inspect or 3D-print. All dimensions in metres, z up. NAME is one of:\n";
  for (const auto& n : defaultShapeNames()) {
    const DefaultShape s = defaultShape(n);
    std::cout << "  " << n << std::string(n.size() < 9 ? 9 - n.size() : 1, ' ') << s.description << "\n"
              << "           (volume " << std::setprecision(4) << s.volume_m3 << " m^3; --spacing at most "
              << s.thickness_m / 3.0 << " m)\n";
  }
  std::cout << "\n"
               "  --output FILE.obj   closed, outward-oriented triangle mesh (Wavefront OBJ, metres)\n"
               "  --resolution N      mesh segments around a full circle, 8..4096 (default 64)\n"
               "  --volume FILE.ply   also write the particle cloud: a cell-centred lattice of spacing S,\n"
               "                      x y z volume surface (volume in m^3), as `topo fill` writes it\n"
               "  --spacing S         lattice spacing in metres for --volume (V_i = S^3; at least 3 particles\n"
               "                      across the thinnest dimension, see above; one that divides the\n"
               "                      dimensions, e.g. 0.0025 or 0.001, keeps the box parts' volume exact)\n"
               "At least one of --output and --volume is required. The log line gives the mesh volume in m^3.\n";
}

}  // namespace

int shapeCommand(const std::vector<std::string>& argv) {
  std::string name;
  std::vector<std::string> rest = argv;
  if (!rest.empty() && rest.front().rfind("--", 0) != 0) {
    name = rest.front();
    rest.erase(rest.begin());
  }
  const Args a(rest, {"help"}, {"output", "resolution", "spacing", "volume"});
  if (a.has("help")) {
    printHelp();
    return 0;
  }
  if (name.empty()) throw UsageError("a shape NAME is required (finger, pear, beam or tumbler)");
  if (!a.has("output") && !a.has("volume")) throw UsageError("--output FILE.obj or --volume FILE.ply is required");
  if (a.has("volume") != a.has("spacing")) throw UsageError("--volume FILE.ply and --spacing S go together");
  const long resolution = a.integer("resolution", 64);
  if (resolution < 8 || resolution > 4096) throw UsageError("--resolution must be 8..4096 segments around a circle");
  const double spacing = a.num("spacing", 0.0);
  if (a.has("spacing") && !(spacing > 0.0)) throw UsageError("--spacing must be a positive number of metres");

  const DefaultShape shape = defaultShape(name);  // unknown name: TopoError listing the valid ones (exit 1)
  if (a.has("output")) {
    const geometry::SurfaceData mesh = geometry::makeDefaultShapeMesh(name, int(resolution));
    geometry::writeObj(mesh, a.str("output"));
    std::cerr << "[topo shape] wrote " << a.str("output") << " (" << name << ", " << mesh.points.size() << " vertices, "
              << mesh.triangles.size() << " triangles, volume " << geometry::meshIntegrals(mesh).volume
              << " m^3; exact " << shape.volume_m3 << " m^3)" << std::endl;
  }
  if (a.has("volume")) {
    const VolumeCloud cloud = defaultShapeCloud(shape, spacing);
    io::writeVolumePly(cloud, a.str("volume"));
    std::cerr << "[topo shape] wrote " << a.str("volume") << " (" << name << ", " << cloud.size() << " particles, "
              << cloud.surfaceCount() << " on the surface, spacing " << spacing << " m, volume " << cloud.totalVolume()
              << " m^3)" << std::endl;
  }
  return 0;
}

}  // namespace topo_gaussian::tools
