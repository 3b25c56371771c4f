// CGAL Surface_mesh_approximation (VSA on a triangle mesh) for bench_simplify.py.
// usage: cgal_vsa IN.off OUT.off N_PROXIES   -> prints the seconds of the approximation
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_approximation/approximate_triangle_mesh.h>
#include <CGAL/boost/graph/IO/polygon_mesh_io.h>

#include <array>
#include <chrono>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

namespace VSA = CGAL::Surface_mesh_approximation;
typedef CGAL::Exact_predicates_inexact_constructions_kernel Kernel;
typedef Kernel::Point_3 Point_3;
typedef CGAL::Surface_mesh<Point_3> Mesh;

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: cgal_vsa IN.off OUT.off N_PROXIES\n";
    return 2;
  }
  Mesh mesh;
  if (!CGAL::IO::read_polygon_mesh(argv[1], mesh)) {
    std::cerr << "cannot read " << argv[1] << "\n";
    return 1;
  }
  const std::size_t n = std::stoul(argv[3]);
  std::vector<Point_3> anchors;
  std::vector<std::array<std::size_t, 3>> triangles;
  auto t0 = std::chrono::steady_clock::now();
  bool is_manifold = VSA::approximate_triangle_mesh(
      mesh, CGAL::parameters::verbose_level(VSA::SILENT)
                .max_number_of_proxies(n)
                .number_of_iterations(30)
                .anchors(std::back_inserter(anchors))
                .triangles(std::back_inserter(triangles)));
  double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ofstream out(argv[2]);
  out.precision(17);
  out << "OFF\n" << anchors.size() << " " << triangles.size() << " 0\n";
  for (const auto& p : anchors) out << p << "\n";
  for (const auto& t : triangles) out << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
  std::cout << seconds << " " << (is_manifold ? 1 : 0) << "\n";
  return 0;
}
