// SPDX-License-Identifier: MIT
// somm index --level L: `u v` per line on stdin → bird-curve index per line on stdout.
#include <string>
#include <vector>

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
  constexpr size_t kBatch = 4096;
  std::vector<float> us, vs;
  std::vector<uint32_t> idx(kBatch);
  us.reserve(kBatch);
  vs.reserve(kBatch);
  auto drain = [&] {
    somm::baryToIndexBatch(us.data(), vs.data(), us.size(), o.level, idx.data());
    for (size_t i = 0; i < us.size(); ++i) {
      out.putUInt(idx[i]);
      out.putChar('\n');
    }
    us.clear();
    vs.clear();
  };
  std::string_view line;
  while (in.next(line)) {
    float u, v;
    bool blank;
    const bool ok = parseUVLine(line, u, v, blank);
    if (blank) continue;
    if (!ok) {
      drain();
      out.flush();
      printError("index", "stdin line " + std::to_string(in.lineNumber()) +
                              ": expected two floats 'u v', got '" + excerpt(line) + "'");
      return kExitUsage;
    }
    us.push_back(u);
    vs.push_back(v);
    if (us.size() == kBatch) drain();
  }
  drain();
  return kExitOk;
}

void setup(CLI::App& root) {
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = root.add_subcommand(
      "index",
      "Map barycentrics to bird-curve micro-triangle indices. Reads one 'u v' pair per line from stdin "
      "(decimal or "
      "hex floats, parsed like strtof; u, v = weights of vertices 1 and 2) and prints one index per line.");
  somm::cli::addRequiredLevel(cmd, opts->level);
  cmd->callback([opts] { somm::cli::setExitCode(run(*opts)); });
}

const somm::cli::Registration reg("index", &setup);

}  // namespace
