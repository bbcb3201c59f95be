// SPDX-License-Identifier: MIT
// somm gen-scene leaf-cards|quad ... -o OUT.glb: writes a deterministic procedural scene
// (include/somm/procedural.h) as a .glb, for demos, CLI tests and benchmarks on scenes of any size.
#include <algorithm>
#include <memory>
#include <string>

#include "command.h"
#include "somm/io.h"
#include "somm/procedural.h"
#include "somm/scene.h"

namespace {

struct Options {
  std::string kind;
  std::string out;
  uint32_t cards = 1000;
  uint32_t seed = 1;
  std::string texture = "leaf";
  uint32_t size = 0;  // 0: the kind's default (quad 256, leaf-cards 512)
  std::string filter = "linear";
  std::string wrap = "repeat";
  float cutoff = 0.5f;
  float uvScale = 1.0f;
};

int run(const Options& o) {
  using namespace somm::cli;
  // An output that exists and is not a regular file (/dev/null, a FIFO, a directory) is a usage error, found
  // before the scene is built (a million cards take seconds).
  if (somm::Status s = somm::checkOutputPath(o.out, {}); !s) {
    printError("gen-scene", s.error().message);
    return kExitUsage;
  }
  somm::Scene scene;
  if (o.kind == "leaf-cards") {
    scene = somm::makeLeafCardScene(o.cards, o.seed, o.size ? o.size : 512);
  } else {
    const uint32_t size = o.size ? o.size : 256;
    somm::AlphaTexture t;
    if (o.texture == "disc")
      t = somm::makeDiscTexture(size);
    else if (o.texture == "noise")
      t = somm::makeNoiseTexture(size, o.seed, std::max<uint32_t>(1, size / 16));
    else if (o.texture == "checker")
      t = somm::makeCheckerTexture(size, std::max<uint32_t>(1, size / 8));
    else if (o.texture == "specks")
      t = somm::makeSpeckTexture(size, std::max<uint32_t>(1, size * size / 256), o.seed);
    else if (o.texture == "stripes")
      t = somm::makeStripeTexture(size, std::max<uint32_t>(2, size / 8));
    else
      t = somm::makeLeafTexture(size);
    somm::Sampler smp;
    smp.filter = o.filter == "nearest" ? somm::Filter::Nearest : somm::Filter::Linear;
    smp.wrapS = smp.wrapT = o.wrap == "clamp"    ? somm::Wrap::ClampToEdge
                            : o.wrap == "mirror" ? somm::Wrap::MirroredRepeat
                                                 : somm::Wrap::Repeat;
    scene = somm::makeQuadScene(std::make_shared<const somm::AlphaTexture>(std::move(t)), smp, o.cutoff,
                                {0, 0, o.uvScale, o.uvScale});
  }
  const somm::Status st = somm::writeGlb(scene, o.out);
  if (!st.ok()) {
    printError("gen-scene", st.error().message);
    return kExitFailure;
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "gen-scene",
      "Write a deterministic procedural scene as .glb: 'leaf-cards' (random overlapping alpha-tested leaf "
      "cards, 2 "
      "triangles each, one geometry) or 'quad' (one alpha-tested quad with a procedural texture).");
  cmd->add_option("kind", opts->kind, "leaf-cards | quad")
      ->required()
      ->check(CLI::IsMember({"leaf-cards", "quad"}));
  cmd->add_option("-o,--output", opts->out, "output .glb")->required();
  cmd->add_option("--cards", opts->cards, "leaf-cards: number of cards")->check(CLI::Range(1u, 1000000u));
  cmd->add_option("--seed", opts->seed, "random seed");
  cmd->add_option("--texture", opts->texture, "quad: disc | noise | checker | specks | stripes | leaf")
      ->check(CLI::IsMember({"disc", "noise", "checker", "specks", "stripes", "leaf"}));
  cmd->add_option("--size", opts->size,
                  "texture size in texels (quad: default 256; leaf-cards: the leaf atlas, default 512)")
      ->check(CLI::Range(1u, 16384u));
  cmd->add_option("--filter", opts->filter, "quad: nearest | linear")
      ->check(CLI::IsMember({"nearest", "linear"}));
  cmd->add_option("--wrap", opts->wrap, "quad: repeat | clamp | mirror")
      ->check(CLI::IsMember({"repeat", "clamp", "mirror"}));
  cmd->add_option("--cutoff", opts->cutoff, "quad: alpha cutoff")
      ->check(CLI::Range(0.0f, 1.0f) & somm::cli::NotNan);
  cmd->add_option("--uv-scale", opts->uvScale, "quad: UVs span [0, K]² (K > 1 exercises the wrap mode)")
      ->check(CLI::Range(-1e6f, 1e6f) & somm::cli::NotNan);
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("gen-scene", &setup);

}  // namespace
