#pragma once
// `demnerf synth`: a posed RGBA dataset of a synthetic object (optionally deformed by a
// simulation result), with its exact mesh, as ground truth for every pipeline stage.

#include <cstdint>
#include <string>

#include "demnerf/render/displacement_interpolator.hpp"
#include "demnerf/render/scene_geometry.hpp"
#include "demnerf/render/speckle_texture.hpp"

namespace demnerf::render {

struct SynthConfig {
  std::string scene = "tbar";   ///< tbar | cuboid | cook
  int views = 48;               ///< train views
  int test_views = 8;           ///< held-out views (0: no transforms_test.json)
  int size = 200;               ///< image width and height, pixels
  std::string out_dir;          ///< created if absent
  /// Optional result PLY (rest x y z + ux uy uz per particle): render the body moved by it.
  std::string result_path;
  /// Optional particle PLY the result was computed on: its row count must match the result's.
  std::string particles_path;
  int samples_per_axis = 4;     ///< 4 -> 16 stratified samples per pixel at edges
  std::uint64_t seed = 0;       ///< speckle pattern and sample jitter
  int threads = 0;              ///< 0: all cores
  double fov_degrees = 40.0;    ///< horizontal field of view
  double mesh_edge = 0.0;       ///< longest mesh edge (m); 0 picks the scene's default
  InterpolatorConfig interpolation;
};

/// What generateSyntheticScene did, for the CLI's figures.
struct SynthFigures {
  std::string scene;
  double seconds = 0.0;
  int views = 0;
  int test_views = 0;
  int width = 0;
  int height = 0;
  std::size_t vertices = 0;
  std::size_t faces = 0;
  double camera_distance = 0.0;           ///< m, from the object's centre
  bool deformed = false;
  std::size_t result_particles = 0;
  double max_displacement = 0.0;          ///< m, largest mesh vertex displacement
  double particle_spacing = 0.0;          ///< m, median nearest-neighbour distance of the result
  double max_vertex_to_particle = 0.0;    ///< m, worst distance from a mesh vertex to a particle
};

/// The shader of a scene object: its base colour and a speckle pattern scaled to its size.
SurfaceShader makeSceneShader(const SceneObject& object, std::uint64_t seed);

/// Writes DIR/transforms_train.json, DIR/transforms_test.json (OpenGL poses, shared
/// intrinsics, the object's padded box as "aabb"), DIR/train/r_000.png ..., DIR/test/r_000.png
/// ... (RGBA, transparent background) and DIR/mesh.ply (the surface as rendered). With a result,
/// DIR/rest_mesh.ply holds the undeformed surface too; cameras are the same as without one.
/// Throws core::Error naming the bad value (view count, size, scene, unreadable or mismatched
/// result, a result that does not cover the body).
SynthFigures generateSyntheticScene(const SynthConfig& config);

}  // namespace demnerf::render
