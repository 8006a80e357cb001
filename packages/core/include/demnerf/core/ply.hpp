#pragma once
// Binary PLY files for particle clouds, simulation results and triangle meshes (and OBJ meshes).
// The types themselves live in particle_cloud.hpp; include that where no file is read or written.

#include <string>

#include "demnerf/core/particle_cloud.hpp"

namespace demnerf::core {

void writeParticles(const std::string& path, const ParticleCloud& cloud);
ParticleCloud readParticles(const std::string& path);

void writeResult(const std::string& path, const ResultField& result);
ResultField readResult(const std::string& path);

/// Binary PLY with float vertices and int face lists.
void writeMesh(const std::string& path, const TriangleMesh& mesh);
/// Reads .ply (ascii or binary little endian) or .obj (v and f records; polygons are fanned).
TriangleMesh readMesh(const std::string& path);

}  // namespace demnerf::core
