// Subcommands whose pipeline stage has not been built yet. Each says so plainly and exits 2.
// When a stage lands, its command moves to its own <name>_command.cpp and leaves this file.

#include "commands.hpp"

namespace demnerf::cli {
namespace {

Figures notBuilt(const char* stage) {
  throw NotBuiltYet(std::string("the ") + stage + " stage is not built yet in this version of dem_nerf");
}

}  // namespace

const Command kTrainCommand = {"train", "train a NeRF on a posed-image dataset",
    "--data DIR --out MODEL [--seconds S | --iterations N] [--config nerf.yaml] [--json]",
    [](const Arguments&) -> Figures { return notBuilt("NeRF training"); }};
const Command kEvalCommand = {"eval", "PSNR and SSIM of a model on a dataset split",
    "--model MODEL --data DIR [--split test] [--json]",
    [](const Arguments&) -> Figures { return notBuilt("NeRF evaluation"); }};
const Command kRenderCommand = {"render", "render a model (optionally deformed) from a split's cameras",
    "--model MODEL --data DIR --split test --out DIR [--result R.ply] [--json]",
    [](const Arguments&) -> Figures { return notBuilt("NeRF rendering"); }};
const Command kExtractCommand = {"extract", "surface mesh from a model's density",
    "--model MODEL --mesh OUT.ply [--resolution 256] [--json]",
    [](const Arguments&) -> Figures { return notBuilt("geometry extraction"); }};
const Command kSampleCommand = {"sample", "particles inside a closed mesh",
    "--mesh M.ply|M.obj --method random|poisson|grid --spacing H --out P.ply [--json]",
    [](const Arguments&) -> Figures { return notBuilt("particle sampling"); }};
const Command kSimulateCommand = {"simulate", "quasi-static deformation of a particle cloud",
    "--particles P.ply --scenario S.yaml --solver dem|pinn|fem [--mesh M] --out R.ply [--json]",
    [](const Arguments&) -> Figures { return notBuilt("simulation"); }};
const Command kCompareCommand = {"compare", "displacement error of a result against a reference",
    "--result R.ply --reference REF.ply [--json]",
    [](const Arguments&) -> Figures { return notBuilt("comparison"); }};
const Command kPipelineCommand = {"pipeline", "every stage from images to the deformed render",
    "--data DIR --scenario S.yaml --out DIR [--json]",
    [](const Arguments&) -> Figures { return notBuilt("whole pipeline"); }};
const Command kSynthCommand = {"synth", "synthetic scene with ground truth (tbar, cuboid, cook)",
    "--scene tbar|cuboid|cook --views N --test-views M --size PX --out DIR [--result R.ply] [--json]",
    [](const Arguments&) -> Figures { return notBuilt("synthetic scene"); }};

}  // namespace demnerf::cli
