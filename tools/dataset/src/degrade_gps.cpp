#include "pl/dataset/degrade_gps.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"

namespace pl::dataset {

namespace {

// Standard normal deviates from a 64-bit Mersenne Twister by the Box-Muller transform: the same
// numbers on every platform for a seed (std::normal_distribution is implementation-defined).
class Gaussian {
 public:
  explicit Gaussian(std::uint64_t seed) : rng_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - static_cast<double>(rng_() >> 11) * 0x1.0p-53;  // (0, 1]
    const double u2 = static_cast<double>(rng_() >> 11) * 0x1.0p-53;        // [0, 1)
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  std::mt19937_64 rng_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

// Makes `out` an empty folder for degrade-gps: it may not exist yet, be empty, or hold an earlier
// output (marked by kMarker; only symlinks, the marker and gps.csv), which is cleared. It must not be
// the source or inside it.
const char* kMarker = ".pl-degrade-gps";
void prepare_output_folder(const std::string& source, const std::string& out) {
  namespace fs = std::filesystem;
  const fs::path src = fs::canonical(source);
  const fs::path dst = fs::weakly_canonical(out);
  auto [s_end, d_it] = std::mismatch(src.begin(), src.end(), dst.begin(), dst.end());
  if (s_end == src.end())
    throw Error("--out " + out + " is " + (d_it == dst.end() ? "the source folder itself" : "inside the source folder " + source) +
                    "; choose a folder outside it, e.g. " + (src.parent_path() / (src.filename().string() + "-consumer")).string());
  if (!fs::exists(fs::symlink_status(out))) {
    fs::create_directories(out);
    return;
  }
  if (!fs::is_directory(fs::symlink_status(out)))
    throw Error("--out " + out + " exists and is not a folder; remove it or choose another path");
  std::vector<fs::path> entries;
  for (const auto& e : fs::directory_iterator(out)) entries.push_back(e.path());
  if (entries.empty()) return;
  // Only a folder this command made is cleared: it carries the marker, and nothing but symlinks,
  // the marker and gps.csv.
  if (!fs::is_regular_file(fs::symlink_status(fs::path(out) / kMarker)))
    throw Error("--out " + out + " is not empty and is not an earlier degrade-gps output (no " + kMarker +
                    " in it); nothing was changed: remove the folder yourself or choose another one");
  for (const auto& e : entries) {
    const std::string name = e.filename().string();
    const bool ours = fs::is_symlink(fs::symlink_status(e)) || name == kMarker || (name == "gps.csv" && fs::is_regular_file(e));
    if (!ours)
      throw Error("--out " + out + " holds " + name + ", which degrade-gps does not write; nothing was changed: remove the "
                      "folder yourself or choose another one");
  }
  for (const auto& e : entries) fs::remove(e);
}

}  // namespace

DegradeGpsReport degrade_gps(const Dataset& ds, const std::string& out, const DegradeGpsConfig& cfg) {
  namespace fs = std::filesystem;
  const double rate = cfg.rate_hz, sigma = cfg.sigma_m;
  const unsigned long long seed = cfg.seed;
  if (!(rate > 0.0) || !std::isfinite(rate)) throw Error("--rate takes fixes per second above 0, e.g. --rate 1");
  if (!(sigma >= 0.0) || !std::isfinite(sigma)) throw Error("--sigma takes metres (>= 0), e.g. --sigma 1.5");
  std::vector<GpsFix> source;
  for (const auto& f : ds.gps)
    if (f.status != kGpsNone) source.push_back(f);
  if (source.empty())
    throw Error(ds.dir + ": no GPS fixes with a position to degrade (a raw drive's oxts/ or a gps.csv with status 1-4)");
  // The source rate from its span, so that --rate cannot ask for more fixes than there are.
  const double span = source.back().t - source.front().t;
  if (source.size() > 1 && span > 0.0) {
    const double source_rate = static_cast<double>(source.size() - 1) / span;
    if (rate > source_rate * 1.05) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "--rate %g Hz is above the rate of the source GPS (%.2f Hz, %zu fixes over %.1f s)",
                    rate, source_rate, source.size(), span);
      throw Error(ds.dir + ": " + buf + "; pick --rate at most that");
    }
  }

  // Thinning: the first fix at or after each multiple of 1/rate since the first fix.
  std::vector<GpsFix> kept;
  long long last_slot = -1;
  for (const auto& f : source) {
    const auto slot = static_cast<long long>(std::floor((f.t - source.front().t) * rate + 1e-6));
    if (slot <= last_slot) continue;
    last_slot = slot;
    kept.push_back(f);
  }

  // Noise in the local East-North-Up frame of each fix.
  Gaussian normal(cfg.seed);
  std::vector<GpsFix> noisy;
  std::vector<double> de, dn, du, dh;
  for (const auto& f : kept) {
    const EnuFrame enu(f.position);
    // Drawn in a fixed order (constructor arguments are evaluated in an unspecified order).
    const double east = normal(), north = normal(), up = normal();
    const Eigen::Vector3d offset(sigma * east, sigma * north, 1.5 * sigma * up);
    noisy.push_back({f.t, enu.to_geodetic(offset), sigma, kGpsSingle});
  }

  prepare_output_folder(ds.dir, out);
  const fs::path src = fs::canonical(ds.dir);
  std::size_t links = 0;
  for (const auto& e : fs::directory_iterator(src)) {
    if (e.path().filename() == "gps.csv") continue;  // replaced below
    fs::create_symlink(fs::canonical(e.path()), fs::path(out) / e.path().filename());
    ++links;
  }
  {
    std::FILE* marker = std::fopen((fs::path(out) / kMarker).c_str(), "w");
    if (!marker) throw Error(out + ": cannot write " + kMarker);
    std::fprintf(marker, "made by pl-dataset degrade-gps from %s; pl-dataset degrade-gps may replace this folder\n", src.string().c_str());
    std::fclose(marker);
  }
  const std::string csv_path = (fs::path(out) / "gps.csv").string();
  std::FILE* csv = std::fopen(csv_path.c_str(), "w");
  if (!csv) throw Error(csv_path + ": cannot write");
  std::fprintf(csv, "# consumer-grade GPS made by pl-dataset degrade-gps from %s: %zu of %zu fixes (%g Hz), noise sigma %g m "
                    "east and north, %g m up, seed %llu\n",
               src.string().c_str(), noisy.size(), source.size(), rate, sigma, 1.5 * sigma, seed);
  std::fprintf(csv, "t,lat,lon,alt,std_m,status\n");
  for (const auto& f : noisy)
    std::fprintf(csv, "%.6f,%.10f,%.10f,%.4f,%.3f,%d\n", f.t, f.position.lat_deg, f.position.lon_deg, f.position.alt_m,
                 f.std_m, f.status);
  if (std::fclose(csv) != 0) throw Error(csv_path + ": write failed (disk full?)");

  // Read the new drive back and measure its fixes against the source's, as written (rounded).
  const Dataset check = open_dataset(out);
  if (check.gps.size() != kept.size()) throw Error(csv_path + ": read back " + std::to_string(check.gps.size()) + " fixes, wrote " + std::to_string(kept.size()));
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const Eigen::Vector3d d = EnuFrame(kept[i].position).to_enu(check.gps[i].position);
    de.push_back(d.x());
    dn.push_back(d.y());
    du.push_back(d.z());
    dh.push_back(d.head<2>().norm());
  }
  DegradeGpsReport r;
  r.scans = check.size();
  r.links = links;
  r.fixes = noisy.size();
  r.source_fixes = source.size();
  r.span_s = span;
  r.rms_east_m = rms(de);
  r.rms_north_m = rms(dn);
  r.rms_up_m = rms(du);
  for (double h : dh) r.mean_horizontal_m += h / static_cast<double>(dh.size());
  r.max_horizontal_m = dh.empty() ? 0.0 : *std::max_element(dh.begin(), dh.end());
  return r;
}

std::string degrade_gps_text(const DegradeGpsReport& r, const std::string& source, const std::string& out, const DegradeGpsConfig& cfg) {
  char buf[1024];
  std::snprintf(buf, sizeof buf, "wrote %s: %zu scans through %zu symlinks to %s, and gps.csv\n", out.c_str(), r.scans, r.links,
                std::filesystem::canonical(source).string().c_str());
  std::string text = buf;
  std::snprintf(buf, sizeof buf, "gps.csv        %zu fixes at %g Hz (of %zu source fixes over %.1f s), status single, std_m %.3f, seed %llu\n",
                r.fixes, cfg.rate_hz, r.source_fixes, r.span_s, cfg.sigma_m, static_cast<unsigned long long>(cfg.seed));
  text += buf;
  std::snprintf(buf, sizeof buf, "noise added    rms east %.3f m, north %.3f m, up %.3f m; horizontal mean %.3f m, max %.3f m\n",
                r.rms_east_m, r.rms_north_m, r.rms_up_m, r.mean_horizontal_m, r.max_horizontal_m);
  return text + buf;
}

}  // namespace pl::dataset
