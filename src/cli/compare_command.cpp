// `demnerf compare`: relative L2 and largest displacement error of a result against a reference
// computed on the same particles (packages/mechanics).

#include "command.hpp"
#include "commands.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/compare_results.hpp"

namespace demnerf::cli {
namespace {

Figures runCompare(const Arguments& arguments) {
  arguments.rejectUnknown({"result", "reference", "json", "quiet"});
  const core::ResultField result = core::readResult(arguments.text("result"));
  const core::ResultField reference = core::readResult(arguments.text("reference"));
  const mechanics::ResultComparison c = mechanics::compareResults(result, reference);
  return Figures{{"rel_l2", c.rel_l2},
                 {"max_error", c.max_error},
                 {"rows", c.rows},
                 {"max_position_gap", c.max_position_gap}};
}

}  // namespace

const Command kCompareCommand = {"compare", "displacement error of a result against a reference",
                                 "--result R.ply --reference REF.ply [--json]", runCompare};

}  // namespace demnerf::cli
