#pragma once

// The shader-function harness: any GLSL function becomes a batched compute test.
//
//   using penumbra::testing::ShaderFunction;
//   ShaderFunction<float(float, glm::vec2)> f("penumbra/noise.glsl", "interleaved_gradient_noise");
//   std::vector<std::tuple<float, glm::vec2>> cases = ...;
//   std::vector<float> results = f.run(cases);          // one dispatch, one invocation per case
//
// The harness generates a compute wrapper (std430 input/output buffers, bounds check), compiles it
// once per process, checks the host layouts against SPIR-V reflection, and runs on the process's
// shared Vulkan device (testing::shared_context(), validation on). `out` and `inout` parameters
// are declared with Out<T> / InOut<T> and come back in the result; resources (textures with their
// samplers) are parameters of marker types (Sampler2DShadow, ...) bound once per batch.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <penumbra/core/error.hpp>
#include <penumbra/gpu/resources.hpp>
#include <penumbra/shader/compiler.hpp>
#include <penumbra/testing/compare.hpp>
#include <penumbra/testing/glsl_types.hpp>
#include <source_location>
#include <span>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace penumbra::gpu {
class Context;
}

namespace penumbra::testing {

// Parameter direction markers.
template <class T>
struct Out {
  using type = T;
};
template <class T>
struct InOut {
  using type = T;
};

enum class ResourceKind {
  sampler2d_shadow,
  sampler2d_array_shadow,
  sampler_cube_shadow,
  sampler2d,
  sampler2d_array,
  sampler_cube_array_shadow,
  sampler_cube_array,
  sampler_cube,
  image2d,  // a storage image (make_storage_image), read and written in place
  image2d_array
};
const char* glsl_name(ResourceKind kind);

// Resource parameter markers: the GLSL function takes the opaque type as an argument.
struct Sampler2DShadow {
  static constexpr ResourceKind kind = ResourceKind::sampler2d_shadow;
};
struct Sampler2DArrayShadow {
  static constexpr ResourceKind kind = ResourceKind::sampler2d_array_shadow;
};
struct SamplerCubeShadow {
  static constexpr ResourceKind kind = ResourceKind::sampler_cube_shadow;
};
struct SamplerCubeArrayShadow {
  static constexpr ResourceKind kind = ResourceKind::sampler_cube_array_shadow;
};
struct SamplerCubeArray {  // raw depths (a non-compare sampler on a depth cube array)
  static constexpr ResourceKind kind = ResourceKind::sampler_cube_array;
};
struct SamplerCube {  // a float cube (make_float_texture with cube), or raw depths of a cube
  static constexpr ResourceKind kind = ResourceKind::sampler_cube;
};
struct Sampler2D {
  static constexpr ResourceKind kind = ResourceKind::sampler2d;
};
struct Sampler2DArray {
  static constexpr ResourceKind kind = ResourceKind::sampler2d_array;
};

// Storage images: the GLSL function takes `image2D` / `image2DArray` (GLSL allows no format
// qualifier on a parameter, so the wrapper declares them format-less). A function that only
// writes runs on every device; one that reads (imageLoad) needs the device's
// shaderStorageImageReadWithoutFormat, and building it elsewhere fails naming that feature.
struct Image2D {
  static constexpr ResourceKind kind = ResourceKind::image2d;
};
struct Image2DArray {
  static constexpr ResourceKind kind = ResourceKind::image2d_array;
};

// An image with its sampler, bound to a resource parameter. A storage image (storage = true)
// has no sampler and stays in VK_IMAGE_LAYOUT_GENERAL.
struct Texture {
  gpu::Image image;
  gpu::Sampler sampler;
  bool depth = false;
  bool storage = false;
};

// A sampler the caller owns and keeps alive (a product's own VkSampler, created on
// testing::shared_context().device()), bound in place of a texture's own sampler. Vulkan cannot
// be asked how a sampler was made, so `compare` says whether it was created with compareEnable:
// the *Shadow kinds need one that compares, the others one that does not.
struct ExternalSampler {
  VkSampler handle = VK_NULL_HANDLE;
  bool compare = false;
};

// What the i-th resource parameter is bound to.
struct ResourceBinding {
  std::shared_ptr<Texture> texture;
  ExternalSampler sampler;  // VK_NULL_HANDLE: the texture's own
};

// A depth texture (layers == 1: 2D; > 1 or array = true: 2D array; cube = true: 6 faces; cube
// with layers > 1 or array = true: a cube array of `layers` cubes, 6 faces each, layer 6 c + f
// is face f of cube c) filled from `depth` (layer-major, row-major), sampled through `sampler`
// (compare samplers for the *Shadow kinds). Default: compare LESS_OR_EQUAL, nearest, clamp to
// edge. format: D32_SFLOAT (the default), D16_UNORM or X8_D24_UNORM_PACK32; for the unorm
// formats each depth is clamped to [0, 1] and rounded to the nearest of 2^16 - 1 (2^24 - 1)
// steps, as a depth attachment would store it.
struct DepthTextureDesc {
  uint32_t width = 1, height = 1, layers = 1;
  VkFormat format = VK_FORMAT_D32_SFLOAT;
  bool array = false;
  bool cube = false;
  gpu::SamplerDesc sampler{VK_FILTER_NEAREST,
                           VK_SAMPLER_MIPMAP_MODE_NEAREST,
                           VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                           VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE,
                           true,
                           VK_COMPARE_OP_LESS_OR_EQUAL,
                           false};
};
std::shared_ptr<Texture> make_depth_texture(const DepthTextureDesc& desc,
                                            std::span<const float> depth);

// A float texture with 1, 2 or 4 channels: R32 / RG32 / RGBA32 SFLOAT, or with half = true
// R16 / RG16 / RGBA16 SFLOAT (each texel rounded to the nearest half, as the GPU stores it).
// layers == 1: 2D; > 1 or array = true: 2D array; cube = true: `layers` cubes of 6 faces
// (layer 6 c + f is face f of cube c), a cube array when layers > 1 or array = true.
struct FloatTextureDesc {
  uint32_t width = 1, height = 1, layers = 1, channels = 1;
  bool array = false;
  bool cube = false;
  bool half = false;
  gpu::SamplerDesc sampler{};
};
std::shared_ptr<Texture> make_float_texture(const FloatTextureDesc& desc,
                                            std::span<const float> texels);

// A storage image for Image2D (layers == 1 and !array) or Image2DArray parameters: R / RG / RGBA
// in 32-bit float, or 16-bit with half = true. `texels` (layer-major, row-major, `channels` per
// texel) is the initial content; empty means zeros. A run writes into it in place; read it back
// with read_storage_image. Needs the format's STORAGE_IMAGE feature (rg formats:
// shaderStorageImageExtendedFormats).
struct StorageImageDesc {
  uint32_t width = 1, height = 1, layers = 1, channels = 4;
  bool array = false;
  bool half = false;
};
std::shared_ptr<Texture> make_storage_image(const StorageImageDesc& desc,
                                            std::span<const float> texels = {});
// The current content of a storage image, as floats (halves widened), layer-major, row-major.
std::vector<float> read_storage_image(Texture& image);

// Thrown by run() when a case fetched or wrote a texel outside its image (FunctionOptions::
// check_bounds): the message names how many cases did, and one of them with its coordinate and
// the image's size.
class OutOfBoundsError : public Error {
 public:
  using Error::Error;
};

struct SpecConstant {
  uint32_t id;
  uint32_t bits;  // the 32-bit value (use spec_constant() to build from int/float/bool)
};
template <class T>
SpecConstant spec_constant(uint32_t id, T value) {
  static_assert(sizeof(T) == 4 || std::is_same_v<T, bool>);
  uint32_t bits = 0;
  if constexpr (std::is_same_v<T, bool>)
    bits = value ? 1u : 0u;
  else
    std::memcpy(&bits, &value, 4);
  return {id, bits};
}

// The directories searched where PENUMBRA_SHADER_PATH is not set (colon-separated): called before
// main() by a source penumbra_add_shader_tests generates into each test executable from its
// SHADER_DIRS, so the executable finds its GLSL when run directly, outside CTest, too. Returns
// true (for a static initializer).
bool set_default_shader_path(const char* path);

struct FunctionOptions {
  // Searched first, in order, for the tested file and its includes; then PENUMBRA_SHADER_PATH (a
  // colon-separated list; penumbra_add_shader_tests sets it from SHADER_DIRS), then Penumbra's
  // own shader library (shader::default_shader_dir()), then the tested file's own directory.
  std::vector<std::filesystem::path> include_dirs;
  std::vector<shader::Define> defines;
  std::vector<SpecConstant> spec_constants;
  std::string prelude;  // GLSL placed before the #include of the tested file
  // shader::CompileOptions::strip_include_version: a tested or included file may begin with its
  // own #version (third-party GLSL); it is dropped, and said so on stderr.
  bool strip_include_version = true;
  // shader::CompileOptions::include_once: files without include guards that share helpers can be
  // tested together (each file is included once per wrapper).
  bool include_once = false;
  // Out-of-bounds detection: texelFetch, texelFetchOffset, imageLoad and imageStore in the tested
  // code go through checked versions (macros defined before the tested file is included) that
  // compare the coordinate, layer and level with the image's size; run() throws OutOfBoundsError
  // when any case went outside. Such an access is undefined in Vulkan (lavapipe returns 0, the
  // validation layer does not look), so it fails the test instead of passing by luck.
  bool check_bounds = true;
  uint32_t workgroup_size = 64;
};

// ---- the type-erased engine ---------------------------------------------------------------

struct ParamSpec {
  enum class Dir { in, out, inout, resource };
  Dir dir = Dir::in;
  std::shared_ptr<const TypeDesc> type;  // null for resources
  ResourceKind resource = ResourceKind::sampler2d;
};

class FunctionEngine {
 public:
  // The engine for this exact wrapper: generated, compiled, reflected and checked once per
  // process, then shared.
  static std::shared_ptr<FunctionEngine> get(const std::filesystem::path& file,
                                             const std::string& function,
                                             std::shared_ptr<const TypeDesc> return_type,
                                             const std::vector<ParamSpec>& params,
                                             const FunctionOptions& options);
  ~FunctionEngine();

  const std::string& source() const { return source_; }
  const std::filesystem::path& file() const { return file_; }
  const std::string& signature() const { return signature_; }
  // What the compiler changed in the sources it read (shader::CompiledShader::notes).
  const std::vector<std::string>& notes() const { return notes_; }
  uint32_t input_stride() const { return input_stride_; }
  uint32_t output_stride() const { return output_stride_; }
  // std430 offsets and types of the input members (in/inout params, in order) and output
  // members (return value first, then out/inout params, in order).
  const std::vector<uint32_t>& input_offsets() const { return input_offsets_; }
  const std::vector<uint32_t>& output_offsets() const { return output_offsets_; }
  const std::vector<std::shared_ptr<const TypeDesc>>& input_types() const { return input_types_; }
  const std::vector<std::shared_ptr<const TypeDesc>>& output_types() const { return output_types_; }
  size_t resource_count() const { return resource_kinds_.size(); }

  // Runs `count` cases (inputs: count · input_stride bytes) and fills outputs (count ·
  // output_stride bytes). resources[i] binds the i-th resource parameter.
  // Throws OutOfBoundsError when bounds are checked and a case went outside an image.
  // `printed`, when given, receives each case's debug printf lines (see ShaderFunction::printed).
  void run(std::span<const std::byte> inputs, size_t count, std::span<std::byte> outputs,
           const std::vector<ResourceBinding>& resources,
           std::vector<std::vector<std::string>>* printed = nullptr);
  // The wrapper's SPIR-V prints (GL_EXT_debug_printf).
  bool prints() const { return prints_; }

  struct Impl;

 private:
  FunctionEngine() = default;
  std::string describe_out_of_bounds(const std::vector<int32_t>& report) const;
  std::filesystem::path file_;
  std::string signature_;
  std::vector<std::string> notes_;
  std::string source_;
  uint32_t input_stride_ = 0, output_stride_ = 0;
  std::vector<uint32_t> input_offsets_, output_offsets_;
  std::vector<std::shared_ptr<const TypeDesc>> input_types_, output_types_;
  std::vector<ResourceKind> resource_kinds_;
  std::vector<size_t> resource_params_;  // parameter index of each resource
  bool check_bounds_ = false;            // the wrapper carries the bounds checks
  bool prints_ = false;
  std::vector<std::string> bounds_types_;  // the GLSL type of each checked overload
  std::unique_ptr<Impl> impl_;
};

// Resolves a shader file through the harness's search path; throws naming what was searched.
std::filesystem::path resolve_shader_file(const std::filesystem::path& file,
                                          const std::vector<std::filesystem::path>& extra_dirs);
std::vector<std::filesystem::path> default_shader_dirs();

// ---- the typed front end -------------------------------------------------------------------

namespace detail {

template <class P>
struct ParamTraits {  // plain `in` parameter
  using In = std::tuple<P>;
  using Result = std::tuple<>;
  static ParamSpec spec() { return {ParamSpec::Dir::in, glsl_type<P>(), {}}; }
};
template <class T>
struct ParamTraits<Out<T>> {
  using In = std::tuple<>;
  using Result = std::tuple<T>;
  static ParamSpec spec() { return {ParamSpec::Dir::out, glsl_type<T>(), {}}; }
};
template <class T>
struct ParamTraits<InOut<T>> {
  using In = std::tuple<T>;
  using Result = std::tuple<T>;
  static ParamSpec spec() { return {ParamSpec::Dir::inout, glsl_type<T>(), {}}; }
};
template <class P>
requires requires {
  P::kind;
}
struct ParamTraits<P> {
  using In = std::tuple<>;
  using Result = std::tuple<>;
  static ParamSpec spec() { return {ParamSpec::Dir::resource, nullptr, P::kind}; }
};

template <class Tuple>
struct Unwrap {
  using type = Tuple;
};
template <class T>
struct Unwrap<std::tuple<T>> {
  using type = T;
};

template <class R>
using ReturnTuple = std::conditional_t<std::is_void_v<R>, std::tuple<>, std::tuple<R>>;

}  // namespace detail

template <class Signature>
class ShaderFunction;

template <class R, class... P>
class ShaderFunction<R(P...)> {
 public:
  // One case: the values of the in and inout parameters, in order.
  using Inputs = decltype(std::tuple_cat(std::declval<typename detail::ParamTraits<P>::In>()...));
  // The return value (if not void), then the out and inout parameters, in order; a single value
  // is returned bare rather than as a one-element tuple.
  using ResultTuple =
      decltype(std::tuple_cat(std::declval<detail::ReturnTuple<R>>(),
                              std::declval<typename detail::ParamTraits<P>::Result>()...));
  using Result = typename detail::Unwrap<ResultTuple>::type;

  // A construction error (the file, a compile error, a signature that matches no overload, a
  // layout mismatch) is thrown with the caller's file:line in front of its message, so that a
  // test's report names the line that built the function (GoogleTest itself cannot locate an
  // exception). Its type is kept: shader::CompileError, with its diagnostics, or Error.
  ShaderFunction(const std::filesystem::path& file, const std::string& function,
                 FunctionOptions options = {},
                 std::source_location where = std::source_location::current()) {
    std::shared_ptr<const TypeDesc> ret;
    if constexpr (!std::is_void_v<R>) ret = glsl_type<R>();
    const auto at = [&] {
      return std::string(where.file_name()) + ":" + std::to_string(where.line()) +
             ": in ShaderFunction(\"" + file.string() + "\", \"" + function + "\"):\n";
    };
    try {
      engine_ =
          FunctionEngine::get(file, function, ret, {detail::ParamTraits<P>::spec()...}, options);
    } catch (const shader::CompileError& e) {
      throw shader::CompileError(at() + e.what(), e.diagnostics());
    } catch (const Error& e) {
      throw Error(at() + e.what());
    }
    resources_.resize(engine_->resource_count());
  }

  // Binds the texture of the `resource_index`-th resource parameter (0 = the first resource
  // parameter of the signature).
  ShaderFunction& bind(size_t resource_index, std::shared_ptr<Texture> texture) {
    return bind(resource_index, std::move(texture), ExternalSampler{});
  }
  // The same, sampled through the caller's own sampler instead of the texture's.
  ShaderFunction& bind(size_t resource_index, std::shared_ptr<Texture> texture,
                       ExternalSampler sampler) {
    if (resource_index >= resources_.size()) {
      throw Error("ShaderFunction::bind: resource index " + std::to_string(resource_index) +
                  " out of range; the signature has " + std::to_string(resources_.size()) +
                  " resource parameter(s)");
    }
    resources_[resource_index] = ResourceBinding{std::move(texture), sampler};
    return *this;
  }

  // Evaluates every case in one dispatch (or a few, beyond the device's group-count limit).
  std::vector<Result> run(std::span<const Inputs> cases) {
    const size_t n = cases.size();
    std::vector<Result> results(n);
    if (n == 0) return results;
    const uint32_t in_stride = engine_->input_stride(), out_stride = engine_->output_stride();
    input_bytes_.assign(n * in_stride, std::byte{0});
    output_bytes_.assign(n * out_stride, std::byte{0});
    const auto& in_off = engine_->input_offsets();
    const auto& in_types = engine_->input_types();
    for (size_t c = 0; c < n; ++c) {
      std::byte* base = input_bytes_.data() + c * in_stride;
      std::apply(
          [&](const auto&... v) {
            size_t k = 0;
            ((detail::pack(v, base + in_off[k], *in_types[k]), ++k), ...);
          },
          cases[c]);
    }
    engine_->run(input_bytes_, n, output_bytes_, resources_, &printed_);
    set_last_run_printf(printed_);
    const auto& out_off = engine_->output_offsets();
    const auto& out_types = engine_->output_types();
    for (size_t c = 0; c < n; ++c) {
      const std::byte* base = output_bytes_.data() + c * out_stride;
      Result r{};  // a local, not results[c]: std::vector<bool> hands out proxies
      if constexpr (std::tuple_size_v<ResultTuple> == 1) {
        detail::unpack(r, base + out_off[0], *out_types[0]);
      } else {
        std::apply(
            [&](auto&... v) {
              size_t k = 0;
              ((detail::unpack(v, base + out_off[k], *out_types[k]), ++k), ...);
            },
            r);
      }
      results[c] = std::move(r);
    }
    return results;
  }
  std::vector<Result> run(const std::vector<Inputs>& cases) {
    return run(std::span<const Inputs>(cases));
  }

  // A single case (a batch of one).
  template <class... A>
  Result operator()(A&&... args) {
    const Inputs one{std::forward<A>(args)...};
    return run(std::span<const Inputs>(&one, 1))[0];
  }

  const std::string& source() const { return engine_->source(); }
  const FunctionEngine& engine() const { return *engine_; }

  // What each case of the last run printed with debugPrintfEXT (GL_EXT_debug_printf), in the
  // order printed: printed()[case] is that case's lines. Empty when the function does not print;
  // when it prints but the device was made without debug printf (PENUMBRA_DEBUG_PRINTF=1 with
  // validation on), run() says so once on stderr. A failing PENUMBRA_EXPECT_ALL_NEAR over this
  // run's results lists each reported case's lines.
  const std::vector<std::vector<std::string>>& printed() const { return printed_; }

 private:
  std::shared_ptr<FunctionEngine> engine_;
  std::vector<ResourceBinding> resources_;
  std::vector<std::byte> input_bytes_, output_bytes_;
  std::vector<std::vector<std::string>> printed_;
};

}  // namespace penumbra::testing
