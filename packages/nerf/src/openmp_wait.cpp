#include "demnerf/nerf/openmp_wait.hpp"

#include <unistd.h>

#include <cstdlib>

namespace demnerf::nerf {

void reexecWithPassiveOpenMpWait(char** argv, const char* exe) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr || std::getenv("GOMP_SPINCOUNT") != nullptr) return;
  if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
  execv(exe, argv);
  // Only reached when the exec failed: keep the default policy this process was loaded with, and
  // leave no setting behind that would claim otherwise to children.
  unsetenv("OMP_WAIT_POLICY");
}

}  // namespace demnerf::nerf
