// The reference's on-disk cache: one file per key, written atomically, checked on load.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/reference/reference.hpp>
#include <system_error>

#include "hash.hpp"

namespace penumbra::reference {
namespace fs = std::filesystem;
namespace {

constexpr char kMagic[8] = {'P', 'N', 'B', 'R', 'R', 'E', 'F', '1'};
// Bump when the tracer's results change for the same inputs (sampling, offsets, masks).
constexpr uint32_t kVersion = 3;  // 2: the terminator model, the vertex normals in the geometry hash; 3: receivers on the surface along their view ray

std::string hex(uint64_t key) {
  char b[17];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(key));
  return b;
}

fs::path file_for(const fs::path& dir, uint64_t key) {
  return dir / (hex(key) + ".pnref");
}

}  // namespace

uint64_t cache_key(const Tracer& tracer, const Receivers& receivers, const AreaLight& light,
                   const TraceOptions& options) {
  detail::Hasher h;
  h.pod(kVersion);
  h.pod(tracer.geometry_hash());
  h.pod(receivers.width);
  h.pod(receivers.height);
  h.pod(receivers.origin);
  h.bytes(receivers.position.data(), receivers.position.size() * sizeof(glm::dvec3));
  h.bytes(receivers.normal.data(), receivers.normal.size() * sizeof(glm::dvec3));
  h.bytes(receivers.valid.data(), receivers.valid.size());
  h.pod(receivers.eye.has_value());
  if (receivers.eye) h.pod(*receivers.eye);
  h.bytes(receivers.depth_tolerance.data(), receivers.depth_tolerance.size() * sizeof(float));
  h.pod(int(light.kind));
  h.pod(light.direction_to_light);
  h.pod(light.angular_radius);
  h.pod(light.position);
  h.pod(light.radius);
  h.pod(options.samples);
  h.pod(options.initial_samples);
  h.pod(options.adaptive);
  h.pod(options.seed);
  h.pod(int(options.terminator));
  if (options.shared_pattern) h.pod(options.shared_pattern);  // older keys stay valid
  return h.h;
}

fs::path default_cache_dir() {
  if (const char* d = std::getenv("PENUMBRA_REFERENCE_CACHE"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d)
    return fs::path(d) / "penumbra" / "reference";
  if (const char* d = std::getenv("HOME"); d && *d)
    return fs::path(d) / ".cache" / "penumbra" / "reference";
  return fs::temp_directory_path() / "penumbra-reference";
}

std::optional<Visibility> cache_load(const fs::path& dir, uint64_t key, size_t count) {
  std::ifstream in(file_for(dir, key), std::ios::binary);
  if (!in) return std::nullopt;
  char magic[8];
  uint32_t version = 0;
  uint64_t stored_key = 0, stored_count = 0, rays = 0;
  in.read(magic, 8);
  in.read(reinterpret_cast<char*>(&version), sizeof version);
  in.read(reinterpret_cast<char*>(&stored_key), sizeof stored_key);
  in.read(reinterpret_cast<char*>(&stored_count), sizeof stored_count);
  in.read(reinterpret_cast<char*>(&rays), sizeof rays);
  if (!in || std::memcmp(magic, kMagic, 8) != 0 || version != kVersion || stored_key != key ||
      stored_count != count)
    return std::nullopt;
  Visibility v;
  v.value.resize(count);
  v.std_error.resize(count);
  v.samples.resize(count);
  in.read(reinterpret_cast<char*>(v.value.data()), std::streamsize(count * sizeof(float)));
  in.read(reinterpret_cast<char*>(v.std_error.data()), std::streamsize(count * sizeof(float)));
  in.read(reinterpret_cast<char*>(v.samples.data()), std::streamsize(count * sizeof(uint32_t)));
  if (!in) return std::nullopt;
  v.rays = rays;
  v.from_cache = true;
  return v;
}

void cache_store(const fs::path& dir, uint64_t key, const Visibility& v) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("reference cache: cannot create " + dir.string() + ": " + ec.message());
  const fs::path target = file_for(dir, key);
  const uint64_t count = v.value.size(), rays = v.rays;
  std::string bytes;
  const auto put = [&](const void* data, size_t size) {
    bytes.append(static_cast<const char*>(data), size);
  };
  put(kMagic, 8);
  put(&kVersion, sizeof kVersion);
  put(&key, sizeof key);
  put(&count, sizeof count);
  put(&rays, sizeof rays);
  put(v.value.data(), count * sizeof(float));
  put(v.std_error.data(), count * sizeof(float));
  put(v.samples.data(), count * sizeof(uint32_t));
  try {
    write_file_atomic(target, bytes);
  } catch (const Error& e) {
    throw Error(std::string("reference cache: ") + e.what());
  }
}

Visibility trace_cached(const Tracer& tracer, const Receivers& receivers, const AreaLight& light,
                        const TraceOptions& options, const fs::path& cache_dir) {
  const uint64_t key = cache_key(tracer, receivers, light, options);
  if (auto hit = cache_load(cache_dir, key, receivers.size())) return std::move(*hit);
  Visibility v = tracer.trace(receivers, light, options);
  cache_store(cache_dir, key, v);
  return v;
}

}  // namespace penumbra::reference
