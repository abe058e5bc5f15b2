// The map viewer in headless Chromium (software WebGL: ANGLE on SwiftShader) against a running
// pl-server on loopback (bench/viewer.sh starts it):
//   - time to first rendered tiles: from the page's navigation start to the first frame drawn with
//     a tile in it, and to the frame with every tile of the first view; each load in a fresh browser
//     profile (nothing cached) after the browser has started (a navigation to /healthz first);
//   - frames per second with the whole map (MIN_TILES tiles or more) in view, the view turning about
//     its centre, every animation frame rendered.
// Screenshots of the map view (and, when the map has a version 2, the diff of 1 and 2) go to
// --screenshots DIR.
//   bench_viewer URL MAP [--runs 3] [--fps-seconds 10] [--min-tiles 200] [--screenshots DIR]
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "headless_chromium.hpp"

using nlohmann::json;
using pl::test::HeadlessChromium;

namespace {

struct TempDir {
  std::string path;
  TempDir() {
    std::string t = (std::filesystem::temp_directory_path() / "pl-bench-viewer-XXXXXX").string();
    if (!mkdtemp(t.data())) throw std::runtime_error("mkdtemp failed");
    path = t;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

// Loads the viewer at `hash` and waits until it has drawn everything it asked for.
void open_viewer(HeadlessChromium& browser, const std::string& url, const std::string& hash) {
  browser.navigate(url + "/healthz");  // the browser's own start-up, out of the figure
  browser.navigate(url + "/viewer/#" + hash);
  browser.eval(
      "(async () => { for (let i = 0; i < 1200 && !window.plViewer; i++) await new Promise(r => setTimeout(r, 50));"
      " await window.plViewer.idle(); return true; })()",
      600);
  const json errors = browser.eval("plViewer.errors");
  if (!errors.empty()) throw std::runtime_error("the viewer reported: " + errors.dump());
}

void save(HeadlessChromium& browser, const std::string& dir, const std::string& name) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << browser.screenshot_png();
  std::printf("screenshot: %s\n", path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_viewer URL MAP [--runs 3] [--fps-seconds 10] [--min-tiles 200] [--screenshots DIR]\n");
    return 2;
  }
  const std::string url = argv[1], map = argv[2];
  int runs = 3, min_tiles = 200;
  double fps_seconds = 10;
  std::string shots;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--runs") runs = std::max(1, std::atoi(value.c_str()));
    else if (flag == "--fps-seconds") fps_seconds = std::max(1.0, std::atof(value.c_str()));
    else if (flag == "--min-tiles") min_tiles = std::atoi(value.c_str());
    else if (flag == "--screenshots") shots = value;
    else {
      std::fprintf(stderr, "bench_viewer: unknown option %s\n", flag.c_str());
      return 2;
    }
  }
  if (HeadlessChromium::find().empty()) {
    std::printf("bench_viewer: skipped: chromium is not installed (apt-get install chromium)\n");
    return 0;
  }
  try {
    const std::string hash = "map=" + map;  // the whole map in view: the viewer's first view
    std::vector<double> first_tile, first_view;
    json last;
    for (int run = 0; run < runs; ++run) {
      TempDir profile;
      HeadlessChromium browser(profile.path, 1280, 800);
      open_viewer(browser, url, hash);
      last = browser.eval("({first: plViewer.firstTileMs, view: plViewer.firstViewMs, roi: plViewer.roi, decoded: plViewer.tilesDecoded,"
                          " points: plViewer.stats().points, canvas: plViewer.canvasStats(),"
                          " nav: performance.getEntriesByType('navigation')[0].responseEnd})");
      first_tile.push_back(last["first"].get<double>());
      first_view.push_back(last["view"].get<double>());
      std::printf("load %d: first tile drawn %.0f ms, first view (%d tiles, %.2f M points) drawn %.0f ms after navigation start "
                  "(page HTML in at %.0f ms)\n",
                  run + 1, first_tile.back(), last["decoded"].get<int>(), last["points"].get<double>() / 1e6, first_view.back(),
                  last["nav"].get<double>());
      if (run + 1 < runs) continue;

      // The frame rate with the map in view.
      const int in_view = last["roi"]["tiles"][0].get<int>();
      if (last["roi"]["overview"].get<bool>() || in_view < min_tiles)
        throw std::runtime_error("the first view has " + std::to_string(in_view) + " tiles (overview: " + last["roi"]["overview"].dump() +
                                 "), fewer than the " + std::to_string(min_tiles) + " asked for: use a larger map");
      const json fps = browser.eval("plViewer.measureFps(" + std::to_string(fps_seconds) + ")", fps_seconds + 120);
      const json gl = browser.eval(
          "(() => { const gl = document.createElement('canvas').getContext('webgl2');"
          " const d = gl && gl.getExtension('WEBGL_debug_renderer_info');"
          " return d ? gl.getParameter(d.UNMASKED_RENDERER_WEBGL) : 'unknown'; })()");
      std::printf("frames per second with %d tiles (%.2f M points) in view, turning: %.1f (%d frames in %.1f s; %dx%d canvas; %s)\n",
                  in_view, last["points"].get<double>() / 1e6, fps["fps"].get<double>(), fps["frames"].get<int>(),
                  fps["seconds"].get<double>(), last["canvas"]["width"].get<int>(), last["canvas"]["height"].get<int>(),
                  gl.get<std::string>().c_str());
      if (!shots.empty()) {
        save(browser, shots, "viewer-map.png");
        const json versions = browser.eval("fetch('../v1/maps/" + map + "/versions').then(r => r.json())");
        if (versions["versions"].size() >= 2) {
          browser.eval("plViewer.setMode('diff', 1, 2)", 600);
          save(browser, shots, "viewer-diff.png");
          const json d = browser.eval("plViewer.diff");
          std::printf("diff v1 -> v2: %zu tiles added, %zu removed, %zu changed\n", d["added"].size(), d["removed"].size(),
                      d["changed"].size());
        }
      }
    }
    std::printf("time to first rendered tiles (median of %d cold loads): first tile %.0f ms, all %d tiles of the first view %.0f ms\n", runs,
                median(first_tile), last["decoded"].get<int>(), median(first_view));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_viewer: %s\n", e.what());
    return 1;
  }
  return 0;
}
