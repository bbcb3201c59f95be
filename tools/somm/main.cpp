#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>
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

bool LineReader::next(std::string_view& line) {
  for (;;) {
    const size_t nl = buf_.find('\n', pos_);
    if (nl != std::string::npos) {
      line = std::string_view(buf_).substr(pos_, nl - pos_);
      pos_ = nl + 1;
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++lineNo_;
      return true;
    }
    if (eof_) {
      if (pos_ >= buf_.size()) return false;
      line = std::string_view(buf_).substr(pos_);
      pos_ = buf_.size();
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      ++lineNo_;
      return true;
    }
    buf_.erase(0, pos_);
    pos_ = 0;
    const size_t old = buf_.size();
    buf_.resize(old + (1 << 16));
    const size_t got = std::fread(buf_.data() + old, 1, 1 << 16, f_);
    buf_.resize(old + got);
    if (got == 0) eof_ = true;
  }
}

std::string_view nextToken(std::string_view& rest) {
  size_t i = 0;
  while (i < rest.size() && (rest[i] == ' ' || rest[i] == '\t' || rest[i] == '\r' || rest[i] == '\v' || rest[i] == '\f'))
    ++i;
  size_t j = i;
  while (j < rest.size() && !(rest[j] == ' ' || rest[j] == '\t' || rest[j] == '\r' || rest[j] == '\v' || rest[j] == '\f'))
    ++j;
  const std::string_view tok = rest.substr(i, j - i);
  rest.remove_prefix(j);
  return tok;
}

bool parseFloat(std::string_view token, float& out) {
  if (token.empty() || token.size() > 4096) return false;
  char local[128];
  std::string heap;
  const char* s;
  if (token.size() < sizeof local) {
    std::memcpy(local, token.data(), token.size());
    local[token.size()] = '\0';
    s = local;
  } else {
    heap.assign(token);
    s = heap.c_str();
  }
  char* end = nullptr;
  errno = 0;
  out = std::strtof(s, &end);  // ERANGE (overflow to inf, underflow to 0/denormal) is accepted: that is strtof's value
  return end == s + token.size();
}

bool parseUInt(std::string_view token, uint64_t& out) {
  if (token.empty()) return false;
  const auto r = std::from_chars(token.data(), token.data() + token.size(), out);
  return r.ec == std::errc() && r.ptr == token.data() + token.size();
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
    std::fprintf(stderr, "somm: %s\n", msg.c_str());
    std::fprintf(stderr, "Run with --help for more information.\n");
    return kExitUsage;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "somm: internal error: %s\n", e.what());
    return kExitFailure;
  }
  return g_exitCode;
}
