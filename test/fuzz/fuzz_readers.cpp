// libFuzzer entry point for the surface file readers.
// The first byte selects the reader (0 PLY, 1 PCD, 2 OBJ, 3 OFF, 4 STL; taken modulo 5), the rest is
// the file; meshes that read are then repaired (repairMesh). A TopoError is the expected answer to bad bytes; any other
// exception escaping, a sanitizer report, or a result that breaks the SurfaceData invariants is a bug in the readers.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/geometry/mesh_repair.h"
#include "topo_gaussian/geometry/surface_reader.h"

namespace {

using namespace topo_gaussian::geometry;

/// Aborts (a crash for libFuzzer) when a successfully read surface is inconsistent.
void checkInvariants(const SurfaceData& s) {
  const std::size_t n = s.points.size();
  if (n == 0) std::abort();  // readers must reject empty input
  auto sameOrEmpty = [n](std::size_t m) { return m == 0 || m == n; };
  if (!sameOrEmpty(s.normals.size()) || !sameOrEmpty(s.colors.size())) std::abort();
  if (s.kind == SurfaceKind::Gaussians) {
    if (s.opacity.size() != n || s.scales.size() != n || s.rotations.size() != n || s.covariances.size() != n)
      std::abort();
    if (s.sh_degree < 0 || s.sh_degree > 3) std::abort();
  } else if (!s.opacity.empty() || !s.covariances.empty()) {
    std::abort();
  }
  for (const auto& t : s.triangles)
    for (int k = 0; k < 3; ++k)
      if (t[k] < 0 || static_cast<std::size_t>(t[k]) >= n) std::abort();
  if (s.kind != SurfaceKind::Mesh && !s.triangles.empty()) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    SurfaceData s;
    switch (data[0] % 5) {
      case 0:
        s = readPly(bytes, "fuzz.ply");
        break;
      case 1:
        s = readPcd(bytes, "fuzz.pcd");
        break;
      case 2:
        s = readObj(bytes, "fuzz.obj");
        break;
      case 3:
        s = readOff(bytes, "fuzz.off");
        break;
      default:
        s = readStl(bytes, "fuzz.stl");
        break;
    }
    checkInvariants(s);
    if (s.kind == SurfaceKind::Mesh) {
      // The mesh repair runs on whatever a reader returns (NaN corners, repeated and out-of-range
      // indices are its business): it must not crash and must return a consistent mesh.
      MeshRepairReport report;
      const SurfaceData repaired = repairMesh(s, &report);
      for (const auto& t : repaired.triangles)
        for (int k = 0; k < 3; ++k)
          if (t[k] < 0 || static_cast<std::size_t>(t[k]) >= repaired.points.size()) std::abort();
      if (report.closed && repaired.triangles.empty()) std::abort();
    }
  } catch (const topo_gaussian::TopoError&) {
    // expected for malformed input
  }
  return 0;
}
