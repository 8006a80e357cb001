// `demnerf synth`: a synthetic posed-image dataset with ground truth (packages/render).

#include "command.hpp"
#include "demnerf/render/synthetic_scene.hpp"

namespace demnerf::cli {
namespace {

Figures runSynth(const Arguments& arguments) {
  arguments.rejectUnknown({"scene", "views", "test-views", "size", "out", "result", "particles", "samples",
                           "seed", "threads", "json", "quiet"});
  render::SynthConfig config;
  config.scene = arguments.text("scene", config.scene);
  config.views = arguments.integer("views", config.views);
  config.test_views = arguments.integer("test-views", config.test_views);
  config.size = arguments.integer("size", config.size);
  config.out_dir = arguments.text("out");
  config.result_path = arguments.text("result", "");
  config.particles_path = arguments.text("particles", "");
  config.samples_per_axis = arguments.integer("samples", config.samples_per_axis);
  const int seed = arguments.integer("seed", 0);
  if (seed < 0) throw UsageError("option --seed expects a non-negative integer, got " + std::to_string(seed));
  config.seed = static_cast<std::uint64_t>(seed);
  config.threads = arguments.integer("threads", config.threads);

  const render::SynthFigures f = render::generateSyntheticScene(config);
  Figures figures = {{"scene", f.scene},       {"seconds", f.seconds},   {"views", f.views},
                     {"test_views", f.test_views}, {"width", f.width},   {"height", f.height},
                     {"vertices", f.vertices}, {"faces", f.faces},       {"camera_distance", f.camera_distance},
                     {"deformed", f.deformed}, {"out", config.out_dir}};
  if (f.deformed) {
    figures["result_particles"] = f.result_particles;
    figures["max_displacement"] = f.max_displacement;
    figures["particle_spacing"] = f.particle_spacing;
    figures["max_vertex_to_particle"] = f.max_vertex_to_particle;
  }
  return figures;
}

}  // namespace

const Command kSynthCommand = {
    "synth", "synthetic scene with ground truth (tbar, cuboid, cook)",
    "--scene tbar|cuboid|cook --views N --test-views M --size PX --out DIR [--result R.ply] "
    "[--particles P.ply] [--samples 4] [--seed 0] [--threads 0] [--json]",
    runSynth};

}  // namespace demnerf::cli
