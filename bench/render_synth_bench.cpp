// Times render::generateSyntheticScene for the three scenes (the work of `demnerf synth`) and
// optionally writes a contact sheet of the T-bar's train views.
//
//   render_synth_bench [--scenes tbar,cuboid,cook] [--repeat 3] [--views 48] [--test-views 8]
//                      [--size 200] [--threads 0] [--out /tmp/render_synth_bench]
//                      [--contact-sheet docs/tbar_contact_sheet.png] [--twist-degrees 20]
//
// Prints one line per run and the median per scene; target: under 30 s per scene on 2 cores.
// --twist-degrees also renders the T-bar moved by a torsion-like field given at ~9000 grid
// particles (written to OUT/tbar_twist_result.ply): the `--result` path of `demnerf synth`.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/render/contact_sheet.hpp"
#include "demnerf/render/synthetic_scene.hpp"

namespace {

std::string option(int argc, char** argv, const std::string& name, const std::string& fallback) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (argv[i] == "--" + name) return argv[i + 1];
  }
  return fallback;
}

// Rotation about the vertical axis growing linearly up the leg (as in torsion of a bar fixed at
// z = 0), constant across the horizontal bar, sampled at cell centres of a grid inside the T-bar.
demnerf::core::ResultField tbarTwist(double degrees, double h) {
  demnerf::core::ResultField result;
  for (double x = -0.15 + 0.5 * h; x < 0.15; x += h) {
    for (double y = -0.03 + 0.5 * h; y < 0.03; y += h) {
      for (double z = 0.5 * h; z < 0.30; z += h) {
        if (z < 0.24 && std::abs(x) > 0.03) continue;
        const double angle = degrees * M_PI / 180.0 * std::min(z, 0.24) / 0.24;
        const double c = std::cos(angle), s = std::sin(angle);
        result.positions.emplace_back(x, y, z);
        result.displacements.emplace_back(c * x - s * y - x, s * x + c * y - y, 0.0);
        result.von_mises.push_back(0.0);
      }
    }
  }
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace demnerf;
  try {
    const int repeat = std::max(1, std::stoi(option(argc, argv, "repeat", "3")));
    const double twist = std::stod(option(argc, argv, "twist-degrees", "0"));
    const std::string out = option(argc, argv, "out", "/tmp/render_synth_bench");
    const std::string sheet_path = option(argc, argv, "contact-sheet", "");
    std::vector<std::string> scenes;
    std::stringstream list(option(argc, argv, "scenes", "tbar,cuboid,cook"));
    for (std::string scene; std::getline(list, scene, ',');) scenes.push_back(scene);
    if (twist != 0.0) scenes.push_back("tbar_twisted");
    for (const std::string& scene : scenes) {
      render::SynthConfig config;
      config.scene = scene;
      if (scene == "tbar_twisted") {
        std::filesystem::create_directories(out);
        config.scene = "tbar";
        config.result_path = out + "/tbar_twist_result.ply";
        core::writeResult(config.result_path, tbarTwist(twist, 0.006));
      }
      config.views = std::stoi(option(argc, argv, "views", "48"));
      config.test_views = std::stoi(option(argc, argv, "test-views", "8"));
      config.size = std::stoi(option(argc, argv, "size", "200"));
      config.threads = std::stoi(option(argc, argv, "threads", "0"));
      config.out_dir = out + "/" + scene;
      std::vector<double> seconds;
      render::SynthFigures figures;
      for (int r = 0; r < repeat; ++r) {
        figures = render::generateSyntheticScene(config);
        seconds.push_back(figures.seconds);
        std::printf("%-7s run %d: %.2f s (%d + %d views, %d px, %zu faces)\n", scene.c_str(), r + 1,
                    figures.seconds, figures.views, figures.test_views, figures.width, figures.faces);
      }
      std::sort(seconds.begin(), seconds.end());
      std::printf("%-7s median %.2f s over %d runs, %.3f s per view\n", scene.c_str(), seconds[seconds.size() / 2],
                  repeat, seconds[seconds.size() / 2] / (figures.views + figures.test_views));
      if (figures.deformed) {
        std::printf("%-7s deformed by %zu particles: max displacement %.1f mm, worst vertex-particle distance "
                    "%.1f mm (spacing %.1f mm)\n", scene.c_str(), figures.result_particles,
                    figures.max_displacement * 1e3, figures.max_vertex_to_particle * 1e3,
                    figures.particle_spacing * 1e3);
      }
      if (scene.rfind("tbar", 0) == 0 && !sheet_path.empty()) {
        const core::Dataset dataset = core::loadDataset(config.out_dir);
        std::vector<cv::Mat> images;
        for (const auto& frame : dataset.train) images.push_back(frame.rgba);
        const std::string path = scene == "tbar" ? sheet_path
            : sheet_path.substr(0, sheet_path.rfind('.')) + "_" + scene.substr(5) + ".png";
        core::writeImagePng(path, render::makeContactSheet(images, 8));
        std::printf("contact sheet of %zu train views: %s\n", images.size(), path.c_str());
      }
    }
  } catch (const std::exception& error) {
    std::cerr << "render_synth_bench: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
