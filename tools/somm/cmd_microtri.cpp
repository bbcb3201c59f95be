// SPDX-License-Identifier: MIT
// somm microtri --level L: micro-triangle index per line on stdin → its three vertices as integer grid coordinates.
#include <string>

#include "command.h"
#include "somm/bird.h"

namespace {

struct Options {
  uint32_t level = 0;
};

int run(const Options& o) {
  using namespace somm::cli;
  LineReader in(stdin);
  Output out;
  const uint64_t count = somm::microTriangleCount(o.level);
  std::string_view line;
  while (in.next(line)) {
    std::string_view rest = line;
    const std::string_view a = nextToken(rest);
    if (a.empty()) continue;
    uint64_t index = 0;
    if (!nextToken(rest).empty() || !parseUInt(a, index)) {
      out.flush();
      printError("microtri", "stdin line " + std::to_string(in.lineNumber()) + ": expected one index, got '" +
                                 excerpt(line) + "'");
      return kExitUsage;
    }
    if (index >= count) {
      out.flush();
      printError("microtri", "stdin line " + std::to_string(in.lineNumber()) + ": index " + std::string(a) +
                                 " is out of range for level " + std::to_string(o.level) + " (must be < " +
                                 std::to_string(count) + ")");
      return kExitUsage;
    }
    const somm::MicroTriangle t = somm::indexToMicroTriangle(uint32_t(index), o.level);
    for (int k = 0; k < 3; ++k) {
      out.putUInt(t.v[k].u);
      out.putChar(' ');
      out.putUInt(t.v[k].v);
      out.putChar(k == 2 ? '\n' : ' ');
    }
  }
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "microtri",
      "Print the vertices of micro-triangles. Reads one index per line from stdin and prints 'u0 v0 u1 v1 u2 "
      "v2': the "
      "vertices in the curve's winding as integer barycentric grid coordinates in units of 2^-level.");
  somm::cli::addRequiredLevel(cmd, opts->level);
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("microtri", &setup);

}  // namespace
