// The exact nearest-neighbour queries of pl-eval map (pl::eval::NearestIndex) against nanoflann's
// k-d tree (KDTreeSingleIndexAdaptor, the baseline) on the same points and the same queries,
// interleaved in one run, one thread:
//   build     the index over the reference cloud
//   nearest   the nearest reference point of every map point (the map's distance to the reference)
//   exclude   a reference point's nearest other point (the reference's spacing)
//   within    whether a map point lies within 0.5 m of each reference point (coverage)
//   radius    the reference points within 2.5 spacings of a point (the surface's plane fit)
// The clouds are generated like a street of the simulator's world: a ground grid and building walls
// sampled every 0.1 m (the reference), and a map of the same surfaces with 2 cm noise, 2 % of its
// points up to 3 m off. Both indexes must give the same answers; the run stops if they do not.
//   bench_nearest [--runs N] [--reference-points N] [--queries N] [--nanoflann-leaf N]
// The benchmark reports; it never fails on a figure.
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <nanoflann.hpp>

#include "bench_util.hpp"
#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/nearest.hpp"

namespace {

// nanoflann's view of the points.
struct Cloud {
  const pl::Points3d& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][static_cast<int>(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, std::uint32_t>;

// Result sets with NearestIndex's semantics: the nearest point other than `exclude`; stop at the first
// point within the radius; every point within the radius (inclusive, unsorted).
struct NearestExcept {
  std::uint32_t exclude;
  double best = std::numeric_limits<double>::infinity();
  std::uint32_t index = 0;
  std::size_t size() const { return best < std::numeric_limits<double>::infinity(); }
  bool full() const { return true; }
  double worstDist() const { return best; }
  bool addPoint(double d, std::uint32_t i) {
    if (i != exclude && d < best) best = d, index = i;
    return true;
  }
};
struct AnyWithin {
  double radius_sq;
  bool found = false;
  std::size_t size() const { return found; }
  bool full() const { return true; }
  double worstDist() const { return std::nextafter(radius_sq, std::numeric_limits<double>::infinity()); }
  bool addPoint(double d, std::uint32_t) {
    found = found || d <= radius_sq;
    return !found;  // false ends the search
  }
};
struct AllWithin {
  double radius_sq;
  std::vector<std::size_t>* out;
  std::size_t size() const { return out->size(); }
  bool full() const { return true; }
  double worstDist() const { return std::nextafter(radius_sq, std::numeric_limits<double>::infinity()); }
  bool addPoint(double d, std::uint32_t i) {
    if (d <= radius_sq) out->push_back(i);
    return true;
  }
};

// A street: ground 0.1 m grid over `side` x 30 m, and a wall on each side, 8 m high.
pl::Points3d street(std::size_t points) {
  const double step = 0.1;
  const double per_metre = (30.0 + 2 * 8.0) / step / step;  // points per metre of street
  const double side = static_cast<double>(points) / per_metre;
  pl::Points3d out;
  for (double x = 0; x < side; x += step) {
    for (double y = -15; y < 15; y += step) out.emplace_back(x, y, 0.02 * std::sin(0.3 * x));
    for (double z = 0; z < 8; z += step) out.emplace_back(x, -15.0, z), out.emplace_back(x, 15.0, z);
  }
  return out;
}

pl::Points3d noisy_copy(const pl::Points3d& ref, std::size_t n, std::mt19937& rng) {
  std::uniform_int_distribution<std::size_t> pick(0, ref.size() - 1);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::uniform_real_distribution<double> far(-3.0, 3.0), u(0.0, 1.0);
  pl::Points3d out;
  for (std::size_t k = 0; k < n; ++k) {
    Eigen::Vector3d p = ref[pick(rng)] + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    if (u(rng) < 0.02) p += Eigen::Vector3d(far(rng), far(rng), far(rng));
    out.push_back(p);
  }
  return out;
}

void report(const char* what, const std::vector<double>& ours, const std::vector<double>& theirs, std::size_t queries) {
  const double a = pl::median(ours), b = pl::median(theirs);
  std::printf("  %-8s ours %8.2f ms  nanoflann %8.2f ms  (%6.0f / %6.0f ns a query)  ours / nanoflann: %.2fx time\n", what, a, b,
              1e6 * a / static_cast<double>(queries), 1e6 * b / static_cast<double>(queries), a / b);
}

void expect(bool same, const char* what) {
  if (!same) throw pl::Error(std::string("the two indexes disagree on ") + what);
}

}  // namespace

int main(int argc, char** argv) {
  pl::cli::Tool tool("bench_nearest", "pl::eval::NearestIndex against nanoflann's k-d tree on pl-eval map's queries");
  int runs = 7;
  std::size_t reference_points = 1000000, queries = 200000, leaf = 10;
  pl::cli::number(tool.app(), "--runs", runs, "interleaved runs of each operation", pl::cli::between(1, 1000));
  pl::cli::number(tool.app(), "--reference-points", reference_points, "points of the reference (about)", pl::cli::at_least(1000));
  pl::cli::number(tool.app(), "--queries", queries, "queries of each kind", pl::cli::at_least(1));
  pl::cli::number(tool.app(), "--nanoflann-leaf", leaf, "nanoflann's leaf size (its default: 10; ours: 12)", pl::cli::at_least(1));
  tool.body([&] {
    std::mt19937 rng(1);
    const pl::Points3d ref = street(reference_points);
    const pl::Points3d map = noisy_copy(ref, queries, rng);
    std::vector<std::uint32_t> members;  // reference points queried for their nearest other point
    std::uniform_int_distribution<std::uint32_t> pick(0, static_cast<std::uint32_t>(ref.size() - 1));
    for (std::size_t k = 0; k < queries; ++k) members.push_back(pick(rng));
    const Cloud cloud{ref};
    std::printf("%zu reference points, %zu queries of each kind, %d interleaved runs, one thread, nanoflann leaves of %zu\n",
                ref.size(), queries, runs, leaf);

    std::vector<double> ours_ms, theirs_ms;
    pl::bench::interleave(runs, [&] { pl::eval::NearestIndex index(ref); }, [&] { Tree tree(3, cloud, {leaf}); }, ours_ms, theirs_ms);
    report("build", ours_ms, theirs_ms, ref.size());
    const pl::eval::NearestIndex index(ref);
    const Tree tree(3, cloud, {leaf});

    // The answers first: the same distances (ties may pick other points), the same hits and sets.
    for (std::size_t k = 0; k < queries; k += 97) {
      NearestExcept n{std::numeric_limits<std::uint32_t>::max()};
      tree.findNeighbors(n, map[k].data(), {});
      expect(std::abs(std::sqrt(n.best) - index.nearest(map[k]).distance) < 1e-12, "nearest");
      NearestExcept e{members[k]};
      tree.findNeighbors(e, ref[members[k]].data(), {});
      expect(std::abs(std::sqrt(e.best) - index.nearest(ref[members[k]], members[k]).distance) < 1e-12, "exclude");
      AnyWithin w{0.25};
      tree.findNeighbors(w, map[k].data(), {});
      expect(w.found == index.any_within(map[k], 0.5), "within");
      std::vector<std::size_t> a, b;
      AllWithin all{0.0625, &b};
      tree.findNeighbors(all, map[k].data(), {});
      index.radius_search(map[k], 0.25, a);
      expect(a.size() == b.size(), "radius");
    }

    double sink = 0;
    std::vector<std::size_t> near;
    const auto timed = [&](const char* what, auto&& ours, auto&& theirs) {
      std::vector<double> a, b;
      pl::bench::interleave(runs, ours, theirs, a, b);
      report(what, a, b, queries);
    };
    timed("nearest", [&] { for (const auto& q : map) sink += index.nearest(q).distance; },
          [&] {
            for (const auto& q : map) {
              NearestExcept n{std::numeric_limits<std::uint32_t>::max()};
              tree.findNeighbors(n, q.data(), {});
              sink += n.best;
            }
          });
    timed("exclude", [&] { for (auto i : members) sink += index.nearest(ref[i], i).distance; },
          [&] {
            for (auto i : members) {
              NearestExcept n{i};
              tree.findNeighbors(n, ref[i].data(), {});
              sink += n.best;
            }
          });
    timed("within", [&] { for (const auto& q : map) sink += index.any_within(q, 0.5); },
          [&] {
            for (const auto& q : map) {
              AnyWithin w{0.25};
              tree.findNeighbors(w, q.data(), {});
              sink += w.found;
            }
          });
    timed("radius", [&] { for (const auto& q : map) near.clear(), index.radius_search(q, 0.25, near), sink += near.size(); },
          [&] {
            for (const auto& q : map) {
              near.clear();
              AllWithin all{0.0625, &near};
              tree.findNeighbors(all, q.data(), {});
              sink += near.size();
            }
          });
    std::printf("  (checksum %.3g)\n", sink);
    return 0;
  });
  return tool.main(argc, argv);
}
