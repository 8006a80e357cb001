#pragma once
// The file layout every saved model shares (NeRF fields, DEM networks): 8 magic bytes, a format
// version, a JSON header, a binary payload and a checksum. Written next to the target and renamed
// into place, so a crash or a full disk never leaves a torn file; read back with every damage
// (wrong kind of file, truncation, flipped bits) reported as a core::Error that says which.

#include <array>
#include <cstdint>
#include <string>

namespace demnerf::core {

using ModelMagic = std::array<char, 8>;

struct ModelContainer {
  std::uint32_t version = 0;
  std::string header;   ///< JSON text
  std::string payload;  ///< raw bytes described by the header
};

/// FNV-1a, 64 bit: detects damage, not tampering.
std::uint64_t fnv1a(const char* data, std::size_t size);

/// `what` names the file in errors ("NeRF model", "DEM model").
void writeModelContainer(const std::string& path, const ModelMagic& magic, const ModelContainer& container,
                         const std::string& what);

/// Checks magic, version (before the checksum: a file from another build is not damaged, and
/// says so), sizes and checksum; the caller checks the payload's layout.
ModelContainer readModelContainer(const std::string& path, const ModelMagic& magic, std::uint32_t version,
                                  const std::string& what);

}  // namespace demnerf::core
