// SPDX-License-Identifier: MIT
// Test helpers: OmmArrays and SommFiles built from random Micromaps (no baker needed).
#pragma once

#include <cstdint>
#include <random>
#include <string>

#include "somm/micromap.h"
#include "somm/omm_array.h"
#include "somm/somm_file.h"

namespace somm::testing {

// `triangles` micromaps at levels in [minLevel, maxLevel]: about a quarter uniform (special indices), a
// quarter repeating an earlier map, the rest random with runs (so that maps are neither uniform nor trivially
// equal).
inline OmmArray randomOmmArray(uint32_t triangles, Format format, uint32_t minLevel, uint32_t maxLevel,
                               uint32_t seed, std::vector<Micromap>* mapsOut = nullptr) {
  std::mt19937 rng(seed);
  OmmArrayBuilder b;
  std::vector<Micromap> kept;
  const uint32_t states = format == Format::TwoState ? 2 : 4;
  for (uint32_t t = 0; t < triangles; ++t) {
    const uint32_t kind = rng() % 4;
    Micromap m;
    if (kind == 1 && !kept.empty()) {
      m = kept[rng() % kept.size()];
    } else {
      const uint32_t level = minLevel + rng() % (maxLevel - minLevel + 1);
      m = Micromap(level, format, State(rng() % states));
      if (kind != 0) {
        State s = State(rng() % states);
        for (uint32_t i = 0; i < m.size(); ++i) {
          if (rng() % 5 == 0) s = State(rng() % states);
          m.set(i, s);
        }
        if (m.size() > 1 && m.uniformState())
          m.set(0, m.get(0) == State::Opaque ? State::Transparent : State::Opaque);
      }
      kept.push_back(m);
    }
    b.add(m);
    if (mapsOut) mapsOut->push_back(m);
  }
  return b.finish();
}

// One geometry as a bake produces it: metadata, its own OMM array and encodings of that array.
struct TestGeometry {
  GeometryInfo info;
  OmmArray flat;
  std::vector<EncodedSection> extra;
};

inline TestGeometry randomGeometry(const std::string& name, uint32_t triangles, Format format,
                                   uint32_t minLevel, uint32_t maxLevel, uint32_t seed,
                                   std::vector<Micromap>* mapsOut = nullptr) {
  TestGeometry g;
  g.info.name = name;
  g.info.material = name + "-material";
  g.info.triangleCount = triangles;
  g.info.format = format;
  g.info.minLevel = minLevel;
  g.info.maxLevel = maxLevel;
  g.info.cutoff = 0.25f + 0.125f * float(seed % 4);
  g.info.sampler = Sampler{Wrap(seed % 3), Wrap((seed + 1) % 3), Filter(seed % 2)};
  g.flat = randomOmmArray(triangles, format, minLevel, maxLevel, seed, mapsOut);
  for (const TriangleDescriptor& d : g.flat.descriptors)
    g.info.stats.microTriangles += microTriangleCount(d.subdivisionLevel);
  g.info.stats.unknownMicroTriangles = g.info.stats.microTriangles / 7;
  g.info.stats.invalidUvTriangles = triangles / 50;
  return g;
}

enum class Layout { PerGeometry, Scene };

// A file from per-geometry bakes: one array per geometry (with its encodings), or one scene-wide array (merged with
// mergeToSceneArray; the encodings of all geometries, first occurrence of an id wins, go to the array).
inline SommFile makeFile(std::vector<TestGeometry> geos, Layout layout) {
  SommFile f;
  std::vector<OmmArray> arrays;
  std::vector<std::vector<EncodedSection>> extras;
  for (TestGeometry& g : geos) {
    f.geometries.push_back(g.info);
    arrays.push_back(std::move(g.flat));
    extras.push_back(std::move(g.extra));
  }
  f.micromaps = perGeometryMicromaps(std::move(arrays));
  if (layout == Layout::PerGeometry) {
    f.encodings = std::move(extras);
  } else {
    f.micromaps = mergeToSceneArray(f.micromaps);
    f.encodings.assign(1, {});
    for (auto& extra : extras)
      for (EncodedSection& e : extra) {
        bool seen = false;
        for (const EncodedSection& x : f.encodings[0]) seen = seen || x.id == e.id;
        if (!seen) f.encodings[0].push_back(std::move(e));
      }
  }
  return f;
}

// Three geometries (4-state leaves, 2-state bark, an empty one) with a few opaque encoding sections.
inline SommFile sampleFile(uint32_t trianglesPerGeometry = 40, uint32_t seed = 1,
                           Layout layout = Layout::Scene) {
  std::vector<TestGeometry> g;
  g.push_back(randomGeometry("leaves", trianglesPerGeometry, Format::FourState, 0, 3, seed));
  g.push_back(randomGeometry("bark", trianglesPerGeometry, Format::TwoState, 1, 4, seed + 1));
  g.push_back(randomGeometry("empty", 0, Format::FourState, 2, 2, seed + 2));
  g[0].extra.push_back(EncodedSection{sectionId("dfs "), {1, 2, 3, 4, 5}});
  g[0].extra.push_back(EncodedSection{sectionId("rank"), {}});
  g[1].extra.push_back(EncodedSection{sectionId("hybr"), std::vector<uint8_t>(13, 0xab)});
  SommFile f = makeFile(std::move(g), layout);
  f.sourcePath = "data/scene.gltf";
  f.toolVersion = "somm test";
  f.bakeOptions = {{"level", "3"}, {"format", "4"}, {"filter", "auto"}};
  return f;
}

// One geometry in its own array.
inline SommFile singleGeometryFile(TestGeometry g) {
  std::vector<TestGeometry> v;
  v.push_back(std::move(g));
  return makeFile(std::move(v), Layout::PerGeometry);
}

}  // namespace somm::testing
