// SPDX-License-Identifier: MIT
// The layout constants of the shader lookups (shaders/somm_lookup.inc, shared by somm.glsl and somm.hlsl) equal
// the C++ ones, both front files compile the one shared source, and no `?:` operand calls a function (HLSL
// evaluates both operands).
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "somm/bird.h"
#include "somm/encode.h"
#include "somm/micromap.h"
#include "somm_test_arrays.h"

namespace {

std::string readFile(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
std::string readShader(const char* name) {
  return readFile(std::string(SOMM_SHADER_DIR) + "/" + name);
}

// "SOMM_CONST uint SOMM_X = 12u;" (SOMM_CONST is `const` in GLSL, `static const` in HLSL)
std::map<std::string, uint64_t> constants(const std::string& src) {
  std::map<std::string, uint64_t> out;
  const std::regex re(R"(SOMM_CONST uint (SOMM_[A-Z0-9_]+) = (0x[0-9a-fA-F]+|[0-9]+)u;)");
  for (auto it = std::sregex_iterator(src.begin(), src.end(), re); it != std::sregex_iterator(); ++it)
    out[(*it)[1]] = std::stoull((*it)[2], nullptr, 0);
  return out;
}

// The value of an enumerator that exists only once the csm / sdag encodings are in (the encode stage); -1 before.
#define SOMM_ENUMERATOR_OR_NONE(Type, Name) \
  ([](auto tag) -> int64_t {                \
    using T = typename decltype(tag)::type; \
    if constexpr (requires { T::Name; })    \
      return int64_t(T::Name);              \
    else                                    \
      return -1;                            \
  }(std::type_identity<Type>{}))

std::set<std::string> functions(const std::string& src) {
  std::set<std::string> out;
  const std::regex re(R"((?:uint|bool|void|SommArray) (somm[A-Za-z0-9]+)\(([^)]*)\).*)");
  std::istringstream in(src);
  std::smatch m;
  for (std::string line; std::getline(in, line);)
    if (std::regex_match(line, m, re)) out.insert(m[1].str() + "(" + m[2].str() + ")");
  return out;
}

TEST(ShaderConstants, EqualTheCppLayout) {
  const std::map<std::string, uint64_t> expected = {
      {"SOMM_MAX_LEVEL", somm::kMaxLevel},
      {"SOMM_STATE_TRANSPARENT", uint64_t(somm::State::Transparent)},
      {"SOMM_STATE_OPAQUE", uint64_t(somm::State::Opaque)},
      {"SOMM_STATE_UNKNOWN_TRANSPARENT", uint64_t(somm::State::UnknownTransparent)},
      {"SOMM_STATE_UNKNOWN_OPAQUE", uint64_t(somm::State::UnknownOpaque)},
      {"SOMM_ARRAY_MAGIC", 0x434e4553u},  // "SENC"; the serialized bytes are checked below
      {"SOMM_ARRAY_HEADER_BYTES", somm::encode::kArrayHeaderBytes},
      {"SOMM_DESCRIPTOR_BYTES", somm::encode::kDescriptorBytes},
      {"SOMM_TAIL_PADDING", somm::encode::kTailPadding},
      {"SOMM_RANK_BLOCK_BITS", somm::encode::kRankBlockBits},
      {"SOMM_ENCODING_FLAT", uint64_t(somm::Encoding::Flat)},
      {"SOMM_ENCODING_DFS", uint64_t(somm::Encoding::Dfs)},
      {"SOMM_ENCODING_DFS_FAST", uint64_t(somm::Encoding::DfsFast)},
      {"SOMM_ENCODING_RANK", uint64_t(somm::Encoding::Rank)},
      {"SOMM_ENCODING_HYBRID", uint64_t(somm::Encoding::Hybrid)},
      {"SOMM_KIND_FLAT", uint64_t(somm::MapKind::Flat)},
      {"SOMM_KIND_DFS", uint64_t(somm::MapKind::Dfs)},
      {"SOMM_KIND_RANK", uint64_t(somm::MapKind::Rank)},
      {"SOMM_FORMAT_2_STATE", uint64_t(somm::Format::TwoState)},
      {"SOMM_FORMAT_4_STATE", uint64_t(somm::Format::FourState)},
  };
  const std::pair<const char*, int64_t> dag[] = {
      {"SOMM_ENCODING_CSM", SOMM_ENUMERATOR_OR_NONE(somm::Encoding, Csm)},
      {"SOMM_ENCODING_SDAG", SOMM_ENUMERATOR_OR_NONE(somm::Encoding, Sdag)},
      {"SOMM_KIND_CSM", SOMM_ENUMERATOR_OR_NONE(somm::MapKind, Csm)},
      {"SOMM_KIND_SDAG", SOMM_ENUMERATOR_OR_NONE(somm::MapKind, Sdag)},
  };
  {
    const char* file = "somm_lookup.inc";
    const std::string src = readShader(file);
    ASSERT_FALSE(src.empty()) << file;
    std::map<std::string, uint64_t> c = constants(src);
    // The DAG encodings (docs/encodings.md: the sdag directory is 104 bytes): checked when the C++ has them.
    EXPECT_EQ(c["SOMM_SDAG_DIRECTORY_BYTES"], 104u) << file;
    c.erase("SOMM_SDAG_DIRECTORY_BYTES");
    for (const auto& [name, value] : dag) {
      if (value >= 0) {
        EXPECT_EQ(c[name], uint64_t(value)) << file << " " << name;
      }
      c.erase(name);
    }
    EXPECT_EQ(c, expected) << file;
  }
}

uint32_t le32(const std::vector<uint8_t>& b, size_t at) {
  return uint32_t(b[at]) | uint32_t(b[at + 1]) << 8 | uint32_t(b[at + 2]) << 16 | uint32_t(b[at + 3]) << 24;
}

// The header fields where sommArray() reads them: magic at 0, encoding at byte 5, index size at 6, triangles at
// 8, maps at 12, the index buffer at 20, then descriptors (offset u32, level, format, kind).
TEST(ShaderConstants, ArrayHeaderFieldsWhereTheShaderReadsThem) {
  {
    const char* file = "somm_lookup.inc";
    const std::map<std::string, uint64_t> c = constants(readShader(file));
    const somm::OmmArray flat = somm::testing::randomOmmArray(30, somm::Format::FourState, 1, 4, 9);
    for (somm::Encoding e : somm::kAllEncodings) {
      auto a = somm::EncodedArray::build(flat, e);
      ASSERT_TRUE(a);
      const std::vector<uint8_t> b = a->serialize();
      EXPECT_EQ(le32(b, 0), c.at("SOMM_ARRAY_MAGIC")) << file;
      EXPECT_EQ(b[5], uint8_t(e));
      // Byte 7 bit 0 (the sdag directory): byte 6 is the packed index width k, the buffer ceil(T·k / 8) bytes;
      // bit 1: rank-packed, 8·ceil(T/32) bytes of group words, then ceil((listed + 1)·k / 8) bytes of entries,
      // listed = the last word's count + the popcount of its mask.
      const bool packed = (b[7] & 1u) != 0, rank = (b[7] & 2u) != 0;
      EXPECT_EQ(packed, a->hasDirectory());
      EXPECT_EQ(rank, a->indexRankPacked());
      EXPECT_EQ(b[4], packed ? 7u : 1u);
      EXPECT_EQ(b[6], packed ? uint8_t(a->indexBits()) : uint8_t(a->indexType()));
      if (packed) {
        EXPECT_EQ(a->indexBits(), somm::encode::sdagIndexBits(a->mapCount()));
      }
      EXPECT_EQ(le32(b, 8), a->triangleCount());
      EXPECT_EQ(le32(b, 12), a->mapCount());
      size_t indexBytes =
          packed ? (size_t(a->triangleCount()) * b[6] + 7) / 8 : size_t(a->triangleCount()) * b[6];
      if (rank) {
        const size_t groups = (a->triangleCount() + 31) / 32, last = 20 + 8 * (groups - 1);
        const size_t entries = le32(b, last) + size_t(__builtin_popcount(le32(b, last + 4))) + 1;
        indexBytes = 8 * groups + (entries * b[6] + 7) / 8;
      }
      EXPECT_EQ(indexBytes, a->indexBufferBytes());
      const size_t desc = c.at("SOMM_ARRAY_HEADER_BYTES") + indexBytes;
      for (uint32_t m = 0; m < a->mapCount(); ++m) {
        const size_t d = desc + m * c.at("SOMM_DESCRIPTOR_BYTES");
        EXPECT_EQ(le32(b, d), a->maps()[m].offset);
        EXPECT_EQ(b[d + 4], a->maps()[m].level);
        EXPECT_EQ(b[d + 5], a->maps()[m].format);
        EXPECT_EQ(b[d + 6], uint8_t(a->maps()[m].kind));
      }
      const size_t data = desc + size_t(a->mapCount()) * c.at("SOMM_DESCRIPTOR_BYTES");
      EXPECT_EQ(b.size(), data + a->dataBytes() + a->paddingBytes());
      if (e != somm::Encoding::Flat) {
        EXPECT_EQ(a->paddingBytes(), c.at("SOMM_TAIL_PADDING"));
      }
    }
  }
}

TEST(ShaderConstants, GlslAndHlslCompileTheOneSharedSource) {
  const std::set<std::string> shared = functions(readShader("somm_lookup.inc"));
  EXPECT_GE(shared.size(), 20u);
  for (const char* f : {"sommBaryToIndex", "sommStateUV", "sommState", "sommFlatState", "sommDfsState",
                        "sommDfsFastState", "sommRankState", "sommCsmState", "sommSdagState"}) {
    bool found = false;
    for (const std::string& s : shared) found = found || s.rfind(std::string(f) + "(", 0) == 0;
    EXPECT_TRUE(found) << f;
  }
  // The front files only define the per-language macros and include the shared source: no lookup of their own.
  for (const char* file : {"somm.glsl", "somm.hlsl"}) {
    const std::string src = readShader(file);
    EXPECT_NE(src.find("#include \"somm_lookup.inc\""), std::string::npos) << file;
    EXPECT_TRUE(functions(src).empty()) << file;
    EXPECT_EQ(constants(src).size(), 0u) << file;
  }
}

// The operands of every `?:` in `src` that call something other than a pure built-in or cast: HLSL evaluates
// both operands of the conditional operator, so such a call runs even when it is not chosen. (The cause of the
// old HLSL dfs mismatches: the check kernel's `mode == 0 ? sommStateUV(...) : sommState(...)` also ran a
// lookup in a garbage "array", whose loops used up llvmpipe's per-invocation loop budget.)
std::vector<std::string> callsInConditionalOperands(const std::string& src) {
  std::string code;  // comments and preprocessor lines removed
  std::istringstream in(src);
  for (std::string line; std::getline(in, line);) {
    line = line.substr(0, line.find("//"));
    const size_t first = line.find_first_not_of(" \t");
    if (first != std::string::npos && line[first] == '#') continue;
    code += line + "\n";
  }
  std::vector<std::string> out;
  const std::regex call(R"(([A-Za-z_][A-Za-z0-9_]*)\s*\()");
  const std::set<std::string> pure = {"uint", "int",           "float",          "min",
                                      "max",  "SOMM_POPCOUNT", "SOMM_FLOAT_BITS"};
  size_t start = 0;
  for (size_t end; (end = code.find_first_of(";{}", start)) != std::string::npos; start = end + 1) {
    const std::string stmt = code.substr(start, end - start);
    const size_t q = stmt.find('?');
    if (q == std::string::npos) continue;
    const std::string operands = stmt.substr(q + 1);
    bool calls = false;
    for (auto it = std::sregex_iterator(operands.begin(), operands.end(), call); it != std::sregex_iterator();
         ++it)
      calls = calls || pure.count((*it)[1].str()) == 0;
    if (calls) out.push_back(stmt);
  }
  return out;
}

TEST(ShaderConstants, NoCallInAConditionalOperand) {
  // The rule's own check: the two forms that caused the bug are found, plain values are not.
  EXPECT_EQ(
      callsInConditionalOperands("r = mode == 0u ? sommStateUV(a, t, u, v) : sommState(a, t, i);").size(),
      1u);
  EXPECT_EQ(callsInConditionalOperands("uint x = w != 0u ? sommBits(blob, 0u, w) : 0u;").size(), 1u);
  EXPECT_TRUE(callsInConditionalOperands("uint f = s <= 26u ? mant << (26u - s) : mant >> min(s - 26u, 31u);")
                  .empty());
  const std::string kernels = std::string(SOMM_SHADER_DIR) + "/../src/gpu/kernels/";
  for (const std::string& path :
       {std::string(SOMM_SHADER_DIR) + "/somm_lookup.inc", std::string(SOMM_SHADER_DIR) + "/somm.glsl",
        std::string(SOMM_SHADER_DIR) + "/somm.hlsl", kernels + "check.comp", kernels + "check.hlsl",
        std::string(SOMM_SHADER_DIR) + "/examples/anyhit_software_micromap.rahit",
        std::string(SOMM_SHADER_DIR) + "/examples/anyhit_succinct_tree.rahit"}) {
    const std::string src = readFile(path);
    ASSERT_FALSE(src.empty()) << path;
    for (const std::string& stmt : callsInConditionalOperands(src)) ADD_FAILURE() << path << ":" << stmt;
  }
}

}  // namespace
