// SPDX-License-Identifier: MIT
// somm query FILE.somm --geometry G --triangle T: `u v` per line on stdin → the micro-triangle state per
// line.
#include <string>

#include "command.h"
#include "encodings.h"
#include "somm/gltf.h"
#include "somm/somm_file.h"

namespace {

struct Options {
  std::string path;
  uint64_t geometry = 0;
  uint64_t triangle = 0;
  std::string encoding = "flat";
};

int run(const Options& o) {
  using namespace somm::cli;
  auto file = somm::readMicromapFile(o.path);  // .somm or glTF (EXT_mesh_opacity_micromap)
  if (!file) {
    printError("query", file.error().message);
    return kExitFailure;
  }
  const somm::SommFile& f = *file;
  if (o.geometry >= f.geometries.size()) {
    printError("query", "--geometry " + std::to_string(o.geometry) + " is out of range: " + o.path + " has " +
                            std::to_string(f.geometries.size()) + " geometries");
    return kExitUsage;
  }
  const somm::GeometryInfo& g = f.geometries[o.geometry];
  const uint32_t geometry = uint32_t(o.geometry);
  if (o.triangle >= g.triangleCount) {
    printError("query", "--triangle " + std::to_string(o.triangle) + " is out of range: geometry " +
                            std::to_string(o.geometry) + " has " + std::to_string(g.triangleCount) +
                            " triangles");
    return kExitUsage;
  }
  const auto enc = somm::parseEncodingName(o.encoding);
  if (!enc) {
    printError("query", "--encoding '" + o.encoding + "' is not one of " + encodingNameList());
    return kExitUsage;
  }
  // The geometry's triangles live in its array at firstTriangle + T (a scene-wide array holds every geometry).
  auto encoded = loadEncoding(f, f.micromaps.geometries[geometry].array, *enc, o.path);
  if (!encoded) {
    printError("query", encoded.error().message);
    return kExitFailure;
  }
  const somm::EncodedArray& array = *encoded;
  const uint32_t t = f.micromaps.globalTriangle(geometry, uint32_t(o.triangle));
  const bool twoState = g.format == somm::Format::TwoState;
  LineReader in(stdin);
  Output out;
  std::string_view line;
  while (in.next(line)) {
    float u, v;
    bool blank;
    const bool ok = parseUVLine(line, u, v, blank);
    if (blank) continue;
    if (!ok) {
      out.flush();
      printError("query", "stdin line " + std::to_string(in.lineNumber()) +
                              ": expected two floats 'u v', got '" + excerpt(line) + "'");
      return kExitUsage;
    }
    somm::State s = array.stateUV(t, u, v);
    if (twoState) s = somm::toTwoState(s);
    out.putChar(char('0' + int(s)));
    out.putChar('\n');
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd =
      root.add_subcommand("query",
                          "Look up micro-triangle states. Reads one 'u v' pair per line from stdin "
                          "(barycentrics of vertices 1 and 2, "
                          "parsed like strtof) and prints the state a ray tracer reads: 0 transparent, 1 "
                          "opaque, 2 unknown-transparent, "
                          "3 unknown-opaque (special indices resolved; a 2-state geometry prints 0 or 1).");
  cmd->add_option("file", opts->path, ".somm file")->required();
  cmd->add_option("--geometry,-g", opts->geometry, "geometry index (see somm info)")->required();
  cmd->add_option("--triangle,-t", opts->triangle,
                  "triangle index within the geometry (0 .. its triangle count - 1)")
      ->required();
  cmd->add_option("--encoding,-e", opts->encoding,
                  "answer from this stored encoding (default flat): " + somm::cli::encodingNameList());
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("query", &setup);

}  // namespace
