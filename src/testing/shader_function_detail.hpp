#pragma once
// The shader-function harness's checks, shared by FunctionEngine (shader_function.cpp) and
// defined in shader_function_checks.cpp.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <penumbra/shader/reflection.hpp>
#include <penumbra/testing/shader_function.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::testing::detail {

// The wrapper's block `block` (GLSL struct struct_name) against the C++ description: every
// member at its offset, the array stride; throws penumbra::Error naming the first difference.
void check_block(
    const shader::Reflection& refl, const char* block, const char* struct_name,
    const std::vector<std::pair<std::string, std::shared_ptr<const TypeDesc>>>& members,
    const std::vector<uint32_t>& offsets, uint32_t stride);
// A type's layout as text (what two descriptions must share to share a wrapper).
std::string layout_signature(const TypeDesc& t);
// The source with line numbers (only those lines when given), for messages.
std::string numbered(const std::string& source, const std::vector<int>& only = {});
bool is_storage(ResourceKind kind);
VkDescriptorType descriptor_type(ResourceKind kind);
// Whether a texture (or an external sampler) fits a GLSL parameter of this kind.
bool kind_matches(ResourceKind kind, const Texture& t, const ExternalSampler& external);
std::string describe_texture(const Texture& t, const ExternalSampler& external);
// SPIR-V's StorageImageReadWithoutFormat capability (the specification's number).
inline constexpr uint32_t kCapabilityStorageImageReadWithoutFormat = 55;
bool uses_capability(const std::vector<uint32_t>& spirv, uint32_t capability);
std::set<uint32_t> capabilities(const std::vector<uint32_t>& spirv);
bool imports_debug_printf(const std::vector<uint32_t>& spirv);
// A verbose debug printf message: which dispatch and invocation printed, and what. Returns false
// for a message without the invocation (the layer not in verbose mode).
bool parse_printf(const std::string& message, uint64_t& dispatch, uint64_t& invocation,
                  std::string& text);
// The text of a non-verbose message: what follows the layer's header.
std::string printf_text(const std::string& message);

// ---- bounds checks

inline constexpr const char* kBoundsOps[] = {"texelFetch", "texelFetchOffset", "imageLoad", "imageStore"};

// std430 layout of PenumbraBounds: 11 scalars, 4 bytes each, in this order.
inline constexpr const char* kBoundsMembers[] = {"count", "first_case", "op", "type", "level", "levels",
                                          "x",     "y",          "z",  "w",    "h",     "d"};
inline constexpr uint32_t kBoundsBytes = sizeof(kBoundsMembers) / sizeof(kBoundsMembers[0]) * 4;

// GLSL placed before the tested file: the report buffer, the case index, the checked versions,
// and the macros that route the tested code's calls through them. Type names (the `type` the
// report records) are collected in `types`.
std::string bounds_prelude(uint32_t binding, bool images, std::vector<std::string>& types);

}  // namespace penumbra::testing::detail
