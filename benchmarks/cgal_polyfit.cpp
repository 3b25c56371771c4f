// CGAL PolyFit (Polygonal_surface_reconstruction, GLPK as the solver) for
// bench_polyfit.py.
//
// usage: cgal_polyfit IN.txt OUT.off MAX_PLANES MAX_CANDIDATES [ransac]
//
// IN.txt: one point a line, "x y z nx ny nz plane" (plane: index of the point's
// plane, -1 for none). With "ransac" the plane column is ignored and the planes are
// detected here by CGAL's efficient RANSAC (its default parameters, seed 0).
// OUT.off: the selected candidate faces (polygons) as an OFF file.
// stdout: "planes P" (given or detected), "candidates C" once the candidate faces
// are built, then "seconds S" (the whole reconstruction: detection, candidates and
// the solve).
// Exit status: 0 done, 1 CGAL gave up (its message on stderr), 2 bad usage or input,
// 3 more than MAX_CANDIDATES candidate faces (GLPK stalls on those; not solved),
// 4 more than MAX_PLANES planes (building the candidates alone takes minutes).
#define CGAL_USE_GLPK 1

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/GLPK_mixed_integer_program_traits.h>
#include <CGAL/Polygonal_surface_reconstruction.h>
#include <CGAL/Random.h>
#include <CGAL/Shape_detection/Efficient_RANSAC.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/property_map.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

typedef CGAL::Exact_predicates_inexact_constructions_kernel Kernel;
typedef Kernel::Point_3 Point;
typedef Kernel::Vector_3 Vector;
typedef CGAL::Surface_mesh<Point> Mesh;
typedef CGAL::GLPK_mixed_integer_program_traits<double> Solver;
typedef CGAL::Polygonal_surface_reconstruction<Kernel> PolyFit;

// The points are addressed by their index: the range holds 0..N-1 and the property
// maps read the coordinate, normal and plane vectors at that index.
typedef std::vector<std::size_t> Index_range;
typedef CGAL::Pointer_property_map<Point>::type Point_map;
typedef CGAL::Pointer_property_map<Vector>::type Normal_map;
typedef CGAL::Pointer_property_map<int>::type Plane_map;

typedef CGAL::Shape_detection::Efficient_RANSAC_traits<Kernel, Index_range, Point_map,
                                                       Normal_map>
    Ransac_traits;
typedef CGAL::Shape_detection::Efficient_RANSAC<Ransac_traits> Ransac;
typedef CGAL::Shape_detection::Plane<Ransac_traits> Ransac_plane;

static bool read_points(const char* path, std::vector<Point>& points,
                        std::vector<Vector>& normals, std::vector<int>& planes) {
  std::ifstream in(path);
  if (!in) return false;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::istringstream fields(line);
    double x, y, z, nx, ny, nz;
    int plane;
    if (!(fields >> x >> y >> z >> nx >> ny >> nz >> plane)) return false;
    points.emplace_back(x, y, z);
    normals.emplace_back(nx, ny, nz);
    planes.push_back(plane);
  }
  return !points.empty();
}

// PolyFit expects the plane indices 0..P-1, each used: renumber them in order of
// first appearance (-1 stays -1). Returns P.
static int renumber(std::vector<int>& planes) {
  std::map<int, int> index;
  for (int& p : planes) {
    if (p < 0) {
      p = -1;
      continue;
    }
    auto it = index.emplace(p, static_cast<int>(index.size())).first;
    p = it->second;
  }
  return static_cast<int>(index.size());
}

// CGAL's efficient RANSAC (planes only, default parameters): the plane of every
// point, -1 where none took it.
static void detect_planes(Index_range& range, Point_map point_map, Normal_map normal_map,
                          std::vector<int>& planes) {
  Ransac ransac;
  ransac.set_input(range, point_map, normal_map);
  ransac.add_shape_factory<Ransac_plane>();
  ransac.detect();
  std::fill(planes.begin(), planes.end(), -1);
  int label = 0;
  for (const auto& shape : ransac.shapes()) {
    for (std::size_t i : shape->indices_of_assigned_points()) planes[range[i]] = label;
    ++label;
  }
}

static void write_off(const char* path, const Mesh& mesh) {
  std::ofstream out(path);
  out.precision(17);
  std::map<Mesh::Vertex_index, std::size_t> id;
  for (auto v : mesh.vertices()) id.emplace(v, id.size());
  out << "OFF\n" << id.size() << " " << mesh.number_of_faces() << " 0\n";
  for (auto v : mesh.vertices()) out << mesh.point(v) << "\n";
  for (auto f : mesh.faces()) {
    std::vector<std::size_t> loop;
    for (auto v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) loop.push_back(id[v]);
    out << loop.size();
    for (std::size_t i : loop) out << " " << i;
    out << "\n";
  }
}

int main(int argc, char** argv) {
  if (argc != 5 && !(argc == 6 && std::string(argv[5]) == "ransac")) {
    std::cerr << "usage: cgal_polyfit IN.txt OUT.off MAX_PLANES MAX_CANDIDATES [ransac]\n";
    return 2;
  }
  CGAL::get_default_random() = CGAL::Random(0);  // RANSAC's draws: deterministic
  std::vector<Point> points;
  std::vector<Vector> normals;
  std::vector<int> planes;
  if (!read_points(argv[1], points, normals, planes)) {
    std::cerr << "cannot read " << argv[1] << "\n";
    return 2;
  }
  const int max_planes = std::stoi(argv[3]);
  const std::size_t max_candidates = std::stoul(argv[4]);
  Index_range range(points.size());
  std::iota(range.begin(), range.end(), std::size_t(0));
  Point_map point_map = CGAL::make_property_map(points);
  Normal_map normal_map = CGAL::make_property_map(normals);
  Plane_map plane_map = CGAL::make_property_map(planes);

  auto t0 = std::chrono::steady_clock::now();
  if (argc == 6) detect_planes(range, point_map, normal_map, planes);
  const int n_planes = renumber(planes);
  std::cout << "planes " << n_planes << std::endl;
  if (n_planes > max_planes) {
    std::cerr << "more than " << max_planes << " planes: not solved\n";
    return 4;
  }
  PolyFit polyfit(range, point_map, normal_map, plane_map);
  Mesh candidates;
  polyfit.output_candidate_faces(candidates);
  std::cout << "candidates " << candidates.number_of_faces() << std::endl;
  if (!polyfit.error_message().empty()) {
    std::cerr << polyfit.error_message() << "\n";
    return 1;
  }
  if (candidates.number_of_faces() > max_candidates) {
    std::cerr << "more than " << max_candidates << " candidate faces: not solved\n";
    return 3;
  }
  Mesh mesh;
  // CGAL's default weights: data fitting 0.43, coverage 0.27, complexity 0.3
  if (!polyfit.reconstruct<Solver>(mesh, 0.43, 0.27, 0.3)) {
    std::cerr << polyfit.error_message() << "\n";
    return 1;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_off(argv[2], mesh);
  std::cout << "seconds " << seconds << std::endl;
  return 0;
}
