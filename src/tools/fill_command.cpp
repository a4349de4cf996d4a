#include <filesystem>
#include <iostream>
#include <sstream>

#include "args.h"
#include "commands.h"
#include "topo_gaussian/geometry/ingest.h"
#include "topo_gaussian/io/volume_ply.h"
#include "volume_picture.h"

namespace topo_gaussian::tools {

namespace {

const char* kHelp =
    "usage: topo fill --input FILE --output VOLUME.ply [--spacing S | --count N] [options]\n"
    "\n"
    "Reads a surface, cleans it, fills its interior with particles on a regular lattice and writes\n"
    "the volume .ply (x y z volume surface; volume in m^3, surface = 1 within one spacing of the boundary).\n"
    "\n"
    "  --input FILE              .ply (3D Gaussians, points or mesh), .pcd, .obj, .off, .stl\n"
    "  --output FILE             volume .ply to write\n"
    "  --spacing S               lattice spacing in metres (after --scale)\n"
    "  --count N                 target particle count instead (default 50000, met within ~15 %)\n"
    "  --json                    print one JSON object with the numbers on stdout\n"
    "  --png FILE                also write a picture (cut-away view and centre slice)\n"
    "  --up-axis A               the input's up axis: x y z -x -y -z (default z); rotated to +z before\n"
    "                            cleaning (Y-up meshes such as bunny.off: --up-axis y)\n"
    "  --scale F                 multiply coordinates, e.g. 0.001 for millimetres (default 1)\n"
    "  --recenter                move the bounding-box centre to the origin\n"
    "  --crop-min X,Y,Z --crop-max X,Y,Z   keep only points inside this box (metres)\n"
    "  --opacity-threshold F     drop Gaussians below this opacity (default 0.02)\n"
    "  --outlier-neighbours K    statistical outlier removal k (default 16, 0 = off; not for meshes)\n"
    "  --outlier-std F           ... and its std-dev ratio (default 3)\n"
    "  --jitter F                random particle offset, fraction of the spacing (default 0)\n"
    "  --grid-resolution N       density grid cells along the longest side (default: the spacing)\n"
    "  --density-threshold F     PhysGaussian shell density (default 2.0)\n"
    "  --search-threshold F      PhysGaussian search density (default 1.0)\n"
    "  --exclude-direction D     PhysGaussian direction not searched, 0..5 = +x -x +y -y +z -z (default 5)\n"
    "  --ray-direction D         PhysGaussian parity ray direction (default 4)\n"
    "  --closing-cells N         seal gaps up to 2N grid cells by closing (default -1: automatic, from the\n"
    "                            point spacing; 0: PhysGaussian's ray-parity fill with a leak check)\n"
    "  --max-open-fraction F     refuse when more of the interior leaks outside (0..1, default 0.05)\n"
    "  --contact-spacing S       spacing of the contact samples on the true surface in metres (stored in the\n"
    "                            volume .ply, element contact; the ground contact uses them); default 0 =\n"
    "                            min(spacing / 2, bounding-box diagonal / 400) for a mesh, / 200 for points\n"
    "                            and Gaussians\n"
    "\n"
    "Warnings (repairs of a mesh, a fallback to the density method, a suspiciously large object) go to\n"
    "stderr as '[topo fill] warning: ...' lines and into --json's \"warnings\". The output must not be the\n"
    "input. Exit codes: 0 done, 1 bad input (the message names the file, the problem and the fix),\n"
    "2 bad command line.\n";

Eigen::Vector3d vec3(const Args& a, const std::string& name, const Eigen::Vector3d& fallback) {
  if (!a.has(name)) return fallback;
  Eigen::Vector3d v;
  const std::string s = a.str(name);
  char c1 = 0, c2 = 0;
  std::istringstream in(s);
  if (!(in >> v.x() >> c1 >> v.y() >> c2 >> v.z()) || c1 != ',' || c2 != ',')
    throw UsageError("--" + name + " expects X,Y,Z, got '" + s + "'");
  return v;
}

}  // namespace

int fillCommand(const std::vector<std::string>& argv) {
  const Args a(argv, {"json", "recenter", "help"},
               {"input",
                "output",
                "spacing",
                "count",
                "png",
                "up-axis",
                "scale",
                "crop-min",
                "crop-max",
                "opacity-threshold",
                "outlier-neighbours",
                "outlier-std",
                "jitter",
                "grid-resolution",
                "density-threshold",
                "search-threshold",
                "exclude-direction",
                "ray-direction",
                "closing-cells",
                "max-open-fraction",
                "contact-spacing"});
  if (a.has("help")) {
    std::cout << kHelp;
    return 0;
  }
  if (!a.has("input")) throw UsageError("--input FILE is required");
  if (!a.has("output")) throw UsageError("--output VOLUME.ply is required");
  if (a.has("spacing") && a.has("count")) throw UsageError("give --spacing or --count, not both");

  const std::string input = a.str("input"), output = a.str("output");
  if (sameFile(input, output))
    throw UsageError("--output " + output + " is the input file itself: writing it would destroy the surface; give " +
                     "another name, e.g. --output " + std::filesystem::path(output).stem().string() + "_volume.ply");
  if (a.has("png") && sameFile(input, a.str("png")))
    throw UsageError("--png " + a.str("png") + " is the input file itself; give another name");
  geometry::IngestOptions o;
  o.up_axis = a.str("up-axis", "z");
  if (o.up_axis == "+x" || o.up_axis == "+y" || o.up_axis == "+z") o.up_axis = o.up_axis.substr(1);
  if (o.up_axis != "x" && o.up_axis != "y" && o.up_axis != "z" && o.up_axis != "-x" && o.up_axis != "-y" &&
      o.up_axis != "-z")
    throw UsageError("--up-axis expects x, y, z, -x, -y or -z, got '" + o.up_axis + "'");
  o.fill.spacing_m = a.num("spacing", 0.0);
  if (a.has("spacing") && !(o.fill.spacing_m > 0.0)) throw UsageError("--spacing must be a positive number of metres");
  const long count = a.integer("count", long(o.fill.target_count));
  if (count < 8) throw UsageError("--count must be at least 8");
  o.fill.target_count = std::size_t(count);
  o.fill.jitter = a.num("jitter", 0.0);
  o.fill.grid_resolution = int(a.integer("grid-resolution", 0));
  o.fill.max_open_fraction = a.num("max-open-fraction", o.fill.max_open_fraction);
  o.fill.contact.spacing_m = a.num("contact-spacing", 0.0);
  if (a.has("contact-spacing") && !(o.fill.contact.spacing_m > 0.0))
    throw UsageError("--contact-spacing must be a positive number of metres");
  o.fill.density.density_threshold = a.num("density-threshold", o.fill.density.density_threshold);
  o.fill.density.search_threshold = a.num("search-threshold", o.fill.density.search_threshold);
  o.fill.density.search_exclude_direction =
      int(a.integer("exclude-direction", o.fill.density.search_exclude_direction));
  o.fill.density.ray_cast_direction = int(a.integer("ray-direction", o.fill.density.ray_cast_direction));
  o.fill.density.closing_cells = int(a.integer("closing-cells", o.fill.density.closing_cells));
  o.clean.scale = a.num("scale", 1.0);
  o.clean.recenter = a.has("recenter");
  o.clean.opacity_threshold = a.num("opacity-threshold", o.clean.opacity_threshold);
  o.clean.outlier_neighbours = int(a.integer("outlier-neighbours", o.clean.outlier_neighbours));
  o.clean.outlier_std_ratio = a.num("outlier-std", o.clean.outlier_std_ratio);
  o.clean.crop_min = vec3(a, "crop-min", o.clean.crop_min);
  o.clean.crop_max = vec3(a, "crop-max", o.clean.crop_max);

  std::cerr << "[topo fill] reading, cleaning and filling " << input << " ..." << std::endl;
  const geometry::IngestResult r = geometry::ingestFile(input, o);
  std::cerr << "[topo fill] " << toString(r.kind) << " (" << r.clean.points_in << " points) -> " << r.cloud.size()
            << " particles, volume " << r.cloud.totalVolume() << " m^3, spacing " << r.cloud.spacing << " m ("
            << r.fill.method << ", " << r.seconds << " s)" << std::endl;
  std::cerr << "[topo fill] " << r.cloud.contact.size() << " contact samples on the true surface ("
            << r.cloud.contact.origin << ", spacing " << r.cloud.contact.spacing << " m, area "
            << r.cloud.contact.totalArea() << " m^2)" << std::endl;
  if (r.fill.mesh_volume_m3 > 0.0)
    std::cerr << "[topo fill] exact mesh volume " << r.fill.mesh_volume_m3 << " m^3, filled " << r.fill.total_volume_m3
              << " m^3 (" << (r.fill.exact_boundary ? "exact boundary cells" : "whole boundary cells") << ")"
              << std::endl;
  for (const std::string& w : r.warnings) std::cerr << "[topo fill] warning: " << w << std::endl;
  io::writeVolumePly(r.cloud, output);
  std::cerr << "[topo fill] wrote " << output << std::endl;
  if (a.has("png")) {
    writeVolumePicture(r.cloud, input, a.str("png"));
    std::cerr << "[topo fill] wrote " << a.str("png") << std::endl;
  }
  if (a.has("json")) std::cout << geometry::toJson(r) << std::endl;
  return 0;
}

}  // namespace topo_gaussian::tools
