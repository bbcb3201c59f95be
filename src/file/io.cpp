// SPDX-License-Identifier: MIT
// Whole-file reading and atomic writing (temporary file + fsync + rename).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>

#include "somm/somm_file.h"

namespace somm {

namespace {

std::string sysError(const std::string& path, const char* what) {
  return path + ": " + what + ": " + std::strerror(errno);
}

std::string directoryOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

}  // namespace

Status writeFileAtomically(const std::string& path, Span<const uint8_t> bytes) {
  if (path.empty()) return makeError(ErrorCode::InvalidArgument, "empty output path");
  if (!path.empty() && path.back() == '/')
    return makeError(ErrorCode::InvalidArgument, path + ": is a directory name");
  struct stat st;
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    return makeError(ErrorCode::IoError, path + ": is a directory");
  const std::string dir = directoryOf(path);
  std::string tmp = path + ".tmp.XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) return makeError(ErrorCode::IoError, sysError(path, "cannot create a temporary file"));
  auto fail = [&](const char* what) -> Status {
    const std::string msg = sysError(path, what);
    ::close(fd);
    ::unlink(tmp.c_str());
    return makeError(ErrorCode::IoError, msg);
  };
  // mkstemp creates 0600; use the permissions an ordinary new file would get (0666 & ~umask).
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0) return fail("cannot set permissions");
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t w = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (w < 0) {
      if (errno == EINTR) continue;
      return fail("write failed");
    }
    done += size_t(w);
  }
  if (::fsync(fd) != 0) return fail("fsync failed");
  if (::close(fd) != 0) {
    const std::string msg = sysError(path, "close failed");
    ::unlink(tmp.c_str());
    return makeError(ErrorCode::IoError, msg);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string msg = sysError(path, "cannot rename the temporary file into place");
    ::unlink(tmp.c_str());
    return makeError(ErrorCode::IoError, msg);
  }
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dfd >= 0) {
    (void)::fsync(dfd);  // best effort: some file systems refuse fsync on directories
    ::close(dfd);
  }
  return Ok{};
}

Result<std::vector<uint8_t>> readWholeFile(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return makeError(ErrorCode::IoError, sysError(path, "cannot open"));
  struct stat st;
  if (::fstat(fd, &st) != 0) {
    const std::string msg = sysError(path, "cannot stat");
    ::close(fd);
    return makeError(ErrorCode::IoError, msg);
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return makeError(ErrorCode::IoError, path + ": not a regular file");
  }
  std::vector<uint8_t> bytes(size_t(st.st_size));
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t r = ::read(fd, bytes.data() + done, bytes.size() - done);
    if (r < 0) {
      if (errno == EINTR) continue;
      const std::string msg = sysError(path, "read failed");
      ::close(fd);
      return makeError(ErrorCode::IoError, msg);
    }
    if (r == 0) break;  // the file shrank while we read it: parse what we got
    done += size_t(r);
  }
  bytes.resize(done);
  ::close(fd);
  return bytes;
}

Status writeSommFile(const std::string& path, const SommFile& file) {
  auto bytes = serializeSomm(file);
  if (!bytes) return makeError(bytes.error().code, path + ": not written: " + bytes.error().message);
  return writeFileAtomically(path, *bytes);
}

Result<SommFile> readSommFile(const std::string& path) {
  auto bytes = readWholeFile(path);
  if (!bytes) return bytes.error();
  return parseSomm(*bytes, path);
}

Result<SceneMicromaps> readSceneMicromaps(const std::string& path) {
  auto file = readSommFile(path);
  if (!file) return file.error();
  return std::move(file->micromaps);
}

}  // namespace somm
