#pragma once
// Every parameter of nerf_node, with its default; read and checked in one place.

#include <ros/ros.h>

#include <string>
#include <vector>

#include "demnerf/geometry/mesh_from_density.hpp"
#include "demnerf/geometry/particle_sampler.hpp"
#include "demnerf/nerf/config.hpp"
#include "nodes/nerf/frame_intake.hpp"
#include "pipeline/surface_config.hpp"
#include "ros_params/parameter_map.hpp"

namespace dem_nerf {

struct NerfNodeConfig {
  std::vector<std::string> cameras{"camera"};  ///< camera namespaces: <ns>/image_raw + <ns>/camera_info
  std::string world_frame = "world";
  double tf_timeout = 0.5;            ///< s to wait for the camera pose at the image stamp
  double min_translation = 0.02;      ///< m a camera must move before its image is a new keyframe
  double min_rotation = 5.0;          ///< degrees, likewise
  int max_frames = 200;               ///< keyframes kept (oldest dropped beyond)
  int min_frames = 8;                 ///< keyframes needed before training starts
  int max_image_size = 400;           ///< images are downscaled so their longer side fits
  int max_input_pixels = 4096 * 4096; ///< larger camera images are refused before decoding (16.8 Mpx, 268 MB as float RGBA)
  int max_render_pixels = 640 * 480;  ///< ~render refuses larger images (time and memory grow with the pixels)
  std::vector<double> aabb;           ///< xmin ymin zmin xmax ymax zmax; empty: from the cameras
  std::vector<double> background_color;  ///< RGB in [0,1] of a single-colour backdrop; empty: none
  double key_tolerance = 0.1;         ///< colour distance that still counts as backdrop
  double train_seconds = 60.0;        ///< stop training after this long (0: no limit)
  int max_iterations = 0;             ///< stop after this many steps (0: no limit)
  double autosave_seconds = 30.0;     ///< save the model this often while training (0: never)
  std::string model_path;             ///< where the model is saved; resumed from on start if it exists
  // The algorithms' settings, one namespace each (ros_params/nerf_parameters.hpp), the same
  // configs and defaults as the CLI's: ~nerf over the file ~nerf_config, with ~threads (torch
  // threads, 0: all cores) as train.threads; ~extraction as `demnerf extract`; ~sampling as
  // `demnerf sample` (method poisson; spacing 0: 1/40 of the mesh's bounding-box diagonal).
  demnerf::nerf::NerfConfig nerf;
  SurfaceConfig extraction;
  demnerf::geometry::SamplerConfig sampling;

  /// Throws demnerf::core::Error naming the first bad parameter.
  static NerfNodeConfig fromParameters(const ros::NodeHandle& private_node);
  /// The same from parameters held in memory (no master; an empty map gives the defaults).
  static NerfNodeConfig fromParameters(const ParameterMap& parameters);

  /// The frame intake's checks, keyframe selection and colour key these parameters make.
  FrameIntakeConfig intake() const;
};

}  // namespace dem_nerf
