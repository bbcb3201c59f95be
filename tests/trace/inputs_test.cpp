// SPDX-License-Identifier: MIT
// Every input kind traces real geometry: OBJ, glTF, GLB, `somm gen-scene` output and (when present) the real
// foliage scenes. Each render must hit alpha-tested geometry (filter calls, texture tests, shadow rays), and
// omm4-flat with the real baker must be pixel-identical to `texture` on it, so the exactness check is never
// vacuous. Also: degenerate instance transforms are errors naming the instance / node.
#include <gtest/gtest.h>
#include <stb_image_write.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_util.h"
#include "somm/bake.h"
#include "somm/procedural.h"
#include "somm/scene.h"
#include "somm/trace.h"

namespace somm {
namespace {

using testing::runSomm;
using testing::TempDir;
using testing::writeFile;

// The real scenes (../shared/assets/foliage); empty when absent.
std::string foliageDir() {
  const char* env = std::getenv("SOMM_FOLIAGE_DIR");
  const std::string dir = env && *env ? env : SOMM_FOLIAGE_DIR;
  return std::filesystem::is_directory(dir) ? dir : std::string();
}

struct Traced {
  TraceCounters texture, omm4;
};

// Renders `texture` and omm4-flat (baked at `level` with the library baker) and checks that the render saw
// alpha-tested geometry and that the two images are identical.
Traced traceAndCheck(Scene s, const std::optional<Camera>& camera, uint32_t level = 4) {
  Traced out;
  auto scene = std::make_shared<const Scene>(std::move(s));
  auto world = TraceWorld::create(scene);
  EXPECT_TRUE(world.ok()) << (world.ok() ? "" : world.error().message);
  if (!world.ok()) return out;
  const Bounds& b = (*world)->bounds();
  EXPECT_LT(b.lower[0], b.upper[0]) << scene->sourcePath << ": empty bounds";
  RenderSettings rs;
  rs.width = 96;
  rs.height = 72;
  rs.camera = camera;
  const RenderResult ref = makeTextureTracer(*world).value()->render(rs);
  out.texture = ref.counters;
  EXPECT_GT(ref.counters.primaryHits, ref.counters.primaryRays / 20) << scene->sourcePath;
  EXPECT_GT(ref.counters.alphaTestedPixels, 0u) << scene->sourcePath;
  EXPECT_GT(ref.counters.filterCalls, 0u) << scene->sourcePath;
  EXPECT_GT(ref.counters.textureTests, 0u) << scene->sourcePath;
  EXPECT_GT(ref.counters.shadowRays, 0u) << scene->sourcePath;
  BakeOptions o;
  o.level = level;
  std::vector<OmmArray> perGeometry;
  for (const Geometry& g : scene->geometries) {
    auto baked = bakeGeometry(g, scene->materials[g.material], o);
    EXPECT_TRUE(baked.ok()) << (baked.ok() ? "" : baked.error().message);
    perGeometry.push_back(baked.ok() ? baked->array : OmmArray{});
  }
  MicromapSet m;
  m.flat4 =
      std::make_shared<const SceneMicromaps>(mergeToSceneArray(perGeometryMicromaps(std::move(perGeometry))));
  auto omm4 = makeTracer(*world, parseMethod("omm4-flat").value(), m);
  EXPECT_TRUE(omm4.ok()) << (omm4.ok() ? "" : omm4.error().message);
  if (!omm4.ok()) return out;
  const RenderResult r = (*omm4)->render(rs);
  out.omm4 = r.counters;
  EXPECT_EQ(r.image.rgba, ref.image.rgba) << scene->sourcePath;
  EXPECT_EQ(r.counters.primaryHits, ref.counters.primaryHits);
  EXPECT_EQ(r.counters.shadowRays, ref.counters.shadowRays);
  EXPECT_LT(r.counters.textureTests, ref.counters.textureTests) << scene->sourcePath;
  return out;
}

// A disc of alpha 1 on alpha 0, RGBA PNG.
void writeDiscPng(const std::string& path, int size) {
  std::vector<uint8_t> rgba(size_t(size) * size * 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const float dx = (x + 0.5f) / size - 0.5f, dy = (y + 0.5f) / size - 0.5f;
      uint8_t* p = rgba.data() + (size_t(y) * size + x) * 4;
      p[0] = 60;
      p[1] = 170;
      p[2] = 40;
      p[3] = dx * dx + dy * dy < 0.16f ? 255 : 0;
    }
  ASSERT_TRUE(stbi_write_png(path.c_str(), size, size, 4, rgba.data(), size * 4));
}

// Two crossed alpha-tested cards over an untextured ground.
std::string writeObjScene(const TempDir& d) {
  writeDiscPng(d.file("leaf.png"), 64);
  writeFile(d.file("s.mtl"),
            "newmtl leaf\nKd 1 1 1\nmap_Kd leaf.png\n\n"
            "newmtl ground\nKd 0.5 0.4 0.3\n");
  writeFile(d.file("s.obj"),
            "mtllib s.mtl\n"
            "v -1 0 0\nv 1 0 0\nv 1 2 0\nv -1 2 0\n"
            "v 0 0 -1\nv 0 0 1\nv 0 2 1\nv 0 2 -1\n"
            "v -3 0 -3\nv 3 0 -3\nv 3 0 3\nv -3 0 3\n"
            "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "usemtl leaf\nf 1/1 2/2 3/3 4/4\nf 5/1 6/2 7/3 8/4\n"
            "usemtl ground\nf 9/1 12/4 11/3 10/2\n");
  return d.file("s.obj");
}

TEST(TraceInputs, ObjScene) {
  TempDir d;
  auto s = loadScene(writeObjScene(d));
  ASSERT_TRUE(s.ok()) << s.error().message;
  for (const Instance& i : s->instances) EXPECT_TRUE(isUsableTransform(i.transform));
  traceAndCheck(std::move(s).value(), std::nullopt);
}

// The bundled real tree (data/redeclipse-tree01), with a camera inside the crown as in `make demo`.
TEST(TraceInputs, BundledRedEclipseTree) {
  auto s = loadScene(std::string(SOMM_DATA_DIR) + "/redeclipse-tree01/tree01.obj");
  ASSERT_TRUE(s.ok()) << s.error().message;
  for (Material& m : s->materials) m.alphaCutoff = 0.7f;
  const Traced t =
      traceAndCheck(std::move(s).value(), Camera{{0, -260, 200}, {30, 0, 250}, {0, 0, 1}, 1.05f});
  EXPECT_GT(t.texture.alphaTestedPixels, 96u * 72u / 2);
}

TEST(TraceInputs, GltfScene) {
  auto s = loadScene(std::string(SOMM_DATA_DIR) + "/oak-tree/oaktree.gltf");
  ASSERT_TRUE(s.ok()) << s.error().message;
  traceAndCheck(std::move(s).value(), std::nullopt);
}

TEST(TraceInputs, ProceduralScenesAndTheirGlb) {
  for (Scene s :
       {makeLeafCardScene(200, 3), makeQuadScene(std::make_shared<const AlphaTexture>(makeDiscTexture(64)),
                                                 Sampler{}, 0.5f, {0, 0, 1, 1})}) {
    for (const Instance& i : s.instances) EXPECT_TRUE(isUsableTransform(i.transform));
    TempDir d;
    ASSERT_TRUE(writeGlb(s, d.file("p.glb")).ok());
    auto back = loadScene(d.file("p.glb"));
    ASSERT_TRUE(back.ok()) << back.error().message;
    traceAndCheck(s, std::nullopt);
    traceAndCheck(std::move(back).value(), std::nullopt);
  }
}

TEST(TraceInputs, GenSceneOutputRendersWithTheCli) {
  TempDir d;
  for (const std::string& kind :
       {std::string("leaf-cards --cards 300"), std::string("quad --texture leaf")}) {
    ASSERT_EQ(runSomm("gen-scene " + kind + " -o " + d.file("g.glb")).exitCode, 0);
    auto s = loadScene(d.file("g.glb"));
    ASSERT_TRUE(s.ok()) << s.error().message;
    traceAndCheck(std::move(s).value(), std::nullopt);
    const auto r =
        runSomm("render " + d.file("g.glb") + " --width 64 --height 48 -o " + d.file("g.png") + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_GT(j["filter_calls"].get<uint64_t>(), 0u) << kind;
    EXPECT_GT(j["shadow_rays"].get<uint64_t>(), 0u) << kind;
    EXPECT_GT(j["alpha_tested_pixels"].get<uint64_t>(), 0u) << kind;
  }
  const auto o =
      runSomm("render " + writeObjScene(d) + " --width 64 --height 48 -o " + d.file("o.png") + " --json");
  ASSERT_EQ(o.exitCode, 0) << o.err;
  EXPECT_GT(nlohmann::json::parse(o.out)["filter_calls"].get<uint64_t>(), 0u);
}

TEST(TraceInputs, DegenerateTransformsAreErrors) {
  Scene s = makeLeafCardScene(10, 1);
  s.instances[0].transform = {};
  auto w = TraceWorld::create(std::make_shared<const Scene>(s));
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().message.find("instance 0"), std::string::npos) << w.error().message;
  EXPECT_NE(w.error().message.find("singular"), std::string::npos) << w.error().message;
  s.instances[0].transform = Instance{}.transform;
  s.instances[0].transform[5] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(TraceWorld::create(std::make_shared<const Scene>(s)).ok());
  s.instances[0].transform = {1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // two equal columns
  EXPECT_FALSE(isUsableTransform(s.instances[0].transform));
  EXPECT_TRUE(isUsableTransform({0.001f, 0, 0, 0, 0, 0.001f, 0, 0, 0, 0, 0.001f, 0, 5, 5, 5, 1}));

  // glTF: a node whose matrix is zero is an error naming the node.
  TempDir d;
  Scene q =
      makeQuadScene(std::make_shared<const AlphaTexture>(makeDiscTexture(16)), Sampler{}, 0.5f, {0, 0, 1, 1});
  ASSERT_TRUE(writeGlb(q, d.file("q.glb")).ok());
  std::string glb = testing::readFile(d.file("q.glb"));
  const std::string identity = "\"matrix\":[1.0,0.0,0.0,0.0,0.0,1.0,0.0,0.0,0.0,0.0,1.0,0.0,0.0,0.0,0.0,1.0]";
  const size_t at = glb.find(identity);
  ASSERT_NE(at, std::string::npos) << "the GLB writer writes the identity as an explicit matrix";
  glb.replace(at, identity.size(),
              "\"matrix\":[0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,1.0]");
  writeFile(d.file("z.glb"), glb);
  auto z = loadScene(d.file("z.glb"));
  ASSERT_FALSE(z.ok());
  EXPECT_NE(z.error().message.find("node 0"), std::string::npos) << z.error().message;
  EXPECT_NE(z.error().message.find("z.glb"), std::string::npos) << z.error().message;
}

// A material is traced as alpha-tested only if some triangle of it can fail the alpha test (the baker's
// classification): an RGBA map_Kd whose alpha never falls below the cutoff is opaque geometry without a filter.
TEST(TraceInputs, MaterialsThatCannotFailAreTracedOpaque) {
  TempDir d;
  writeObjScene(d);  // leaf.png (a disc) for material 'leaf'
  std::vector<uint8_t> rgba(16 * 16 * 4, 200);
  for (size_t i = 3; i < rgba.size(); i += 4) rgba[i] = 250;  // alpha 0.98 everywhere
  ASSERT_TRUE(stbi_write_png(d.file("solid.png").c_str(), 16, 16, 4, rgba.data(), 16 * 4));
  writeFile(d.file("s.mtl"), "newmtl leaf\nKd 1 1 1\nmap_Kd solid.png\n\nnewmtl ground\nKd 0.5 0.4 0.3\n");
  auto s = loadScene(d.file("s.obj"));
  ASSERT_TRUE(s.ok()) << s.error().message;
  ASSERT_TRUE(s->materials[0].alphaTested());
  auto canFail = materialsThatCanFailAlphaTest(*s);
  ASSERT_TRUE(canFail.ok());
  EXPECT_EQ(*canFail, (std::vector<bool>{false, false}));
  Scene failing = *s;
  failing.materials[0].alphaCutoff = 0.99f;  // now every texel fails
  EXPECT_EQ(materialsThatCanFailAlphaTest(failing).value(), (std::vector<bool>{true, false}));
  auto w = TraceWorld::create(std::make_shared<const Scene>(std::move(s).value()));
  ASSERT_TRUE(w.ok());
  EXPECT_EQ((*w)->alphaTestedMaterials(), 0u);
  const RenderResult r = makeTextureTracer(*w).value()->render(RenderSettings{});
  EXPECT_GT(r.counters.primaryHits, 0u);
  EXPECT_EQ(r.counters.filterCalls, 0u);
  const auto info = runSomm("scene-info " + d.file("s.obj") + " --json");
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["alpha_tested_triangles"], 4);
  EXPECT_EQ(j["can_fail_triangles"], 0);
  EXPECT_EQ(j["alpha_tested_materials"], 1);
  EXPECT_EQ(j["can_fail_materials"], 0);
}

// A missing texture that cannot carry alpha (a map_Kd JPEG) is a warning and the material is drawn opaque; a
// missing PNG (which could carry alpha) stays an error naming the material and the file.
TEST(TraceInputs, MissingJpegIsAWarningMissingPngAnError) {
  TempDir d;
  writeObjScene(d);
  writeFile(d.file("s.mtl"), "newmtl leaf\nKd 1 1 1\nmap_Kd gone.jpg\n\nnewmtl ground\nKd 0.5 0.4 0.3\n");
  auto s = loadScene(d.file("s.obj"));
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_FALSE(s->materials[0].alphaTested());
  ASSERT_FALSE(s->warnings.empty());
  EXPECT_NE(s->warnings.back().find("gone.jpg"), std::string::npos) << s->warnings.back();
  writeFile(d.file("s.mtl"), "newmtl leaf\nKd 1 1 1\nmap_Kd gone.png\n\nnewmtl ground\nKd 0.5 0.4 0.3\n");
  auto e = loadScene(d.file("s.obj"));
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("gone.png"), std::string::npos) << e.error().message;
  EXPECT_NE(e.error().message.find("leaf"), std::string::npos) << e.error().message;
  // map_d missing: an error even when it is a JPEG (it is the alpha).
  writeFile(d.file("s.mtl"), "newmtl leaf\nKd 1 1 1\nmap_d gone.jpg\n");
  EXPECT_FALSE(loadScene(d.file("s.obj")).ok());
}

// The real scenes, with cameras that look into the foliage.
TEST(TraceInputs, RealFoliageScenes) {
  const std::string dir = foliageDir();
  if (dir.empty()) GTEST_SKIP() << "no ../shared/assets/foliage (set SOMM_FOLIAGE_DIR)";
  struct Case {
    std::string path;
    float cutoff;  // < 0: the materials' own
    std::optional<Camera> camera;
  };
  const Case cases[] = {
      {dir + "/redeclipse/obj/tree01.obj", 0.7f, std::nullopt},
      {dir + "/zeroad/flora-quarter.obj", -1.0f, std::nullopt},
      {dir + "/torcs-forza/forza.obj", -1.0f, Camera{{450, 12, -860}, {348, 7, -868}, {0, 1, 0}, 1.05f}},
  };
  for (const Case& c : cases) {
    if (!std::filesystem::exists(c.path)) {
      ADD_FAILURE() << c.path << " missing from " << dir;
      continue;
    }
    auto s = loadScene(c.path);
    ASSERT_TRUE(s.ok()) << s.error().message;
    if (c.cutoff >= 0)
      for (Material& m : s->materials) m.alphaCutoff = c.cutoff;
    const Traced t = traceAndCheck(std::move(s).value(), c.camera);
    EXPECT_GT(t.texture.alphaTestedPixels, 96u * 72u / 20)
        << c.path << ": the camera must look into the foliage";
  }
}

}  // namespace
}  // namespace somm
