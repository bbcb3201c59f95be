// SPDX-License-Identifier: MIT
// The UV-only OBJ load (LoadOptions::loadPositions = false: tinyobjloader's callback parser, or the full load when
// the file is irregular) against the full load as the oracle: the same geometries (names, materials, vertex
// numbering, UVs, triangles), materials, textures, warnings, input files and instances, or the same error — on
// a corpus of small files that exercise shape splitting, materials, index forms and every irregular case, on the
// bundled OBJ and on the real scenes in ../shared/assets/foliage when present.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "scene/loaders.h"
#include "scene_test_util.h"
#include "somm/scene.h"

namespace {

using scenetest::TempDir;
using scenetest::writeFile;

// Bitwise equality of two float arrays (NaN payloads included).
bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

bool sameTexture(const std::shared_ptr<const somm::AlphaTexture>& a,
                 const std::shared_ptr<const somm::AlphaTexture>& b) {
  if (!a || !b) return !a && !b;
  return a->width == b->width && a->height == b->height && a->values() == b->values();
}

// Loads `path` both ways and expects the same outcome; returns the full load's geometry count (-1: an error).
int expectSameLoad(const std::string& path) {
  SCOPED_TRACE(path);
  somm::LoadOptions full, uv;
  uv.loadPositions = false;
  const somm::Result<somm::Scene> a = somm::loadScene(path, full);
  const somm::Result<somm::Scene> b = somm::loadScene(path, uv);
  EXPECT_EQ(a.ok(), b.ok());
  if (!a.ok() || !b.ok()) {
    if (!a.ok() && !b.ok()) {
      EXPECT_EQ(a.error().message, b.error().message);
    }
    return -1;
  }
  EXPECT_EQ(a->warnings, b->warnings);
  EXPECT_EQ(a->inputFiles, b->inputFiles);
  EXPECT_EQ(a->sourcePath, b->sourcePath);
  EXPECT_EQ(a->geometries.size(), b->geometries.size());
  for (size_t g = 0; g < std::min(a->geometries.size(), b->geometries.size()); ++g) {
    const somm::Geometry &x = a->geometries[g], &y = b->geometries[g];
    EXPECT_EQ(x.name, y.name) << g;
    EXPECT_EQ(x.material, y.material) << g;
    EXPECT_TRUE(sameBits(x.uvs, y.uvs)) << g;
    EXPECT_EQ(x.indices, y.indices) << g;
    EXPECT_EQ(x.positions.size(), x.uvs.size() / 2 * 3) << g;
    EXPECT_TRUE(y.positions.empty()) << g;
  }
  EXPECT_EQ(a->materials.size(), b->materials.size());
  for (size_t m = 0; m < std::min(a->materials.size(), b->materials.size()); ++m) {
    const somm::Material &x = a->materials[m], &y = b->materials[m];
    EXPECT_EQ(x.name, y.name) << m;
    EXPECT_EQ(x.alphaMode, y.alphaMode) << m;
    EXPECT_EQ(x.alphaCutoff, y.alphaCutoff) << m;
    EXPECT_EQ(x.alphaSource, y.alphaSource) << m;
    EXPECT_EQ(x.sampler.wrapS, y.sampler.wrapS) << m;
    EXPECT_EQ(x.sampler.wrapT, y.sampler.wrapT) << m;
    EXPECT_EQ(x.sampler.filter, y.sampler.filter) << m;
    EXPECT_EQ(x.baseColorFactor, y.baseColorFactor) << m;
    EXPECT_TRUE(sameTexture(x.alpha, y.alpha)) << m;
    EXPECT_EQ(bool(x.baseColor), bool(y.baseColor)) << m;
  }
  EXPECT_EQ(a->instances.size(), b->instances.size());
  return int(a->geometries.size());
}

const char* kMtl =
    "newmtl leaf\nKd 1 1 1\nmap_Kd leaf.png\n"
    "newmtl bark\nKd 0.5 0.4 0.3\n"
    "newmtl leaf\nKd 0 0 0\n";  // a second definition of a name: the first one is used

// m.mtl (kMtl) and the 2×2 RGBA leaf texture its materials name, in `dir`.
void writeMaterials(TempDir& dir) {
  scenetest::writePng8(dir.file("leaf.png"), 2, 2, 4,
                       {255, 0, 0, 255, 0, 255, 0, 0, 0, 0, 255, 128, 9, 9, 9, 64});
  writeFile(dir.file("m.mtl"), kMtl);
}

// Whether `path` loads through the UV-only callback parse (not irregular, no error); `nonFinite`: its count of
// non-finite position components in the vertices.
bool takesCallbackParse(const std::string& path, uint64_t* nonFinite = nullptr) {
  bool irregular = false;
  uint64_t count = 0;
  const bool ok = somm::detail::loadObjUvOnly(path, somm::LoadOptions{}, irregular, count).ok();
  if (nonFinite) *nonFinite = count;
  return ok && !irregular;
}

struct Case {
  const char* name;
  std::string text;
  bool regular = true;  // the callback parse serves it (else the full load does)
};

std::vector<Case> corpus() {
  const std::string v =
      "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 0\n"
      "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 0.25 0.75 0.5\nvn 0 0 1\n";
  return {
      {"plain", v + "usemtl leaf\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"},
      {"polygon fan", v + "usemtl leaf\nf 1/1 2/2 3/3 4/4 5/5\n"},
      {"index forms", v + "usemtl leaf\nf 1 2 3\nf 1/1/1 2/2/1 3/3/1\nf 1//1 2//1 4//1\nf 1/5 2 3/3\n"},
      {"negative indices",
       v + "usemtl leaf\nf -5/-5 -4/-4 -3/-3\nv 3 3 3\nvt 0.5 0.5\nf -1/-1 -2/-2 -3/-3\n"},
      {"default material first", v + "f 1/1 2/2 3/3\nusemtl leaf\nf 1/1 3/3 4/4\nusemtl bark\nf 1 2 3\n"},
      {"materials back and forth",
       v + "usemtl leaf\nf 1/1 2/2 3/3\nusemtl bark\nf 1 2 4\nusemtl leaf\nf 2/2 3/3 4/4\nusemtl leaf\n"
           "f 1/1 2/2 4/4\n"},
      {"groups and objects",
       v + "g a\nusemtl leaf\nf 1/1 2/2 3/3\ng a\nf 1/1 3/3 4/4\no obj one\nf 1 2 3\ng\t b  c \nusemtl bark\n"
           "f 1 2 3\no empty\no\tnext  \nf 2 3 4\n"},
      {"shapes without faces", v + "g a\ng b\no c\nusemtl leaf\ng d\nf 1/1 2/2 3/3\ng e\n"},
      {"unnamed shapes after named ones", v + "usemtl leaf\nf 1 2 3\ng a\nf 1 2 3\no \nf 1 2 4\n"},
      {"crlf and tabs",
       "mtllib m.mtl\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nvt 0 0\r\nvt 1 0\r\nvt 1 1\r\n"
       "usemtl leaf\r\n\tf\t1/1  2/2\t3/3 \r\n# comment\r\n\r\ns 1\r\nf 1/1 2/2 3/3\r\n"},
      {"usemtl trailing space", v + "usemtl leaf \nf 1/1 2/2 3/3\nusemtl  bark\t\nf 1 2 3\n"},
      {"non-finite positions and uvs",
       v + "v nan 0 inf\nvt nan 0\nusemtl leaf\nf 6/6 2/2 3/3\nf 1/6 6/2 3/1\n"},
      {"cr line ends",
       "mtllib m.mtl\rv 0 0 0\rv 1 0 0\rv 1 1 0\rvt 0 0\rvt 1 0\rvt 1 1\rusemtl leaf\r"
       "f 1/1 2/2 3/3\rg x\rf 1 2 3"},
      {"no final newline", v + "usemtl leaf\nf 1/1 2/2 3/3"},
      // Position numbers the scan drops (surely finite) or leaves to the parser (an exponent above 9, a run of
      // more than 15 digits, other text): the same vertices and non-finite counts either way.
      {"position number forms",
       v + "v 1e5 -2.5E-3 .5\nv\t+1 -.25 3.\nv 1e-300 1E+9 -0.0 1\nv 1e10 1234567890123456 0\nv 1e999 0 "
           "-1e99\n"
           "v 0x10 1 2\nv\nv 1.5\nusemtl leaf\nf 6/1 7/2 8/3\nf 9 10 11\nf -1 -2 -3\nf 12/1 11/2 6/3\n"},
      // Texture coordinate forms (compared bit for bit).
      {"texture coordinate forms",
       v + "vt 0.1 0.7\nvt -0.25 1.\nvt 0.1234567 0.9999999 0.5 junk\nvt 0.12345678 0.3\nvt "
           "123456789012345.5 -0\n"
           "vt 1234567890123456 0\nvt 1e-3 0.5\nvt\t.5 -.5\nvt +0.5 0.5\nvt 0.5abc 0\nvt 0.3\nvt\nvt \n"
           "vt 0.33333 0.66667\nvt 1e12345678901234567890 0.5\nvt 1.5 2e-99999999999\n"
           "usemtl leaf\nf 1/6 2/7 3/8\nf 1/9 2/10 3/11\nf 1/12 2/13 3/14\nf 1/15 2/16 "
           "3/17\n"
           "f 1/18 2/18 3/17\nf 1/19 2/20 3/19\n"},
      // Face forms the scan reads itself, and forms it leaves to the parser (more than 9 digits in a field).
      {"face forms", v + "usemtl leaf\nf 1/1/1 2//1 3/3\tf_junk_is_not_here\n", false},
      {"face field lengths", v + "usemtl leaf\nf 0000000001/1 2/0000000002 3\nf 000000001/00001 "
                                 "-1/-1/-1\t-2//-1  \nf -0005 -0004 -0003\n"},
      // Irregular: the full load decides (warnings, errors, elements the callback parser reads differently).
      {"unknown material", v + "usemtl nothere\nf 1/1 2/2 3/3\n", false},
      {"degenerate face", v + "usemtl leaf\nf 1/1 2/2\nf 1/1 2/2 3/3\n", false},
      {"empty face", v + "usemtl leaf\nf \nf 1/1 2/2 3/3\n", false},
      {"lines and points", v + "usemtl leaf\nl 1 2\np 3\nf 1/1 2/2 3/3\no x\nl 1 2\no y\nf 1 2 3\n", false},
      {"skin weights", v + "vw 1 0 0.5\nusemtl leaf\nf 1/1 2/2 3/3\n", false},
      {"negative joint", v + "vw 1 -1 0.5\nf 1 2 3\n", false},
      {"four fields", v + "f 1/1/1/1 2 3\n", false},
      {"vw-like names", v + "vwx 1\nv 1 2 3\nusemtl leaf\nf 1/1 2/2 3/3\n"},
      {"usemtl glued", v + "usemtlleaf\nf 1/1 2/2 3/3\n", false},
      {"usemtl alone", v + "usemtl\nf 1/1 2/2 3/3\n", false},
      {"zero index", v + "f 0 1 2\n", false},
      {"zero texcoord", v + "f 1/0 2/1 3/2\n", false},
      {"zero normal", v + "f 1//0 2//1 3//1\n", false},
      {"junk in face", v + "f 1 2 3 # tri\n", false},
      {"plus sign", v + "f +1 2 3\n", false},
      {"trailing slash", v + "f 1/ 2/ 3/\n", false},
      {"cr ends a face line", v + "f \r1 2 3\n", false},
      {"cr then a line element", v + "vt 0 0\rl 1 2\nusemtl leaf\nf 1/1 2/2 3/3\n", false},
      {"vertex out of range", v + "f 1 2 9\n", false},
      {"texcoord out of range", v + "f 1/9 2/1 3/1\n", false},
      {"normal out of range", v + "f 1//7 2//1 3//1\n", false},
      {"relative out of range", v + "f -9 1 2\n", false},
      {"forward reference", "mtllib m.mtl\nf 1 2 3\nv 0 0 0\nv 1 0 0\nv 1 1 0\n", false},
      {"index overflow", v + "f 1 2 2147483648\n", false},
      {"empty group name", v + "g \nusemtl leaf\nf 1/1 2/2 3/3\n", false},
      {"bare g (not a group line)", v + "g\nusemtl leaf\nf 1/1 2/2 3/3\n"},
      {"missing mtllib", "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", false},
      {"empty", ""},
  };
}

TEST(ObjUvOnly, SameAsFullLoadOnCorpus) {
  TempDir dir;
  writeMaterials(dir);
  int loaded = 0, failed = 0;
  for (const Case& c : corpus()) {
    SCOPED_TRACE(c.name);
    const std::string path = dir.file("c.obj");
    writeFile(path, c.text);
    (expectSameLoad(path) < 0 ? failed : loaded) += 1;
    bool irregular = false;
    uint64_t nonFinite = 0;
    (void)somm::detail::loadObjUvOnly(path, somm::LoadOptions{}, irregular, nonFinite);
    EXPECT_EQ(irregular, !c.regular);
  }
  // The corpus holds both kinds (a guard against a corpus that only errors).
  EXPECT_GE(loaded, 20);
  EXPECT_GE(failed, 8);
}

// The non-finite check of loadScene counts the positions a UV-only load does not keep.
TEST(ObjUvOnly, NonFinitePositionsStillWarn) {
  TempDir dir;
  // tinyobjloader reads "nan" as 0; an exponent out of range is infinite.
  writeFile(dir.file("n.obj"), "v 1e999 0 0\nv 1 -1e999 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1 2 3\n");
  somm::LoadOptions uv;
  uv.loadPositions = false;
  auto r = somm::loadScene(dir.file("n.obj"), uv);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->warnings.size(), 1u);
  // 6 vertices ((v, vt) pairs), 2 of which carry one non-finite component each twice over.
  EXPECT_EQ(r->warnings[0], "4 non-finite position and 0 non-finite texture coordinate components (NaN/inf)");
  ASSERT_EQ(r->geometries.size(), 1u);
  EXPECT_EQ(r->geometries[0].indices, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_TRUE(r->geometries[0].positions.empty());
}

// Lines across the 64 KiB chunks the file is read in: every position, normal and face line form at every offset
// around a chunk's end (the scan drops numbers and reads faces only within a chunk; a line that goes on beyond it
// is left whole to the parser), with LF and CR LF line ends.
TEST(ObjUvOnly, LinesAcrossReadChunks) {
  TempDir dir;
  writeMaterials(dir);
  for (const char* eol : {"\n", "\r\n"}) {
    SCOPED_TRACE(eol[0] == '\r' ? "CR LF" : "LF");
    std::string text = std::string("mtllib m.mtl") + eol + "usemtl leaf" + eol;
    uint32_t positions = 0, uvs = 0, faces = 0;
    for (uint32_t k = 0; text.size() < 300000; ++k) {
      // Lines of many lengths, so that chunk ends fall at every place in them.
      const std::string pad(k % 23, '0');
      text += "v " + std::to_string(k % 97) + "." + pad + "5 -" + std::to_string(k % 13) + ".25 1e-" +
              std::to_string(k % 4) + eol;
      text += "vt 0." + std::to_string(k % 89) + " 0." + std::to_string(k % 71) + eol;
      text += std::string("vn 0 ") + (k % 3 ? "1" : "1.0000000000000000001") + " 0" + eol;
      ++positions, ++uvs;
      if (positions >= 3) {
        const std::string a = std::to_string(positions), b = std::to_string(positions - 1),
                          c = std::to_string(positions - 2);
        switch (k % 4) {
          case 0:
            text += "f " + a + "/" + std::to_string(uvs) + " " + b + "/" + std::to_string(uvs - 1) + " " + c +
                    "/1" + eol;
            break;
          case 1:
            text += "f -1/-1/-1 -2/-2/-2 -3/-3/-1" + std::string(k % 7, ' ') + eol;
            break;
          case 2:
            text += "f\t" + a + "//1\t" + b + "//1 " + pad + c + "//1 " + a + "//2" + eol;
            break;
          default:
            text += "f " + a + " " + b + " " + c + eol;
            break;
        }
        ++faces;
      }
    }
    const std::string path = dir.file("chunks.obj");
    writeFile(path, text);
    somm::LoadOptions uv;
    uv.loadPositions = false;
    auto r = somm::loadScene(path, uv);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->geometries.size(), 1u);
    EXPECT_GT(r->geometries[0].indices.size(), size_t(3) * faces);  // quads fan into two triangles
    EXPECT_EQ(expectSameLoad(path), 1);
    EXPECT_TRUE(takesCallbackParse(path));
  }
}

// Runs of face lines with position lines between them (the scan drops both whole and the parser sees one "f 0" per
// run within a chunk): relative indices to the dropped positions, non-finite positions the parser reads among them,
// texture coordinates inside runs (read by the scan, or by the parser: the run breaks), runs broken by comments,
// materials and objects, at every offset around the chunk ends, LF and CR LF.
TEST(ObjUvOnly, RunsOfFacesAcrossReadChunks) {
  TempDir dir;
  writeMaterials(dir);
  for (const char* eol : {"\n", "\r\n"}) {
    SCOPED_TRACE(eol[0] == '\r' ? "CR LF" : "LF");
    std::string text = std::string("mtllib m.mtl") + eol + "vt 0.5 0.25" + eol + "vt 0.75 1" + eol;
    uint64_t positions = 0;
    for (uint32_t k = 0; text.size() < 400000; ++k) {
      const std::string pad(k % 19, '0');
      if (k % 11 == 0) text += "o block" + std::to_string(k) + eol;
      if (k % 7 == 0) text += std::string("usemtl ") + (k % 14 ? "leaf" : "bark") + eol;
      for (uint32_t i = 0; i < 3 + k % 4; ++i, ++positions)
        text += "v " + std::to_string(k % 53) + "." + pad + "5 " + std::to_string(i) + " -0.25" + eol;
      if (k % 5 == 0) text += "vt 0." + std::to_string(k % 97) + " 0.5" + eol;
      for (uint32_t f = 0; f < 1 + k % 9; ++f) {
        switch ((k + f) % 6) {
          case 0:  // absolute indices
            text += "f " + std::to_string(positions) + "/1 " + std::to_string(positions - 1) + "/2 " +
                    std::to_string(positions - 2) + "/1" + eol;
            break;
          case 1:  // a dropped position between two faces, named relatively
            text += "v 1." + pad + "5 2 3" + eol;
            ++positions;
            text += std::string("f -1/-1 -2/-2 -3/-1 -4/-2") + eol;
            break;
          case 2:  // a position the parser reads (not surely finite) inside a run
            text += std::string(k % 3 ? "v 1e99 0 0" : "v nan 1 2") + eol;
            ++positions;
            text += "f\t-1 " + std::to_string(positions - 1) + "  -3" + eol;
            break;
          case 3:  // a texture coordinate the scan reads, or (odd f) one it leaves to the parser
            text += (f % 2 ? "vt 0.5x 0." : "vt 0.125 0.") + std::to_string(f) + eol +
                    std::string("f -1/-1 -2/-1 -3/-2") + eol;
            break;
          case 4:  // a comment line: the run breaks
            text += "# c" + std::string(f, ' ') + eol + "f 1/1 2/2 " + std::to_string(positions) + "/1" + eol;
            break;
          default:
            text += "f " + std::to_string(positions - 2) + " -1 -2" + eol;
            break;
        }
      }
    }
    const std::string path = dir.file("runs.obj");
    writeFile(path, text);
    EXPECT_GT(expectSameLoad(path), 8);
    uint64_t nonFinite = 0;
    EXPECT_TRUE(takesCallbackParse(path, &nonFinite));
    EXPECT_GT(nonFinite, 0u);
  }
}

// Texture coordinates: 40,000 lines of random numbers of up to 15 integer and 20 fraction digits, bit for bit as the
// full load reads them.
TEST(ObjUvOnly, RandomTextureCoordinatesAsTheParserReadsThem) {
  TempDir dir;
  std::mt19937_64 rng(7);
  // The forms the scan reads itself — signs, a leading or trailing point, up to 20 fraction digits (weights past the
  // parser's table of 10^-k), exponents of 1-3 digits (subnormal, overflowing) — and some it leaves to the parser.
  auto number = [&] {
    const uint64_t form = rng() % 64;
    std::string t = form % 4 == 0 ? "-" : form % 16 == 1 ? "+" : "";
    const int intDigits = int(rng() % 16), fracDigits = int(rng() % (form % 8 == 2 ? 21 : 9));
    if (form % 16 != 3) t += intDigits == 0 ? "0" : std::to_string(1 + rng() % 9);
    for (int k = 1; k < intDigits; ++k) t += char('0' + rng() % 10);
    if (fracDigits > 0 || rng() % 8 == 0 || form % 16 == 3) t += '.';
    for (int k = 0; k < fracDigits || (form % 16 == 3 && k == 0); ++k) t += char('0' + rng() % 10);
    if (form % 8 == 5) {
      t += rng() % 2 ? 'e' : 'E';
      const uint64_t sign = rng() % 3;
      t += sign == 0 ? "-" : sign == 1 ? "+" : "";
      t += std::to_string(rng() % (rng() % 4 == 0 ? 1000 : 40));
    }
    if (form == 63) t += rng() % 2 ? "x" : "e";  // not a number the scan reads: the parser's
    return t;
  };
  std::string text = "v 0 0 0\nv 1 0 0\nv 1 1 0\n";
  const int n = 40000;
  for (int k = 0; k < n; ++k) {
    text += rng() % 8 ? "vt " : "vt\t ";
    text += number();
    text += rng() % 4 ? ' ' : '\t';
    text += number();
    if (rng() % 8 == 0) text += ' ', text += number();  // a third number, unused
    text += '\n';
  }
  for (int k = 1; k + 2 <= n; k += 3)
    text += "f 1/" + std::to_string(k) + " 2/" + std::to_string(k + 1) + " 3/" + std::to_string(k + 2) + "\n";
  const std::string path = dir.file("uv.obj");
  writeFile(path, text);
  EXPECT_EQ(expectSameLoad(path), 1);
  EXPECT_TRUE(takesCallbackParse(path));
}

TEST(ObjUvOnly, SameAsFullLoadOnBundledScene) {
  EXPECT_GT(expectSameLoad(std::string(SOMM_DATA_DIR) + "/redeclipse-tree01/tree01.obj"), 0);
}

TEST(ObjUvOnly, SameAsFullLoadOnRealScenes) {
  const char* env = std::getenv("SOMM_FOLIAGE_DIR");
  const std::string dir = env && *env ? env : SOMM_FOLIAGE_DIR;
  if (dir.empty() || !std::filesystem::exists(dir + "/torcs-forza/forza.obj"))
    GTEST_SKIP() << "no ../shared/assets/foliage (set SOMM_FOLIAGE_DIR)";
  std::vector<std::string> files = {dir + "/torcs-forza/forza.obj", dir + "/zeroad/flora-quarter.obj"};
  for (const char* sub : {"/redeclipse/obj", "/zeroad/meshes"})
    if (std::filesystem::is_directory(dir + sub))
      for (const auto& e : std::filesystem::directory_iterator(dir + sub))
        if (e.path().extension() == ".obj") files.push_back(e.path().string());
  for (const std::string& f : files) {
    EXPECT_GT(expectSameLoad(f), 0) << f;
    EXPECT_TRUE(takesCallbackParse(f)) << f;  // real files take the UV-only parse
  }
}

}  // namespace

namespace {

// Lines end at CR as well as LF for tinyobjloader: a face line after a lone CR is still checked for indices above
// 2^31 - 1 (which the parser would overflow), on both load paths.
TEST(ObjUvOnly, IndexOverflowAfterCrLineEnd) {
  TempDir dir;
  writeFile(dir.file("cr.obj"), "v 0 0 0\nv 1 0 0\nv 1 1 0\ns 1\rf 1 2 2147483648\n");
  for (bool positions : {true, false}) {
    somm::LoadOptions o;
    o.loadPositions = positions;
    auto r = somm::loadScene(dir.file("cr.obj"), o);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("index 2147483648 is out of range"), std::string::npos)
        << r.error().message;
  }
}

}  // namespace

namespace {

// glTF without positions: the POSITION accessor is read (and counted) but not stored; the rest is the full load.
TEST(ObjUvOnly, GltfSameAsFullLoadWithoutPositions) {
  for (const char* rel : {"/oak-tree/oaktree.gltf", "/alpha-blend-mode-test/AlphaBlendModeTest.gltf"})
    EXPECT_GT(expectSameLoad(std::string(SOMM_DATA_DIR) + rel), 0) << rel;
}

}  // namespace

namespace {

// The textures of a material library are decoded as soon as the library has been read, while the OBJ is still being
// parsed. A later library may ask more of the same file (here: its red channel as map_d, after the first asked for
// its alpha as map_Kd): the file is then decoded again for everything. Oracle: the same materials in one library
// (all needs known at once), at one and at two threads, with and without positions; the texels checked exactly.
TEST(ObjUvOnly, TexturesOfLaterLibrariesAndGrownNeeds) {
  TempDir dir;
  // 2x2 RGBA: red 255, 0, 0, 9; alpha 255, 0, 128, 64 (rows flipped on load: OBJ's v = 0 is the bottom row).
  scenetest::writePng8(dir.file("leaf.png"), 2, 2, 4,
                       {255, 0, 0, 255, 0, 255, 0, 0, 0, 0, 255, 128, 9, 9, 9, 64});
  scenetest::writePng8(dir.file("bark.png"), 1, 1, 2, {10, 20});
  // bark.png: first as c's map_d (its alpha), then as d's map_Kd (colour and alpha).
  const std::string a = "newmtl a\nmap_Kd leaf.png\nnewmtl c\nmap_d bark.png\n";
  const std::string b = "newmtl b\nmap_d -imfchan r leaf.png\nnewmtl d\nmap_Kd bark.png\n";
  writeFile(dir.file("m1.mtl"), a);
  writeFile(dir.file("m2.mtl"), b);
  writeFile(dir.file("both.mtl"), a + b);
  const std::string body =
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl a\nf 1/1 2/2 3/3\nusemtl c\nf 1/1 2/2 3/3\n";
  const std::string tail = "usemtl b\nf 1/1 2/2 3/3\nusemtl d\nf 1/1 2/2 3/3\n";
  writeFile(dir.file("two.obj"), "mtllib m1.mtl\n" + body + "mtllib m2.mtl\n" + tail);
  writeFile(dir.file("one.obj"), "mtllib both.mtl\n" + body + tail);
  const std::vector<float> alphaOfA = {128 / 255.0f, 64 / 255.0f, 1.0f, 0.0f},
                           redOfB = {0.0f, 9 / 255.0f, 1.0f, 0.0f};
  for (size_t threads : {1, 2}) {
    tbb::global_control cap(tbb::global_control::max_allowed_parallelism, threads);
    for (bool positions : {false, true}) {
      SCOPED_TRACE(std::to_string(threads) + " threads, positions " + std::to_string(positions));
      somm::LoadOptions o;
      o.loadPositions = positions;
      auto two = somm::loadScene(dir.file("two.obj"), o);
      auto one = somm::loadScene(dir.file("one.obj"), o);
      ASSERT_TRUE(two.ok()) << two.error().message;
      ASSERT_TRUE(one.ok()) << one.error().message;
      ASSERT_EQ(two->materials.size(), 4u);
      ASSERT_EQ(one->materials.size(), 4u);
      for (size_t m = 0; m < 4; ++m) {
        EXPECT_EQ(two->materials[m].name, one->materials[m].name);
        EXPECT_TRUE(sameTexture(two->materials[m].alpha, one->materials[m].alpha)) << m;
        ASSERT_TRUE(two->materials[m].alpha) << m;
      }
      EXPECT_EQ(two->materials[0].alpha->values(), alphaOfA);
      EXPECT_EQ(two->materials[1].alpha->values(), std::vector<float>{20 / 255.0f});
      EXPECT_EQ(two->materials[2].alpha->values(), redOfB);
      EXPECT_EQ(two->materials[3].alpha->values(), std::vector<float>{20 / 255.0f});
      // d's colour: bark.png decoded again once d asked for it (c's task had not converted the colour).
      ASSERT_TRUE(two->materials[3].baseColor);
      ASSERT_TRUE(one->materials[3].baseColor);
      EXPECT_EQ(two->materials[3].baseColor->width, 1u);
      EXPECT_FALSE(two->materials[2].baseColor);
    }
  }
  // A texture that fails to decode fails the load with the material's name, however early it was started.
  writeFile(dir.file("bark.png"), "not a png");
  for (size_t threads : {1, 2}) {
    tbb::global_control cap(tbb::global_control::max_allowed_parallelism, threads);
    somm::LoadOptions o;
    o.loadPositions = false;
    auto r = somm::loadScene(dir.file("two.obj"), o);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("material 'c': texture '"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("bark.png"), std::string::npos) << r.error().message;
  }
}

}  // namespace
