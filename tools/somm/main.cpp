// SPDX-License-Identifier: MIT
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <new>
#include <vector>

#include "command.h"
#include "somm/io.h"

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

Registration::Registration(const char* name, SetupFn setup) {
  registry().push_back({name, setup});
}

void setExitCode(int code) {
  g_exitCode = code;
}

void printError(std::string_view command, std::string_view message) {
  // Names from files inside messages: control bytes (a newline would forge a second line, escape sequences
  // reach the terminal) and invalid UTF-8 as \xNN, so the message is always one printable line.
  const std::string m = escapeName(std::string(message));
  std::fprintf(stderr, "somm %.*s: %s\n", int(command.size()), command.data(), m.c_str());
}

namespace {
bool g_stdoutFailed = false;
}  // namespace

void Output::flush() {
  if (!buf_.empty() && !g_stdoutFailed) {
    if (std::fwrite(buf_.data(), 1, buf_.size(), stdout) != buf_.size()) g_stdoutFailed = true;
  }
  buf_.clear();
  if (!g_stdoutFailed && std::fflush(stdout) != 0) g_stdoutFailed = true;
}

void Output::putUInt(uint64_t v) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof tmp, v);
  buf_.append(tmp, size_t(r.ptr - tmp));
  if (buf_.size() >= (1 << 16)) flush();
}

}  // namespace somm::cli

// Everything after CLI::App's construction runs inside the try; an allocation failure in the constructor itself
// terminates at startup, before any work.
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  using namespace somm::cli;
#if (defined(__GNUC__) || defined(__clang__)) && defined(__POPCNT__) && \
    (defined(__x86_64__) || defined(__i386__))
  // Built with -mpopcnt (CMake option SOMM_POPCNT): refuse to run on a CPU without the instruction rather than
  // die of an illegal instruction in the middle of a command.
  if (!__builtin_cpu_supports("popcnt")) {
    std::fputs(
        "somm: this build uses the POPCNT instruction (x86-64-v2), which this CPU lacks; rebuild with "
        "-DSOMM_POPCNT=OFF\n",
        stderr);
    return kExitFailure;
  }
#endif
  CLI::App app{"somm — Succinct Opacity MicroMaps: bake, compress, inspect and ray trace opacity micromaps",
               "somm"};
  try {
    app.set_version_flag("--version", std::string("somm ") + SOMM_VERSION);
    app.require_subcommand(1);
    // Only the named command's options are built when the first word names one (start-up: building every
    // command's options is most of the CLI's own start-up work); otherwise (help, an option, an unknown word) all.
    bool named = false;
    if (argc > 1)
      for (const auto& e : registry())
        if (std::strcmp(argv[1], e.name) == 0) {
          e.setup(app);
          named = true;
          break;
        }
    if (!named)
      for (const auto& e : registry()) e.setup(app);
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
    if (app.get_subcommands().empty() && argc > 1 && argv[1][0] != '-')
      msg = "unknown command '" + excerpt(argv[1]) + "'";
    std::fprintf(stderr, "somm: %s\n", msg.c_str());
    std::fprintf(stderr, "Run with --help for more information.\n");
    return kExitUsage;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "somm %s: out of memory\n",
                 app.get_subcommands().empty() ? "" : app.get_subcommands()[0]->get_name().c_str());
    return kExitFailure;
  } catch (const std::length_error&) {
    std::fprintf(stderr, "somm %s: out of memory (a size beyond what can be allocated)\n",
                 app.get_subcommands().empty() ? "" : app.get_subcommands()[0]->get_name().c_str());
    return kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "somm: internal error: %s\n", somm::escapeName(e.what()).c_str());
    return kExitFailure;
  }
  // Output written with printf or through Output: a failed write or flush (a full disk, /dev/full, a closed
  // pipe) is a failure, never a silent success.
  if (!g_stdoutFailed && std::fflush(stdout) != 0) g_stdoutFailed = true;
  if (!g_stdoutFailed && std::ferror(stdout)) g_stdoutFailed = true;
  if (g_stdoutFailed) {
    const int e = errno;
    std::fprintf(stderr, "somm %s: cannot write to standard output: %s\n",
                 app.get_subcommands().empty() ? "" : app.get_subcommands()[0]->get_name().c_str(),
                 std::strerror(e ? e : EIO));
    return g_exitCode == kExitOk ? kExitFailure : g_exitCode;
  }
  return g_exitCode;
}
