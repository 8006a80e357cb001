// Subcommands whose pipeline stage is not in this build. Each says so plainly and exits 2.
// A stage's real command lives in src/cli/<name>_command.cpp; CMakeLists.txt compiles it and
// defines DEMNERF_HAS_<NAME>_COMMAND once the library it needs is built, which drops the
// placeholder here. (Maintained by the lead; helpers leave this file alone.)

#include "commands.hpp"

namespace demnerf::cli {
namespace {

[[noreturn]] Figures notBuilt(const char* stage) {
  throw NotBuiltYet(std::string("the ") + stage + " stage is not built yet in this version of dem_nerf");
}

}  // namespace

#ifndef DEMNERF_HAS_TRAIN_COMMAND
const Command kTrainCommand = {"train", "train a NeRF on a posed-image dataset",
    "--data DIR --out MODEL [--seconds S | --iterations N] [--config nerf.yaml] [--json]",
    [](const Arguments&) -> Figures { notBuilt("NeRF training"); }};
#endif
#ifndef DEMNERF_HAS_EVAL_COMMAND
const Command kEvalCommand = {"eval", "PSNR and SSIM of a model on a dataset split",
    "--model MODEL --data DIR [--split test] [--json]",
    [](const Arguments&) -> Figures { notBuilt("NeRF evaluation"); }};
#endif
#ifndef DEMNERF_HAS_RENDER_COMMAND
const Command kRenderCommand = {"render", "render a model (optionally deformed) from a split's cameras",
    "--model MODEL --data DIR --split test --out DIR [--result R.ply] [--json]",
    [](const Arguments&) -> Figures { notBuilt("NeRF rendering"); }};
#endif
#ifndef DEMNERF_HAS_EXTRACT_COMMAND
const Command kExtractCommand = {"extract", "surface mesh from a model's density",
    "--model MODEL --mesh OUT.ply [--resolution 256] [--json]",
    [](const Arguments&) -> Figures { notBuilt("geometry extraction"); }};
#endif
#ifndef DEMNERF_HAS_SAMPLE_COMMAND
const Command kSampleCommand = {"sample", "particles inside a closed mesh",
    "--mesh M.ply|M.obj --method random|poisson|grid --spacing H --out P.ply [--json]",
    [](const Arguments&) -> Figures { notBuilt("particle sampling"); }};
#endif
#ifndef DEMNERF_HAS_SIMULATE_COMMAND
const Command kSimulateCommand = {"simulate", "quasi-static deformation of a particle cloud",
    "--particles P.ply --scenario S.yaml --solver dem|pinn|fem [--mesh M] --out R.ply [--json]",
    [](const Arguments&) -> Figures { notBuilt("simulation"); }};
#endif
#ifndef DEMNERF_HAS_PREDICT_COMMAND
const Command kPredictCommand = {"predict", "displacement from a saved DEM model, at any points and load in its range",
    "--model M.dem --out R.ply [--points P.ply] [--load-scale S] [--json]",
    [](const Arguments&) -> Figures { notBuilt("DEM prediction"); }};
#endif
#ifndef DEMNERF_HAS_COMPARE_COMMAND
const Command kCompareCommand = {"compare", "displacement error of a result against a reference",
    "--result R.ply --reference REF.ply [--json]",
    [](const Arguments&) -> Figures { notBuilt("comparison"); }};
#endif
#ifndef DEMNERF_HAS_SYNTH_COMMAND
const Command kSynthCommand = {"synth", "synthetic scene with ground truth (tbar, cuboid, cook)",
    "--scene tbar|cuboid|cook --views N --test-views M --size PX --out DIR [--result R.ply] [--json]",
    [](const Arguments&) -> Figures { notBuilt("synthetic scene"); }};
#endif
#ifndef DEMNERF_HAS_PIPELINE_COMMAND
const Command kPipelineCommand = {"pipeline", "every stage from images to the deformed render",
    "--data DIR --scenario S.yaml --out DIR [--json]",
    [](const Arguments&) -> Figures { notBuilt("whole pipeline"); }};
#endif

}  // namespace demnerf::cli
