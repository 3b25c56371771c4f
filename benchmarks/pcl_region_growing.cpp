// PCL RegionGrowing (Rabbani et al. 2006) on a raw binary cloud, for bench_vsa.py.
//
// Build (Debian: apt-get install libpcl-dev):
//   g++ -O2 -std=c++17 benchmarks/pcl_region_growing.cpp -o bench-output/pcl_rg \
//       $(pkg-config --cflags --libs pcl_segmentation-1.13 pcl_features-1.13 \
//         pcl_search-1.13 pcl_kdtree-1.13 pcl_common-1.13)
//
// Usage: pcl_rg IN.bin OUT_labels.bin k smoothness_deg curvature_threshold min_cluster mode
//   IN.bin: int64 N, int64 C, then N x C float64 rows (x y z [nx ny nz curvature]);
//   mode "given" uses the normals and curvature of the file (C = 7), "estimate"
//   estimates them with NormalEstimationOMP over k neighbours (C >= 3).
//   OUT_labels.bin: N int32 labels (-1 = not in a kept cluster), then, with
//   mode "given", N x k int32 neighbour indices as PCL's k-d tree returns them.
// Prints one JSON line with the timings (seconds).
#include <pcl/features/normal_3d_omp.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/region_growing.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

static double now() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

int main(int argc, char** argv) {
  if (argc < 8) {
    std::cerr << "usage: pcl_rg IN.bin OUT.bin k smoothness_deg curvature min_cluster mode\n";
    return 2;
  }
  const int k = std::atoi(argv[3]);
  const double smooth = std::atof(argv[4]) * M_PI / 180.0;
  const double curv_thr = std::atof(argv[5]);
  const int min_cluster = std::atoi(argv[6]);
  const std::string mode = argv[7];
  std::ifstream in(argv[1], std::ios::binary);
  int64_t n = 0, c = 0;
  in.read(reinterpret_cast<char*>(&n), 8);
  in.read(reinterpret_cast<char*>(&c), 8);
  std::vector<double> data(static_cast<size_t>(n * c));
  in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(8 * n * c));
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
  cloud->resize(n);
  for (int64_t i = 0; i < n; ++i) {
    (*cloud)[i].x = static_cast<float>(data[i * c + 0]);
    (*cloud)[i].y = static_cast<float>(data[i * c + 1]);
    (*cloud)[i].z = static_cast<float>(data[i * c + 2]);
  }
  pcl::search::Search<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  double t0 = now();
  double t_normals = 0.0;
  if (mode == "given") {
    normals->resize(n);
    for (int64_t i = 0; i < n; ++i) {
      (*normals)[i].normal_x = static_cast<float>(data[i * c + 3]);
      (*normals)[i].normal_y = static_cast<float>(data[i * c + 4]);
      (*normals)[i].normal_z = static_cast<float>(data[i * c + 5]);
      (*normals)[i].curvature = static_cast<float>(data[i * c + 6]);
    }
  } else {
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne;
    ne.setSearchMethod(tree);
    ne.setInputCloud(cloud);
    ne.setKSearch(k);
    ne.compute(*normals);
    t_normals = now() - t0;
  }
  double t1 = now();
  pcl::RegionGrowing<pcl::PointXYZ, pcl::Normal> rg;
  rg.setMinClusterSize(min_cluster);
  rg.setMaxClusterSize(1000000000);
  rg.setSearchMethod(tree);
  rg.setNumberOfNeighbours(k);
  rg.setInputCloud(cloud);
  rg.setInputNormals(normals);
  rg.setSmoothnessThreshold(static_cast<float>(smooth));
  rg.setCurvatureThreshold(static_cast<float>(curv_thr));
  std::vector<pcl::PointIndices> clusters;
  rg.extract(clusters);
  double t_rg = now() - t1;
  std::vector<int32_t> labels(static_cast<size_t>(n), -1);
  for (size_t r = 0; r < clusters.size(); ++r)
    for (auto idx : clusters[r].indices) labels[idx] = static_cast<int32_t>(r);
  std::ofstream out(argv[2], std::ios::binary);
  out.write(reinterpret_cast<const char*>(labels.data()), static_cast<std::streamsize>(4 * n));
  if (mode == "given") {
    std::vector<int> idx;
    std::vector<float> dist;
    std::vector<int32_t> row(k);
    for (int64_t i = 0; i < n; ++i) {
      tree->nearestKSearch(static_cast<int>(i), k, idx, dist);
      for (int j = 0; j < k; ++j) row[j] = j < static_cast<int>(idx.size()) ? idx[j] : -1;
      out.write(reinterpret_cast<const char*>(row.data()), 4 * k);
    }
  }
  std::printf("{\"normals_s\": %.6f, \"region_growing_s\": %.6f, \"n_clusters\": %zu}\n",
              t_normals, t_rg, clusters.size());
  return 0;
}
