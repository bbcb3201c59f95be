// SPDX-License-Identifier: MIT
#include <charconv>
#include <vector>

#include "command.h"

namespace somm::cli {

namespace {
struct Entry {
  const char* name;
  SetupFn setup;
};
std::vector<Entry>& registry() {
  static std::vector<Entry> r;
  return r;
}
int g_exitCode = kExitOk;
}  // namespace

Registration::Registration(const char* name, SetupFn setup) { registry().push_back({name, setup}); }

void setExitCode(int code) { g_exitCode = code; }

void printError(std::string_view command, std::string_view message) {
  std::fprintf(stderr, "somm %.*s: %.*s\n", int(command.size()), command.data(), int(message.size()), message.data());
}

void Output::putUInt(uint64_t v) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  buf_.append(tmp, size_t(r.ptr - tmp));
  if (buf_.size() >= (1 << 16)) flush();
}

void Output::flush() {
  if (!buf_.empty()) std::fwrite(buf_.data(), 1, buf_.size(), stdout);
  buf_.clear();
  std::fflush(stdout);
}

}  // namespace somm::cli

int main(int argc, char** argv) {
  using namespace somm::cli;
  CLI::App app{"somm — Succinct Opacity MicroMaps: bake, compress, inspect and ray trace opacity micromaps", "somm"};
  app.set_version_flag("--version", std::string("somm ") + SOMM_VERSION);
  app.require_subcommand(1);
  for (const auto& e : registry()) e.setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string msg = e.what();
    // An unknown first word: say so instead of CLI11's "A subcommand is required".
    if (app.get_subcommands().empty() && argc > 1 && argv[1][0] != '-') msg = "unknown command '" + excerpt(argv[1]) + "'";
    std::fprintf(stderr, "somm: %s\n", msg.c_str());
    std::fprintf(stderr, "Run with --help for more information.\n");
    return kExitUsage;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "somm: internal error: %s\n", e.what());
    return kExitFailure;
  }
  return g_exitCode;
}
