#include <gtest/gtest.h>

#include "demnerf/core/error.hpp"
#include "demnerf/core/scenario.hpp"

using namespace demnerf::core;

namespace {

const char* kTwist = R"(
name: twist
material: {model: neo_hookean, youngs_modulus: 5.0e5, poisson_ratio: 0.3, density: 1000}
body_force: [0, 0, -9810]
load_steps: 4
fixtures:
  - name: base
    region: {type: box, center: [0, 0, 0], size: [0.1, 0.1, 0.01]}
    displacement: [0, 0, 0]
  - name: roller
    region: {type: halfspace, center: [0, 0, 0.3], normal: [0, 0, -2]}
    constrained: [false, false, true]
loads:
  - name: right
    region: {type: sphere, center: [0.15, 0.03, 0.27], radius: 0.03}
    force: [0, -5, 0]
    torque: [0, 0, 0.1]
)";

std::string errorOf(const std::string& yaml) {
  try {
    parseScenario(yaml, "s.yaml");
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  text.replace(text.find(from), from.size(), to);
  return text;
}

}  // namespace

TEST(Scenario, ParsesEveryField) {
  const Scenario scenario = parseScenario(kTwist);
  EXPECT_EQ(scenario.name, "twist");
  EXPECT_DOUBLE_EQ(scenario.material.youngs_modulus, 5e5);
  EXPECT_NEAR(scenario.material.mu(), 5e5 / 2.6, 1e-6);
  EXPECT_NEAR(scenario.material.lambda(), 5e5 * 0.3 / (1.3 * 0.4), 1e-6);
  EXPECT_EQ(scenario.load_steps, 4);
  ASSERT_EQ(scenario.fixtures.size(), 2u);
  EXPECT_EQ(scenario.fixtures[1].constrained, Eigen::Vector3i(0, 0, 1));
  EXPECT_TRUE(scenario.fixtures[1].region.normal.isApprox(Eigen::Vector3d(0, 0, -1)));
  ASSERT_EQ(scenario.loads.size(), 1u);
  EXPECT_DOUBLE_EQ(scenario.loads[0].torque.z(), 0.1);
  EXPECT_TRUE(scenario.loads[0].region.contains({0.15, 0.03, 0.29}));
  EXPECT_FALSE(scenario.loads[0].region.contains({0.15, 0.03, 0.31}));
  EXPECT_TRUE(scenario.fixtures[0].region.contains({0.05, -0.05, 0.005}));
  EXPECT_FALSE(scenario.fixtures[0].region.contains({0.05, -0.05, 0.006}));
  EXPECT_TRUE(scenario.fixtures[1].region.contains({0, 0, 0.31}));
}

TEST(Scenario, BadValuesAreNamedWithFileKeyAndValue) {
  EXPECT_NE(errorOf(replace(kTwist, "poisson_ratio: 0.3", "poisson_ratio: 0.5")).find("poisson_ratio"), std::string::npos);
  EXPECT_NE(errorOf(replace(kTwist, "youngs_modulus: 5.0e5", "youngs_modulus: -1")).find("youngs_modulus"), std::string::npos);
  EXPECT_NE(errorOf(replace(kTwist, "model: neo_hookean", "model: mooney")).find("'mooney'"), std::string::npos);
  const std::string nan = errorOf(replace(kTwist, "force: [0, -5, 0]", "force: [0, .nan, 0]"));
  EXPECT_NE(nan.find("loads[0].force[1]"), std::string::npos) << nan;
  EXPECT_NE(nan.find("s.yaml"), std::string::npos) << nan;
  EXPECT_NE(errorOf(replace(kTwist, "type: sphere", "type: cone")).find("'cone'"), std::string::npos);
  EXPECT_NE(errorOf(replace(kTwist, "radius: 0.03", "radius: big")).find("loads[0].region.radius"), std::string::npos);
  EXPECT_NE(errorOf(replace(kTwist, "torque:", "torq:")).find("loads[0].torq"), std::string::npos);
  EXPECT_NE(errorOf("material: {youngs_modulus: 1, poisson_ratio: 0.2}\n").find("no fixtures"), std::string::npos);
  EXPECT_NE(errorOf("material: [1, 2\n").find("not valid YAML"), std::string::npos);
  try {
    loadScenario("/nonexistent/scenario.yaml");
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/scenario.yaml"), std::string::npos);
  }
}

TEST(Scenario, RegionDescriptionsForMessages) {
  Region box;
  box.size = {0.1, 0.1, 0.01};
  EXPECT_EQ(box.describe(), "box center (0,0,0) size (0.1,0.1,0.01)");
}

TEST(Scenario, YamlRoundTripKeepsEveryValue) {
  Scenario a = parseScenario(kTwist);
  a.material.youngs_modulus = 123456.78901234567;  // needs all 17 digits to survive
  const Scenario b = parseScenario(toYaml(a), "round trip");
  EXPECT_EQ(b.name, a.name);
  EXPECT_EQ(b.material.model, a.material.model);
  EXPECT_EQ(b.material.youngs_modulus, a.material.youngs_modulus);
  EXPECT_EQ(b.material.poisson_ratio, a.material.poisson_ratio);
  EXPECT_EQ(b.body_force, a.body_force);
  EXPECT_EQ(b.load_steps, a.load_steps);
  ASSERT_EQ(b.fixtures.size(), a.fixtures.size());
  for (std::size_t i = 0; i < a.fixtures.size(); ++i) {
    EXPECT_EQ(b.fixtures[i].name, a.fixtures[i].name);
    EXPECT_EQ(b.fixtures[i].region.type, a.fixtures[i].region.type);
    EXPECT_EQ(b.fixtures[i].region.center, a.fixtures[i].region.center);
    EXPECT_EQ(b.fixtures[i].region.size, a.fixtures[i].region.size);
    EXPECT_EQ(b.fixtures[i].region.normal, a.fixtures[i].region.normal);
    EXPECT_EQ(b.fixtures[i].constrained, a.fixtures[i].constrained);
    EXPECT_EQ(b.fixtures[i].displacement, a.fixtures[i].displacement);
  }
  ASSERT_EQ(b.loads.size(), 1u);
  EXPECT_EQ(b.loads[0].region.radius, a.loads[0].region.radius);
  EXPECT_EQ(b.loads[0].force, a.loads[0].force);
  EXPECT_EQ(b.loads[0].torque, a.loads[0].torque);
  // A scenario without loads (fixtures and prescribed displacements only) round-trips too.
  a.loads.clear();
  EXPECT_TRUE(parseScenario(toYaml(a)).loads.empty());
}
