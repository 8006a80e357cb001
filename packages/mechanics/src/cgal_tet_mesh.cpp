// CGAL stays private to this translation unit: Mesh_3 is header-only and takes tens of seconds and
// gigabytes to compile, so no public header of demnerf_mechanics includes it (CMake links CGAL
// PRIVATE for the same reason).
#include "demnerf/mechanics/cgal_tet_mesh.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>

#include <cmath>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/plane_section.hpp"
#include "demnerf/mechanics/sharp_features.hpp"

namespace demnerf::mechanics {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Surface = CGAL::Surface_mesh<Kernel::Point_3>;
using Domain = CGAL::Polyhedral_mesh_domain_with_features_3<Kernel, Surface>;
using Triangulation = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using Complex = CGAL::Mesh_complex_3_in_triangulation_3<Triangulation, Domain::Corner_index, Domain::Curve_index>;
using Criteria = CGAL::Mesh_criteria_3<Triangulation>;

// Mesh_3 decides inside/outside by ray shooting against the surface, so a hole or a flipped
// triangle gives a silently wrong body: check that every directed edge is matched by exactly one
// opposite edge (closed, two-manifold along edges, consistently oriented) before meshing.
void checkClosed(const core::TriangleMesh& surface) {
  if (surface.vertices.empty() || surface.faces.empty())
    throw core::Error("tetrahedral mesh: the surface mesh is empty (" + std::to_string(surface.vertices.size()) +
                      " vertices, " + std::to_string(surface.faces.size()) + " triangles); pass a closed triangle mesh");
  const long long n = static_cast<long long>(surface.vertices.size());
  std::map<std::pair<int, int>, int> directed;
  for (std::size_t f = 0; f < surface.faces.size(); ++f) {
    const auto& t = surface.faces[f];
    for (int k = 0; k < 3; ++k) {
      if (t[k] < 0 || t[k] >= n)
        throw core::Error("tetrahedral mesh: triangle " + std::to_string(f) + " refers to vertex " +
                          std::to_string(t[k]) + " of " + std::to_string(n));
      if (t[k] == t[(k + 1) % 3])
        throw core::Error("tetrahedral mesh: triangle " + std::to_string(f) +
                          " repeats a vertex; remove degenerate triangles (demnerf mesh repair) first");
    }
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  }
  std::size_t open = 0, misoriented = 0;
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (reverse == directed.end()) ++open;
    else if (count != 1 || reverse->second != 1) ++misoriented;
  }
  if (open > 0)
    throw core::Error("tetrahedral mesh: the surface is not closed: " + std::to_string(open) +
                      " triangle edges have no neighbour; repair the mesh (close its holes) or use the voxel mesher");
  if (misoriented > 0)
    throw core::Error("tetrahedral mesh: " + std::to_string(misoriented) +
                      " surface edges are shared by more than two triangles or by two with the same orientation; "
                      "make the surface a consistently oriented two-manifold or use the voxel mesher");
}

Surface surfaceMesh(const core::TriangleMesh& mesh) {
  std::vector<Kernel::Point_3> points;
  points.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::array<std::size_t, 3>> triangles;
  triangles.reserve(mesh.faces.size());
  for (const auto& f : mesh.faces)
    triangles.push_back({static_cast<std::size_t>(f[0]), static_cast<std::size_t>(f[1]), static_cast<std::size_t>(f[2])});
  Surface result;
  CGAL::Polygon_mesh_processing::polygon_soup_to_polygon_mesh(points, triangles, result);
  return result;
}

/// Each cut plane as a square over the body: Mesh_3 puts facets on the part inside the body. Where
/// it meets the surface the two are not protected as a feature (features may meet only at their
/// ends, and this rim crosses the body's edges: Mesh_3 crashed), so the elements along the rim may
/// straddle the plane a little; those inside do not. (A section kept a quarter cell inside the
/// surface instead was worse: a cuboid clamped at x <= 15 mm 1.8 % softer at 7 mm cells (0.8 % at
/// 5 mm) than a mesh with nodes on the plane, against 0.1 % with the square, and its border
/// crashed Mesh_3.)
std::vector<Surface> cutPlanes(const core::TriangleMesh& surface, const CgalMeshConfig& config, double cell) {
  std::vector<Surface> cuts;
  for (const CgalMeshConfig::Plane& plane : config.cut_planes)
    if (planeCutsBody(surface, plane.point, plane.normal, 0.1 * cell))
      cuts.push_back(surfaceMesh(planeSquare(surface, plane.point, plane.normal, cell)));
  return cuts;
}

void checkConfig(const CgalMeshConfig& config) {
  if (config.order != 1 && config.order != 2)
    throw core::Error("tetrahedral mesh: order must be 1 (TET4) or 2 (TET10), got " + std::to_string(config.order));
  if (!(config.cell >= 0.0) || !std::isfinite(config.cell))
    throw core::Error("tetrahedral mesh: the cell size must be a positive length in metres (0: automatic), got " +
                      std::to_string(config.cell));
  if (!(config.facet_distance >= 0.0) || !std::isfinite(config.facet_distance))
    throw core::Error("tetrahedral mesh: facet_distance must be a positive length in metres (0: cell / 10), got " +
                      std::to_string(config.facet_distance));
}

}  // namespace

bool creasesAreNoise(const core::TriangleMesh& surface, const CgalMeshConfig& config) {
  if (!(config.feature_angle >= 0.0 && config.feature_angle <= 180.0))
    throw core::Error("tetrahedral mesh: feature_angle must be in [0, 180] degrees, got " +
                      std::to_string(config.feature_angle));
  if (!(config.max_dangling_fraction >= 0.0 && config.max_dangling_fraction <= 1.0))
    throw core::Error("tetrahedral mesh: max_dangling_fraction must be in [0, 1], got " +
                      std::to_string(config.max_dangling_fraction));
  double total = 0.0, dangling = 0.0;
  for (const SharpCurve& curve : sharpCurves(surface, config.feature_angle)) {
    total += curve.length;
    if (curve.dangling) dangling += curve.length;
  }
  return dangling > config.max_dangling_fraction * total;
}

TetMesh cgalMeshFromSurface(const core::TriangleMesh& surface, const CgalMeshConfig& config) {
  checkConfig(config);
  checkClosed(surface);

  Eigen::Vector3d lo = surface.vertices[0], hi = lo;
  for (const auto& v : surface.vertices) {
    if (!v.allFinite()) throw core::Error("tetrahedral mesh: the surface has a vertex that is not finite");
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double diagonal = (hi - lo).norm();
  if (!(diagonal > 0)) throw core::Error("tetrahedral mesh: the surface has zero extent");
  const double cell = config.cell > 0 ? config.cell : diagonal / 20.0;
  const double facet_distance = config.facet_distance > 0 ? config.facet_distance : cell / 10.0;

  const Surface polyhedron = surfaceMesh(surface);
  const std::vector<Surface> cuts = cutPlanes(surface, config, cell);
  std::vector<const Surface*> cut_pointers;
  for (const Surface& cut : cuts) cut_pointers.push_back(&cut);

  // The domain's initial points draw random numbers: seed them. A mesh still differs slightly from
  // one call to the next when the heap differs (box test after the DEM tests: 799 vs 794 nodes;
  // T-bar, h = 0.01: 9358-9362 tets, FEM rel L2 spread 1e-5), presumably from CGAL containers
  // ordered by memory address. Exudation removes most slivers, whose near-singular Jacobians
  // stall the FEM's Newton solve. The sliver perturber is off: with it, meshes of the same input
  // differed far more (box test, 425 vs 417 tets).
  CGAL::Random random(config.seed);
  CGAL::get_default_random() = CGAL::Random(config.seed);
  // Cut planes come first; the body's surface bounds the meshed domain.
  Domain domain = cuts.empty() ? Domain(polyhedron, &random)
                               : Domain(cut_pointers.begin(), cut_pointers.end(), polyhedron, &random);
  // The body's edges (a box's, the T-bar's) are protected so its faces stay planar; the creases of
  // a scanned or NeRF-extracted surface are noise, and protecting them shrinks the tetrahedra far
  // below the cell (CGAL shrinks its protecting balls where creases run close): NeRF cuboid, cell
  // 16.7 mm: 129,733 tetrahedra with them, 2,950 without. Its bumps are then followed to within
  // facet_distance like any curved face.
  if (config.protect_creases && !creasesAreNoise(surface, config)) domain.detect_features(config.feature_angle);
  namespace p = CGAL::parameters;
  const Criteria criteria(p::edge_size = cell, p::facet_angle = 25, p::facet_size = cell,
                          p::facet_distance = facet_distance, p::cell_radius_edge_ratio = 3, p::cell_size = cell);
  const Complex c3t3 = CGAL::make_mesh_3<Complex>(domain, criteria, p::no_perturb(), p::exude());

  TetMesh mesh;
  std::unordered_map<Triangulation::Vertex_handle, int> node_of;
  auto position = [](Triangulation::Vertex_handle v) {
    const auto& q = v->point().point();
    return Eigen::Vector3d(CGAL::to_double(q.x()), CGAL::to_double(q.y()), CGAL::to_double(q.z()));
  };
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    std::array<Eigen::Vector3d, 4> corners;
    for (int k = 0; k < 4; ++k) corners[k] = position(c->vertex(k));
    double volume = 0;
    barycentricGradients(corners, &volume);
    // A flat tetrahedron of four coplanar points on a planar face (Delaunay keeps these when the
    // cell is as coarse as the body is thin, e.g. the T-bar at h = 0.03: 1e-21 m^3) holds no
    // volume but has an infinite shape gradient; without it the surface there is its two lower
    // triangles, which lie in the face plane, so dropping it loses nothing.
    if (std::abs(volume) <= 1e-9 * cell * cell * cell) continue;
    std::array<int, 10> e;
    e.fill(-1);
    for (int k = 0; k < 4; ++k) {
      // Nodes are numbered in order of first use, so only vertices of kept cells become nodes.
      const auto [it, added] = node_of.emplace(c->vertex(k), static_cast<int>(mesh.nodes.size()));
      if (added) mesh.nodes.push_back(corners[k]);
      e[k] = it->second;
    }
    if (volume < 0) std::swap(e[1], e[2]);
    mesh.elements.push_back(e);
  }
  if (mesh.elements.empty())
    throw core::Error("tetrahedral mesh: CGAL produced no tetrahedra inside the surface (cell " + std::to_string(cell) +
                      " m); use a smaller cell, or check that the surface encloses a volume");
  return config.order == 2 ? elevateToQuadratic(mesh) : mesh;
}

}  // namespace demnerf::mechanics
