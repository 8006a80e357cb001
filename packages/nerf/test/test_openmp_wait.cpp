// reexecWithPassiveOpenMpWait, run for real in a forked child: /bin/sh stands in for the
// re-executed program and writes the wait policy it was started with.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "demnerf/nerf/openmp_wait.hpp"

namespace {

/// What the child reports: "exec:<policy>" from the shell it was replaced with, or
/// "returned:<policy>" when the call came back. `preset` is the child's OMP_WAIT_POLICY (nullptr:
/// none), `exe` the program to re-execute.
std::string childReport(const char* preset, const char* exe) {
  const std::string out = ::testing::TempDir() + "openmp_wait_" + std::to_string(getpid()) + ".txt";
  std::remove(out.c_str());
  const std::string script = "printf '%s' \"exec:$OMP_WAIT_POLICY\" > '" + out + "'";
  char sh[] = "sh", flag[] = "-c";
  char* argv[] = {sh, flag, const_cast<char*>(script.c_str()), nullptr};
  const pid_t pid = fork();
  if (pid == 0) {
    unsetenv("GOMP_SPINCOUNT");
    if (preset) setenv("OMP_WAIT_POLICY", preset, 1);
    else unsetenv("OMP_WAIT_POLICY");
    demnerf::nerf::reexecWithPassiveOpenMpWait(argv, exe);
    const char* now = std::getenv("OMP_WAIT_POLICY");
    const std::string report = std::string("returned:") + (now ? now : "");
    const int fd = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const bool written = fd >= 0 && write(fd, report.data(), report.size()) == static_cast<ssize_t>(report.size());
    _exit(written ? 0 : 3);
  }
  int status = 0;
  EXPECT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child status " << status;
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  std::remove(out.c_str());
  return text.str();
}

TEST(OpenMpWait, ReexecutesWithPassiveWaitWhenNoPolicyIsSet) {
  EXPECT_EQ(childReport(nullptr, "/bin/sh"), "exec:passive");
}

TEST(OpenMpWait, KeepsThePolicyTheCallerSet) {
  EXPECT_EQ(childReport("active", "/bin/sh"), "returned:active");
}

TEST(OpenMpWait, GoesOnWithTheLoadedPolicyWhenTheExecFails) {
  // No setting is left behind: the process keeps spinning, and its children should too.
  EXPECT_EQ(childReport(nullptr, "/nonexistent/demnerf"), "returned:");
}

}  // namespace
