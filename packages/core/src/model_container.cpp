#include "demnerf/core/model_container.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::core {
namespace {

template <typename T>
void append(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <typename T>
T readAt(const std::string& data, std::size_t offset) {
  T value;
  std::memcpy(&value, data.data() + offset, sizeof(T));
  return value;
}

}  // namespace

std::uint64_t fnv1a(const char* data, std::size_t size) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::size_t i = 0; i < size; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ull;
  }
  return h;
}

void writeModelContainer(const std::string& path, const ModelMagic& magic, const ModelContainer& container,
                         const std::string& what) {
  std::string out(magic.data(), magic.size());
  append(out, container.version);
  append(out, static_cast<std::uint64_t>(container.header.size()));
  out += container.header;
  out += container.payload;
  append(out, fnv1a(out.data(), out.size()));

  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream file(tmp, std::ios::binary | std::ios::trunc);
    if (!file) throw Error("cannot write " + what + " file '" + tmp + "' (does the directory exist and is it writable?)");
    file.write(out.data(), static_cast<std::streamsize>(out.size()));
    file.flush();
    if (!file) {
      file.close();
      std::remove(tmp.c_str());
      throw Error("writing " + what + " file '" + tmp + "' failed after " + std::to_string(out.size()) +
                  " bytes were queued (disk full?); '" + path + "' was left unchanged");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(tmp.c_str());
    throw Error("cannot move " + what + " file into place at '" + path + "': " + reason);
  }
}

ModelContainer readModelContainer(const std::string& path, const ModelMagic& magic, std::uint32_t version,
                                  const std::string& what) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error("cannot open " + what + " file '" + path + "'");
  const std::string where = what + " file '" + path + "'";
  // The fixed header first: a file that is not ours (or from another build, or truncated) is
  // refused before a byte of its body is read, however large it is.
  const std::size_t fixed = magic.size() + sizeof(std::uint32_t) + sizeof(std::uint64_t);
  std::string head(fixed, '\0');
  file.read(head.data(), static_cast<std::streamsize>(fixed));
  const std::size_t got = static_cast<std::size_t>(file.gcount());
  if (got < magic.size() || std::memcmp(head.data(), magic.data(), magic.size()) != 0)
    throw Error(where + " is not a dem_nerf " + what + " (wrong magic bytes)");
  if (got < fixed) throw Error(where + " is truncated: " + std::to_string(got) + " bytes, no header");
  ModelContainer container;
  container.version = readAt<std::uint32_t>(head, magic.size());
  if (container.version != version)
    throw Error(where + " has format version " + std::to_string(container.version) + "; this build reads version " +
                std::to_string(version));
  file.clear();
  file.seekg(0, std::ios::end);
  const std::streamoff end = file.tellg();
  if (end < 0) throw Error("cannot size " + where);
  const std::uint64_t size = static_cast<std::uint64_t>(end);
  const auto header_bytes = readAt<std::uint64_t>(head, magic.size() + sizeof(std::uint32_t));
  if (size < fixed + sizeof(std::uint64_t) || header_bytes > size - fixed - sizeof(std::uint64_t))
    throw Error(where + " is truncated: header says " + std::to_string(header_bytes) + " bytes, file has " +
                std::to_string(size));
  std::string data(static_cast<std::size_t>(size), '\0');
  file.seekg(0, std::ios::beg);
  file.read(data.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uint64_t>(file.gcount()) != size) throw Error("reading " + where + " failed part-way");
  const std::size_t body_end = data.size() - sizeof(std::uint64_t);
  if (fnv1a(data.data(), body_end) != readAt<std::uint64_t>(data, body_end))
    throw Error(where + " is corrupt or truncated: checksum mismatch (the file was damaged after it was written)");
  container.header = data.substr(fixed, header_bytes);
  container.payload = data.substr(fixed + header_bytes, body_end - fixed - header_bytes);
  return container;
}

}  // namespace demnerf::core
