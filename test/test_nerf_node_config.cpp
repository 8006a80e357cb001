// nerf_node's parameters without a master (ParameterMap): one namespace per algorithm (~nerf,
// ~extraction, ~sampling), read by the loaders the CLI's files and flags use, with their defaults.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "cli/surface_flags.hpp"
#include "demnerf/core/error.hpp"
#include "nodes/nerf/nerf_node_config.hpp"

using dem_nerf::NerfNodeConfig;
using dem_nerf::ParameterMap;

namespace {

XmlRpc::XmlRpcValue keys(std::initializer_list<std::pair<const char*, XmlRpc::XmlRpcValue>> items) {
  XmlRpc::XmlRpcValue value;
  for (const auto& [key, item] : items) value[key] = item;
  return value;
}

XmlRpc::XmlRpcValue list(std::initializer_list<double> numbers) {
  XmlRpc::XmlRpcValue value;
  int i = 0;
  for (double n : numbers) value[i++] = n;
  return value;
}

std::string refusal(const ParameterMap& parameters) {
  try {
    NerfNodeConfig::fromParameters(parameters);
  } catch (const demnerf::core::Error& e) {
    return e.what();
  }
  return "";
}

void expectSameSurface(const dem_nerf::SurfaceConfig& a, const dem_nerf::SurfaceConfig& b) {
  EXPECT_EQ(a.resolution, b.resolution);
  EXPECT_EQ(a.mesh.surface, b.mesh.surface);
  EXPECT_EQ(a.mesh.opacity, b.mesh.opacity);
  EXPECT_EQ(a.mesh.threshold, b.mesh.threshold);
  EXPECT_EQ(a.mesh.simplification.max_faces, b.mesh.simplification.max_faces);
  EXPECT_EQ(a.mesh.repair.smoothing_iterations, b.mesh.repair.smoothing_iterations);
  EXPECT_EQ(a.isolation.max_second_piece_fraction, b.isolation.max_second_piece_fraction);
  EXPECT_EQ(a.mesh.solid.radius, b.mesh.solid.radius);
  EXPECT_EQ(a.mesh.solid.behind, b.mesh.solid.behind);
  EXPECT_EQ(a.solid_views, b.solid_views);
  ASSERT_EQ(a.box.has_value(), b.box.has_value());
  if (a.box) EXPECT_TRUE(a.box->isApprox(*b.box));
}

}  // namespace

TEST(NerfNodeConfig, DefaultsAreTheCommandLinesDefaults) {
  const NerfNodeConfig config = NerfNodeConfig::fromParameters(ParameterMap{});
  const demnerf::cli::Arguments no_flags({}, {});
  expectSameSurface(config.extraction, demnerf::cli::surfaceFlags(no_flags));
  EXPECT_EQ(config.extraction.resolution, 192);
  EXPECT_EQ(config.extraction.mesh.surface, demnerf::geometry::SurfaceDefinition::kOpacity);
  EXPECT_EQ(config.sampling.method, demnerf::geometry::SamplingMethod::kPoisson);
  EXPECT_EQ(config.sampling.spacing, 0.0);  // 1/40 of the surface's diagonal
  EXPECT_EQ(demnerf::nerf::toJson(config.nerf), demnerf::nerf::toJson(demnerf::nerf::NerfConfig{}));
}

TEST(NerfNodeConfig, ExtractionNamespaceIsDemnerfExtractsFlags) {
  const NerfNodeConfig config = NerfNodeConfig::fromParameters(ParameterMap{
      {"extraction", keys({{"resolution", 128}, {"surface", "density"}, {"threshold", 5},
                           {"box", list({-0.1, -0.2, 0.0, 0.1, 0.2, 0.3})}, {"max_second_piece", 0.3},
                           {"solid_radius", 0.08}, {"solid_behind", list({0.9, -0.4, 0.0})}, {"smoothing", 3}})}});
  const demnerf::cli::Arguments flags({"--resolution", "128", "--threshold", "5", "--box", "-0.1,-0.2,0,0.1,0.2,0.3",
                                       "--max-second-piece", "0.3", "--solid-radius", "0.08", "--solid-behind",
                                       "0.9,-0.4,0", "--smooth", "3"},
                                      {});
  expectSameSurface(config.extraction, demnerf::cli::surfaceFlags(flags));
  ASSERT_TRUE(config.extraction.box.has_value());
  EXPECT_DOUBLE_EQ(config.extraction.box->max().z(), 0.3);
  EXPECT_EQ(config.extraction.mesh.solid.radius, 0.08);
  EXPECT_EQ(config.extraction.mesh.solid.behind, Eigen::Vector3d(0.9, -0.4, 0.0));
  EXPECT_EQ(config.extraction.mesh.repair.smoothing_iterations, 3);
}

TEST(NerfNodeConfig, SolidViewsCarvesWithTheKeyframesLater) {
  const NerfNodeConfig config = NerfNodeConfig::fromParameters(
      ParameterMap{{"extraction", keys({{"solid_radius", 0.16}, {"solid_views", 4}})}});
  EXPECT_EQ(config.extraction.solid_views, 4);
  // The cameras are the keyframes, attached at extraction (withTrainingCameras; test_nerf_node_carving).
  EXPECT_TRUE(config.extraction.mesh.solid.cameras.empty());
  EXPECT_EQ(NerfNodeConfig::fromParameters(ParameterMap{}).extraction.solid_views, 0);  // off, as without --solid-cameras
}

TEST(NerfNodeConfig, SolidViewsNeedsARadiusNoDirectionAndKeptKeyframes) {
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"solid_views", 4}})}})
                .find("~extraction: 'solid_views' needs 'solid_radius' > 0"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"solid_radius", 0.1}, {"solid_views", 4},
                                                      {"solid_behind", list({1, 0, 0})}})}})
                .find("'solid_behind' are alternatives"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"solid_radius", 0.1}, {"solid_views", -1}})}})
                .find("'solid_views' must be an integer in [0,"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"max_frames", 12}, {"extraction", keys({{"solid_radius", 0.1}, {"solid_views", 13}})}})
                .find("~extraction/solid_views (13) must not exceed ~max_frames (12)"),
            std::string::npos);
  // The command line refuses the same pair before it reads any dataset.
  try {
    demnerf::cli::surfaceFlags(demnerf::cli::Arguments({"--solid-cameras", "/no/such/capture", "--solid-views", "4"}, {}));
    ADD_FAILURE() << "--solid-cameras without --solid-radius was accepted";
  } catch (const demnerf::cli::UsageError& error) {
    EXPECT_NE(std::string(error.what()).find("needs --solid-radius R > 0"), std::string::npos) << error.what();
  }
}

TEST(NerfNodeConfig, NerfNamespaceGoesOverTheFileAndSamplingIsItsOwn) {
  const std::string path = ::testing::TempDir() + "nerf_node_" + std::to_string(::getpid()) + ".yaml";
  std::ofstream(path) << "hash: {log2_table_size: 14, levels: 12}\ntrain: {seed: 3}\n";
  const NerfNodeConfig config = NerfNodeConfig::fromParameters(
      ParameterMap{{"nerf_config", path},
                   {"nerf", keys({{"hash", keys({{"levels", 8}})}, {"train", keys({{"loss", "huber"}})}})},
                   {"threads", 1},
                   {"sampling", keys({{"method", "grid"}, {"spacing", 0.006}, {"seed", 9}})}});
  const nlohmann::json nerf = demnerf::nerf::toJson(config.nerf);
  EXPECT_EQ(nerf["hash"]["log2_table_size"], 14);  // file
  EXPECT_EQ(nerf["hash"]["levels"], 8);            // namespace over file
  EXPECT_EQ(nerf["train"]["seed"], 3);
  EXPECT_EQ(nerf["train"]["loss"], "huber");
  EXPECT_EQ(config.nerf.train.threads, 1);  // ~threads
  EXPECT_EQ(config.sampling.method, demnerf::geometry::SamplingMethod::kGrid);
  EXPECT_EQ(config.sampling.spacing, 0.006);
  EXPECT_EQ(config.sampling.seed, 9u);
  std::remove(path.c_str());
}

TEST(NerfNodeConfig, BadNamespacesAndOldNamesAreRefusedByName) {
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"opacity", 1.5}})}}).find("~extraction: 'opacity' must lie in (0, 1)"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"resolutoin", 64}})}}).find("unknown key 'resolutoin'"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"box", list({0, 0, 0, -1, 1, 1})}})}}).find("'box'"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"solid_radius", -0.1}})}}).find("'solid_radius'"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"extraction", keys({{"solid_behind", list({1, 0})}})}}).find("[dx, dy, dz]"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"sampling", keys({{"method", "hex"}})}}).find("random, poisson or grid"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"nerf", keys({{"hash", keys({{"levles", 8}})}})}}).find("hash.levles"),
            std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"sampling", 0.01}}).find("must be a namespace"), std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"surface_opacity", 0.2}}).find("~extraction/opacity"), std::string::npos);
  EXPECT_NE(refusal(ParameterMap{{"particle_spacing", 0.01}}).find("~sampling/spacing"), std::string::npos);
}
