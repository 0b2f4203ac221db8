// GLSL coverage: the SPIR-V instrumentation (coverage_totals.cpp: the per-process totals and the
// LCOV tracefile).

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/coverage.hpp>
#include <set>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include "coverage_spirv.hpp"

namespace fs = std::filesystem;

namespace penumbra::testing {
namespace detail {
namespace {

// SPIR-V opcodes and enumerants used here (the SPIR-V 1.5 specification's numbers).
enum : uint32_t {
  kOpSource = 3,
  kOpTypeVector = 23,
  kOpCompositeConstruct = 80,
  kOpCompositeExtract = 81,
  kOpIMul = 132,
  kOpLoad = 61,
  kOpStore = 62,
  kOpIAdd = 128,
  kOpName = 5,
  kOpString = 7,
  kOpLine = 8,
  kOpMemoryModel = 14,
  kOpEntryPoint = 15,
  kOpTypeInt = 21,
  kOpTypeRuntimeArray = 29,
  kOpTypeStruct = 30,
  kOpTypePointer = 32,
  kOpConstant = 43,
  kOpFunction = 54,
  kOpFunctionEnd = 56,
  kOpFunctionCall = 57,
  kOpVariable = 59,
  kOpAccessChain = 65,
  kOpDecorate = 71,
  kOpMemberDecorate = 72,
  kOpSelect = 169,
  kOpPhi = 245,
  kOpLoopMerge = 246,
  kOpSelectionMerge = 247,
  kOpLabel = 248,
  kOpBranch = 249,
  kOpBranchConditional = 250,
  kOpSwitch = 251,
  kOpKill = 252,
  kOpReturn = 253,
  kOpReturnValue = 254,
  kOpUnreachable = 255,
  kOpNoLine = 317,
  kOpTerminateInvocation = 4416,
  kOpIgnoreIntersectionKHR = 4448,
  kOpTerminateRayKHR = 4449,
  kOpEmitMeshTasksEXT = 5294,

  kStorageUniform = 2,
  kStoragePrivate = 6,
  kDecorationBuiltIn = 11,
  kBuiltInGlobalInvocationId = 28,
  kStorageStorageBuffer = 12,
  kDecorationBlock = 2,
  kDecorationBufferBlock = 3,
  kDecorationArrayStride = 6,
  kDecorationBinding = 33,
  kDecorationDescriptorSet = 34,
  kDecorationOffset = 35,
};

bool is_terminator(uint32_t op) {
  switch (op) {
    case kOpBranch:
    case kOpBranchConditional:
    case kOpSwitch:
    case kOpKill:
    case kOpReturn:
    case kOpReturnValue:
    case kOpUnreachable:
    case kOpTerminateInvocation:
    case kOpIgnoreIntersectionKHR:
    case kOpTerminateRayKHR:
    case kOpEmitMeshTasksEXT:
      return true;
    default:
      return false;
  }
}

// The sections before the annotations (capabilities .. debug names), and the annotations.
bool before_types(uint32_t op) {
  switch (op) {
    case 17:    // OpCapability
    case 10:    // OpExtension
    case 11:    // OpExtInstImport
    case 14:    // OpMemoryModel
    case 15:    // OpEntryPoint
    case 16:    // OpExecutionMode
    case 331:   // OpExecutionModeId
    case 7:     // OpString
    case 4:     // OpSourceExtension
    case 3:     // OpSource
    case 2:     // OpSourceContinued
    case 5:     // OpName
    case 6:     // OpMemberName
    case 330:   // OpModuleProcessed
    case 71:    // OpDecorate
    case 72:    // OpMemberDecorate
    case 73:    // OpDecorationGroup
    case 74:    // OpGroupDecorate
    case 75:    // OpGroupMemberDecorate
    case 332:   // OpDecorateId
    case 5632:  // OpDecorateString
    case 5633:  // OpMemberDecorateString
      return true;
    default:
      return false;
  }
}

std::string literal_string(std::span<const uint32_t> words) {
  std::string s;
  for (uint32_t w : words) {
    for (int b = 0; b < 4; ++b) {
      const char c = char((w >> (8 * b)) & 0xffu);
      if (c == '\0') return s;
      s.push_back(c);
    }
  }
  return s;
}

struct Inst {
  size_t at;  // word offset
  uint32_t words;
  uint32_t op;
};

}  // namespace

std::string demangle_glsl(std::string_view mangled) {
  const size_t open = mangled.find('(');
  if (open == std::string_view::npos) return std::string(mangled);
  std::string out(mangled.substr(0, open + 1));
  std::string_view rest = mangled.substr(open + 1);
  auto scalar = [](char c) -> const char* {
    switch (c) {
      case 'f':
        return "float";
      case 'd':
        return "double";
      case 'i':
        return "int";
      case 'u':
        return "uint";
      case 'b':
        return "bool";
      default:
        return nullptr;
    }
  };
  auto prefix = [](char c) -> const char* {
    switch (c) {
      case 'f':
        return "";
      case 'd':
        return "d";
      case 'i':
        return "i";
      case 'u':
        return "u";
      case 'b':
        return "b";
      default:
        return nullptr;
    }
  };
  auto digit = [](char c) { return c >= '2' && c <= '4'; };
  bool first = true;
  while (!rest.empty()) {
    const size_t semi = rest.find(';');
    std::string_view t = rest.substr(0, semi);
    rest = semi == std::string_view::npos ? std::string_view() : rest.substr(semi + 1);
    if (t.empty()) continue;
    std::string array;  // "[3]" suffixes stay as written
    if (const size_t br = t.find('['); br != std::string_view::npos) {
      array = std::string(t.substr(br));
      t = t.substr(0, br);
    }
    std::string name;
    if (t.size() == 2 && t[1] == '1' && scalar(t[0])) {
      name = scalar(t[0]);
    } else if (t.size() == 3 && t[0] == 'v' && prefix(t[1]) && digit(t[2])) {
      name = std::string(prefix(t[1])) + "vec" + t[2];
    } else if (t.size() == 4 && t[0] == 'm' && (t[1] == 'f' || t[1] == 'd') && digit(t[2]) &&
               digit(t[3])) {
      name = std::string(prefix(t[1])) + "mat" + t[2];
      if (t[2] != t[3]) name += std::string("x") + t[3];
    } else if (t.rfind("struct-", 0) == 0) {
      // struct-Name-member types...
      name = std::string(t.substr(7, t.find('-', 7) - 7));
    } else if (t.size() >= 2 && t[0] == 's') {
      // s [I] [A] [S] dim [M] ...: sS21 sampler2DShadow, sASC1 samplerCubeArrayShadow
      size_t k = 1;
      const bool image = k < t.size() && t[k] == 'I' && ++k;
      const bool arrayed = k < t.size() && t[k] == 'A' && ++k;
      const bool shadow = k < t.size() && t[k] == 'S' && ++k;
      const char dim = k < t.size() ? t[k++] : '?';
      const bool ms = k < t.size() && t[k] == 'M' && ++k;
      const char* dims = dim == '1'   ? "1D"
                         : dim == '2' ? "2D"
                         : dim == '3' ? "3D"
                         : dim == 'C' ? "Cube"
                                      : nullptr;
      if (dims != nullptr &&
          t.substr(k).find_first_not_of("0123456789") == std::string_view::npos) {
        name = std::string(image ? "image" : "sampler") + dims + (ms ? "MS" : "") +
               (arrayed ? "Array" : "") + (shadow ? "Shadow" : "");
      } else {
        name = std::string(t);
      }
    } else {
      name = std::string(t);
    }
    out += (first ? "" : "; ") + name + array;  // LCOV's FN records take no comma
    first = false;
  }
  return out + ")";
}

InstrumentedSpirv instrument_for_coverage(std::span<const uint32_t> spirv, uint32_t set,
                                          uint32_t binding,
                                          const std::function<bool(std::string_view)>& count_file) {
  if (spirv.size() < 5 || spirv[0] != 0x07230203u)
    throw Error("coverage: not a SPIR-V module (no magic number)");
  const uint32_t version = spirv[1];
  std::vector<Inst> insts;
  for (size_t i = 5; i < spirv.size();) {
    const uint32_t words = spirv[i] >> 16, op = spirv[i] & 0xffffu;
    if (words == 0 || i + words > spirv.size())
      throw Error("coverage: malformed SPIR-V instruction at word " + std::to_string(i));
    insts.push_back({i, words, op});
    i += words;
  }
  auto word = [&](const Inst& in, uint32_t k) { return k < in.words ? spirv[in.at + k] : 0u; };

  // ---- what the module has ----
  const bool storage_buffer = version >= 0x00010300u;
  const uint32_t sc = storage_buffer ? kStorageStorageBuffer : kStorageUniform;
  std::unordered_map<uint32_t, std::string> strings, names;
  uint32_t uint_type = 0, uvec4_type = 0, ptr_uvec4 = 0, gid_var = 0, gid_vec = 0;
  std::set<uint32_t> entry_functions;
  size_t first_function = insts.size(), decorate_at = insts.size();
  for (size_t k = 0; k < insts.size(); ++k) {
    const Inst& in = insts[k];
    if (decorate_at == insts.size() && !before_types(in.op)) decorate_at = k;
    if (in.op == kOpString)
      strings[word(in, 1)] = literal_string(spirv.subspan(in.at + 2, in.words - 2));
    if (in.op == kOpName)
      names[word(in, 1)] = literal_string(spirv.subspan(in.at + 2, in.words - 2));
    if (in.op == kOpTypeInt && word(in, 2) == 32 && word(in, 3) == 0 && uint_type == 0)
      uint_type = word(in, 1);
    if (in.op == kOpFunction && first_function == insts.size()) first_function = k;
    if (in.op == kOpEntryPoint) entry_functions.insert(word(in, 2));
    if (in.op == kOpDecorate && word(in, 2) == kDecorationBuiltIn &&
        word(in, 3) == kBuiltInGlobalInvocationId)
      gid_var = word(in, 1);
  }
  std::vector<size_t> entry_returns;  // the OpReturns of entry points' functions
  // The functions an entry point calls, directly or not: only their counters can move (the
  // others are kept uncalled for the count of lines no test runs), so only they are flushed.
  std::set<uint32_t> reachable = entry_functions;
  {
    std::map<uint32_t, std::set<uint32_t>> callees;
    uint32_t current = 0;
    for (size_t k = 0; k < insts.size(); ++k) {
      if (insts[k].op == kOpFunction) current = word(insts[k], 2);
      if (insts[k].op == kOpFunctionCall) callees[current].insert(word(insts[k], 3));
      if (insts[k].op == kOpReturn && entry_functions.count(current)) entry_returns.push_back(k);
    }
    std::vector<uint32_t> work(reachable.begin(), reachable.end());
    while (!work.empty()) {
      const uint32_t f = work.back();
      work.pop_back();
      for (uint32_t g : callees[f])
        if (reachable.insert(g).second) work.push_back(g);
    }
  }
  uint32_t gid_pointer = 0;
  for (const Inst& in : insts)
    if (in.op == kOpTypeVector && uint_type != 0 && word(in, 2) == uint_type && word(in, 3) == 4)
      uvec4_type = word(in, 1);
  for (const Inst& in : insts) {
    if (in.op == kOpTypePointer && uvec4_type != 0 && word(in, 2) == sc &&
        word(in, 3) == uvec4_type)
      ptr_uvec4 = word(in, 1);
    if (in.op == kOpVariable && gid_var != 0 && word(in, 2) == gid_var) gid_pointer = word(in, 1);
  }
  for (const Inst& in : insts)
    if (in.op == kOpTypePointer && gid_pointer != 0 && word(in, 1) == gid_pointer)
      gid_vec = word(in, 3);
  size_t types_at = first_function;
  while (types_at > decorate_at &&
         (insts[types_at - 1].op == kOpLine || insts[types_at - 1].op == kOpNoLine))
    --types_at;

  // ---- the blocks, their lines and branches ----
  InstrumentedSpirv result;
  CoverageMap& map = result.map;
  std::unordered_map<uint32_t, int> file_of_string;  // OpString id -> map.files index, -1: not
  auto counted_file = [&](uint32_t string_id) -> int {
    if (auto it = file_of_string.find(string_id); it != file_of_string.end()) return it->second;
    int index = -1;
    if (auto it = strings.find(string_id); it != strings.end() && count_file(it->second)) {
      index = int(map.files.size());
      map.files.push_back(it->second);
    }
    file_of_string[string_id] = index;
    return index;
  };
  struct BlockScan {
    size_t insert_at = 0;  // instruction index the block counter goes before
    std::vector<CoverageMap::Line> lines;
    bool entry = false;
    uint32_t function_id = 0;  // the function it is in
    std::optional<CoverageMap::Line> function_line;
    // the conditional branch that ends it, when its line is counted
    std::optional<CoverageMap::Line> branch_line;
    size_t branch_at = 0;  // the branch, or the merge instruction just before it
    uint32_t condition = 0;
  };
  std::vector<BlockScan> blocks;
  bool in_function = false, in_block = false, have_line = false, first_block = false;
  uint32_t function_id = 0;
  std::optional<CoverageMap::Line> line, function_line;
  size_t merge_at = 0;  // 0: none in this block (index 0 is never in a function)
  for (size_t k = 0; k < insts.size(); ++k) {
    const Inst& in = insts[k];
    switch (in.op) {
      case kOpLine: {
        const int f = counted_file(word(in, 1));
        have_line = true;
        line = f >= 0 ? std::optional(CoverageMap::Line{uint32_t(f), word(in, 2)}) : std::nullopt;
        if (in_block && line) blocks.back().lines.push_back(*line);
        continue;
      }
      case kOpNoLine:
        have_line = false;
        line.reset();
        continue;
      case kOpFunction:
        in_function = true;
        first_block = true;
        function_id = word(in, 2);
        function_line = have_line ? line : std::nullopt;
        continue;
      case kOpFunctionEnd:
        in_function = in_block = have_line = false;
        line.reset();
        continue;
      default:
        break;
    }
    if (!in_function) continue;
    if (in.op == kOpLabel) {
      BlockScan b;
      b.insert_at = 0;
      b.function_id = function_id;
      if (have_line && line) b.lines.push_back(*line);
      if (first_block) {
        b.entry = true;
        b.function_line = function_line;
        if (function_line) b.lines.insert(b.lines.begin(), *function_line);
        first_block = false;
      }
      blocks.push_back(std::move(b));
      in_block = true;
      merge_at = 0;
      continue;
    }
    if (!in_block) continue;
    BlockScan& b = blocks.back();
    if (b.insert_at == 0 && in.op != kOpPhi && in.op != kOpVariable) b.insert_at = k;
    if (in.op == kOpSelectionMerge || in.op == kOpLoopMerge) merge_at = k;
    if (in.op == kOpBranchConditional && have_line && line) {
      b.branch_line = line;
      b.branch_at = merge_at != 0 ? merge_at : k;  // a merge must stay just before its branch
      b.condition = word(in, 1);
    }
    if (is_terminator(in.op)) {
      in_block = false;
      have_line = false;
      line.reset();
    }
  }

  // Counters: blocks with a counted line or a counted branch; then the branches.
  std::vector<int> counter_of_block(blocks.size(), -1);
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> branches_at_line;
  for (size_t b = 0; b < blocks.size(); ++b) {
    BlockScan& s = blocks[b];
    if (s.lines.empty() && !s.branch_line) continue;
    counter_of_block[b] = int(map.blocks.size());
    std::sort(s.lines.begin(), s.lines.end(),
              [](auto& x, auto& y) { return std::tie(x.file, x.line) < std::tie(y.file, y.line); });
    s.lines.erase(
        std::unique(s.lines.begin(), s.lines.end(),
                    [](auto& x, auto& y) { return x.file == y.file && x.line == y.line; }),
        s.lines.end());
    map.blocks.push_back({s.lines});
    if (s.entry && !s.lines.empty()) {
      const auto it = names.find(s.function_id);
      map.functions.push_back(
          {s.function_line.value_or(s.lines.front()),
           it != names.end() ? demangle_glsl(it->second) : "%" + std::to_string(s.function_id),
           uint32_t(counter_of_block[b])});
    }
  }
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (!blocks[b].branch_line) continue;
    const CoverageMap::Line at = *blocks[b].branch_line;
    map.branches.push_back(
        {at, uint32_t(counter_of_block[b]), branches_at_line[{at.file, at.line}]++});
  }

  // Only the functions an entry point reaches can count: the others (kept uncalled) get no
  // code, their counters stay 0. Each live counter has a slot in the private array.
  std::vector<uint32_t> live;
  std::vector<int> slot(map.counters(), -1);
  for (size_t b = 0; b < blocks.size(); ++b)
    if (counter_of_block[b] >= 0 && reachable.count(blocks[b].function_id))
      live.push_back(uint32_t(counter_of_block[b]));
  {
    uint32_t j = 0;
    for (size_t b = 0; b < blocks.size(); ++b) {
      if (!blocks[b].branch_line) continue;
      if (reachable.count(blocks[b].function_id)) live.push_back(uint32_t(map.blocks.size()) + j);
      ++j;
    }
  }
  for (size_t i = 0; i < live.size(); ++i) slot[live[i]] = int(i);
  map.live = live;

  // ---- the new module ----
  // Each invocation counts in Private variables, one per live counter (no atomics in the
  // tested code: a loop's block would contend on one address every iteration), and every
  // return of an entry point stores them to its own row of the counter buffer, four to a
  // uvec4: counters[gl_GlobalInvocationID.x * row_words + slot]. The host adds the rows up.
  // (Atomics or subgroup reductions there cost lavapipe 3-4x the compile time of stores, and
  // scalar stores 2-3x that of uvec4 stores.)
  if (gid_var == 0 || gid_vec == 0)
    throw Error("coverage: the module does not read gl_GlobalInvocationID");
  uint32_t bound = spirv[3];
  auto id = [&] { return bound++; };
  const bool new_uint = uint_type == 0;
  if (new_uint) uint_type = id();
  const bool new_uvec4 = uvec4_type == 0;
  if (new_uvec4) uvec4_type = id();
  const bool new_ptr_uvec4 = ptr_uvec4 == 0;
  if (new_ptr_uvec4) ptr_uvec4 = id();
  const uint32_t row_vectors = map.row_words() / 4;
  const uint32_t array_type = id(), struct_type = id(), ptr_struct = id(), var = id();
  const uint32_t ptr_private_uint = id();
  std::vector<uint32_t> private_vars(live.size());
  for (uint32_t& v : private_vars) v = id();
  const uint32_t c0 = id(), c1 = id(), row = id();
  std::vector<uint32_t> slot_constant(live.size());
  for (size_t k = 0; k < live.size(); ++k) slot_constant[k] = k == 0 ? c0 : k == 1 ? c1 : id();

  std::multimap<size_t, std::vector<uint32_t>> inserts;  // instruction index -> words before it
  auto op = [](uint32_t code, std::initializer_list<uint32_t> operands) {
    std::vector<uint32_t> w{uint32_t((operands.size() + 1) << 16) | code};
    w.insert(w.end(), operands);
    return w;
  };
  auto append = [](std::vector<uint32_t>& to, const std::vector<uint32_t>& w) {
    to.insert(to.end(), w.begin(), w.end());
  };
  {
    std::vector<uint32_t> d;
    append(d, op(kOpDecorate, {array_type, kDecorationArrayStride, 16}));
    append(d, op(kOpMemberDecorate, {struct_type, 0, kDecorationOffset, 0}));
    append(d, op(kOpDecorate, {struct_type, storage_buffer ? uint32_t(kDecorationBlock)
                                                           : uint32_t(kDecorationBufferBlock)}));
    append(d, op(kOpDecorate, {var, kDecorationDescriptorSet, set}));
    append(d, op(kOpDecorate, {var, kDecorationBinding, binding}));
    inserts.emplace(decorate_at, std::move(d));
  }
  {
    std::vector<uint32_t> t;
    if (new_uint) append(t, op(kOpTypeInt, {uint_type, 32, 0}));
    if (new_uvec4) append(t, op(kOpTypeVector, {uvec4_type, uint_type, 4}));
    append(t, op(kOpTypeRuntimeArray, {array_type, uvec4_type}));
    append(t, op(kOpTypeStruct, {struct_type, array_type}));
    append(t, op(kOpTypePointer, {ptr_struct, sc, struct_type}));
    if (new_ptr_uvec4) append(t, op(kOpTypePointer, {ptr_uvec4, sc, uvec4_type}));
    append(t, op(kOpTypePointer, {ptr_private_uint, kStoragePrivate, uint_type}));
    append(t, op(kOpConstant, {uint_type, c0, 0}));
    append(t, op(kOpConstant, {uint_type, c1, 1}));
    for (size_t k = 2; k < live.size(); ++k)
      append(t, op(kOpConstant, {uint_type, slot_constant[k], uint32_t(k)}));
    append(t, op(kOpConstant, {uint_type, row, row_vectors}));
    append(t, op(kOpVariable, {ptr_struct, var, sc}));
    for (uint32_t v : private_vars)
      append(t, op(kOpVariable, {ptr_private_uint, v, kStoragePrivate, c0}));
    inserts.emplace(types_at, std::move(t));
  }

  // private[slot] += value
  auto count = [&](std::vector<uint32_t>& to, int s, uint32_t value) {
    const uint32_t p = private_vars[uint32_t(s)], v = id(), sum = id();
    append(to, op(kOpLoad, {uint_type, v, p}));
    append(to, op(kOpIAdd, {uint_type, sum, v, value}));
    append(to, op(kOpStore, {p, sum}));
  };
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (counter_of_block[b] < 0 || slot[uint32_t(counter_of_block[b])] < 0) continue;
    std::vector<uint32_t> w;
    count(w, slot[uint32_t(counter_of_block[b])], c1);
    inserts.emplace(blocks[b].insert_at, std::move(w));
  }
  {
    uint32_t j = 0;
    for (size_t b = 0; b < blocks.size(); ++b) {
      if (!blocks[b].branch_line) continue;
      const int s = slot[uint32_t(map.blocks.size()) + j++];
      if (s < 0) continue;
      const uint32_t taken = id();
      std::vector<uint32_t> w;
      append(w, op(kOpSelect, {uint_type, taken, blocks[b].condition, c1, c0}));
      count(w, s, taken);
      inserts.emplace(blocks[b].branch_at, std::move(w));
    }
  }
  // The flush, before every OpReturn of an entry point's function.
  for (size_t k : entry_returns) {
    std::vector<uint32_t> w;
    const uint32_t g = id(), x = id(), base = id();
    append(w, op(kOpLoad, {gid_vec, g, gid_var}));
    append(w, op(kOpCompositeExtract, {uint_type, x, g, 0}));
    append(w, op(kOpIMul, {uint_type, base, x, row}));
    for (uint32_t q = 0; q < row_vectors; ++q) {
      uint32_t v[4];
      for (uint32_t c = 0; c < 4; ++c) {
        const size_t s = 4 * q + c;
        v[c] = c0;
        if (s < live.size()) append(w, op(kOpLoad, {uint_type, v[c] = id(), private_vars[s]}));
      }
      const uint32_t vec = id(), index = id(), p = id();
      append(w, op(kOpCompositeConstruct, {uvec4_type, vec, v[0], v[1], v[2], v[3]}));
      append(w, op(kOpIAdd, {uint_type, index, base, slot_constant[q]}));
      append(w, op(kOpAccessChain, {ptr_uvec4, p, var, c0, index}));
      append(w, op(kOpStore, {p, vec}));
    }
    inserts.emplace(k, std::move(w));
  }

  std::vector<uint32_t>& out = result.spirv;
  out.reserve(spirv.size() + 12 * live.size() + 64);
  out.insert(out.end(), spirv.begin(), spirv.begin() + 5);
  for (size_t k = 0; k < insts.size(); ++k) {
    for (auto [it, end] = inserts.equal_range(k); it != end; ++it)
      out.insert(out.end(), it->second.begin(), it->second.end());
    const Inst& in = insts[k];
    if (in.op == kOpEntryPoint && version >= 0x00010400u) {
      // From SPIR-V 1.4 an entry point lists every global variable it uses.
      out.push_back(uint32_t((in.words + 1 + private_vars.size()) << 16) | in.op);
      out.insert(out.end(), spirv.begin() + long(in.at + 1),
                 spirv.begin() + long(in.at + in.words));
      out.push_back(var);
      out.insert(out.end(), private_vars.begin(), private_vars.end());
      continue;
    }
    out.insert(out.end(), spirv.begin() + long(in.at), spirv.begin() + long(in.at + in.words));
  }
  out[3] = bound;
  return result;
}

}  // namespace detail
}  // namespace penumbra::testing
