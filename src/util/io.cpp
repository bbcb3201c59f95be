// SPDX-License-Identifier: MIT
// somm — reading regular files with a size cap, atomic writing, staged directories, escaping (somm/io.h).
#include "somm/io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <new>
#include <system_error>

#include "somm/limits.h"

namespace somm {

namespace {

std::string sysError(const std::string& path, const char* what) {
  return escapeName(path) + ": " + what + ": " + std::strerror(errno);
}

std::string directoryOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

std::string baseOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

const char* typeName(mode_t m) {
  if (S_ISDIR(m)) return "a directory";
  if (S_ISFIFO(m)) return "a FIFO";
  if (S_ISCHR(m)) return "a character device";
  if (S_ISBLK(m)) return "a block device";
  if (S_ISSOCK(m)) return "a socket";
  return "not a regular file";
}

std::string humanBytes(uint64_t v) {
  return std::to_string(v) + " bytes";
}

void fsyncDirectory(const std::string& dir) {
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    (void)::fsync(dfd);  // best effort: some file systems refuse fsync on directories
    ::close(dfd);
  }
}

}  // namespace

Result<OpenedFile> openRegularFile(const std::string& path, uint64_t maxBytes, const char* kind,
                                   const char* limitName) {
  // O_NONBLOCK: opening a FIFO without a writer would block forever; it is refused below anyway.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) return makeError(ErrorCode::IoError, sysError(path, "cannot open"));
  struct stat st;
  if (::fstat(fd, &st) != 0) {
    const std::string msg = sysError(path, "cannot stat");
    ::close(fd);
    return makeError(ErrorCode::IoError, msg);
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return makeError(ErrorCode::IoError, escapeName(path) + ": not a regular file (" + typeName(st.st_mode) +
                                             "); only regular files are read");
  }
  if (uint64_t(st.st_size) > maxBytes) {
    ::close(fd);
    return makeError(ErrorCode::LimitExceeded, escapeName(path) + ": " + kind + " of " +
                                                   humanBytes(uint64_t(st.st_size)) + " exceeds " +
                                                   limitHint(limitName, maxBytes));
  }
  (void)::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  return OpenedFile{fd, uint64_t(st.st_size)};
}

Result<std::vector<uint8_t>> readRegularFile(const std::string& path, uint64_t maxBytes, const char* kind,
                                             const char* limitName) {
  auto opened = openRegularFile(path, maxBytes, kind, limitName);
  if (!opened) return opened.error();
  const int fd = opened->fd;
  std::vector<uint8_t> bytes;
  try {
    bytes.resize(size_t(opened->size));
  } catch (const std::bad_alloc&) {
    ::close(fd);
    return makeError(ErrorCode::LimitExceeded,
                     escapeName(path) + ": out of memory reading " + humanBytes(opened->size));
  }
  size_t done = 0;
  while (done < bytes.size()) {  // never more than the size stat reported: a growing file is cut there
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

Status writeFileAtomically(const std::string& path, const uint8_t* bytes, size_t size) {
  const std::pair<const uint8_t*, size_t> one{bytes, size};
  return writeFileAtomically(path, &one, 1);
}

Status writeFileAtomically(const std::string& path, const std::pair<const uint8_t*, size_t>* pieces,
                           size_t count) {
  if (path.empty()) return makeError(ErrorCode::InvalidArgument, "empty output path");
  if (path.back() == '/')
    return makeError(ErrorCode::InvalidArgument, escapeName(path) + ": is a directory name");
  struct stat st;
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
    return makeError(ErrorCode::IoError, escapeName(path) + ": exists and is " + typeName(st.st_mode) +
                                             "; refusing to replace it");
  const std::string dir = directoryOf(path);
  // A unique name in the target directory; mkostemp opens with O_CREAT | O_EXCL, so an existing file or
  // symlink of that name is never followed or reused.
  std::string tmp = (dir == "." && path.find('/') == std::string::npos ? std::string() : dir + "/") + "." +
                    baseOf(path) + ".tmp.XXXXXX";
  const int fd = ::mkostemp(tmp.data(), O_CLOEXEC);
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
  for (size_t i = 0; i < count; ++i) {
    const uint8_t* bytes = pieces[i].first;
    const size_t size = pieces[i].second;
    size_t done = 0;
    while (done < size) {
      const ssize_t w = ::write(fd, bytes + done, size - done);
      if (w < 0) {
        if (errno == EINTR) continue;
        return fail("write failed");
      }
      done += size_t(w);
    }
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
  fsyncDirectory(dir);
  return Ok{};
}

Status checkOutputPath(const std::string& output, const std::vector<std::string>& inputs) {
  struct stat so;
  if (::stat(output.c_str(), &so) != 0) return Ok{};  // does not exist (yet): cannot be an input
  if (!S_ISREG(so.st_mode))
    return makeError(ErrorCode::InvalidArgument, escapeName(output) + ": the output exists and is " +
                                                     typeName(so.st_mode) + "; refusing to replace it");
  for (const std::string& in : inputs) {
    struct stat si;
    if (::stat(in.c_str(), &si) == 0 && si.st_dev == so.st_dev && si.st_ino == so.st_ino)
      return makeError(ErrorCode::InvalidArgument, escapeName(output) + ": the output is the input " +
                                                       escapeName(in) + "; refusing to overwrite it");
  }
  return Ok{};
}

StagedDirectory::~StagedDirectory() {
  if (!staging_.empty() && !committed_) {
    std::error_code ec;
    std::filesystem::remove_all(staging_, ec);
  }
}

Status StagedDirectory::begin(const std::string& path) {
  path_ = path;
  while (path_.size() > 1 && path_.back() == '/') path_.pop_back();
  if (path_.empty()) return makeError(ErrorCode::InvalidArgument, "empty output directory");
  struct stat st;
  if (::lstat(path_.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode))
      return makeError(ErrorCode::IoError, escapeName(path_) + ": exists and is not a directory");
    std::error_code ec;
    if (!std::filesystem::is_empty(path_, ec) || ec)
      return makeError(ErrorCode::IoError,
                       escapeName(path_) +
                           ": the output directory exists and is not empty (its files are "
                           "kept; export into a new or empty directory)");
  }
  const std::string parent = directoryOf(path_);
  std::error_code ec;
  std::filesystem::create_directories(parent, ec);
  std::string tmp = (parent == "." && path_.find('/') == std::string::npos ? std::string() : parent + "/") +
                    "." + baseOf(path_) + ".tmp.XXXXXX";
  if (!::mkdtemp(tmp.data()))
    return makeError(ErrorCode::IoError, sysError(path_, "cannot create a temporary directory"));
  staging_ = tmp;
  return Ok{};
}

Status StagedDirectory::commit() {
  if (staging_.empty()) return makeError(ErrorCode::InvalidArgument, "StagedDirectory::commit before begin");
  fsyncDirectory(staging_);
  if (::rename(staging_.c_str(), path_.c_str()) != 0)
    return makeError(ErrorCode::IoError, sysError(path_, "cannot rename the temporary directory into place"));
  committed_ = true;
  fsyncDirectory(directoryOf(path_));
  return Ok{};
}

std::string escapeName(const std::string& s) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  out.reserve(s.size());
  auto esc = [&](unsigned char c) {
    out += "\\x";
    out += hex[c >> 4];
    out += hex[c & 15];
  };
  const size_t n = s.size();
  for (size_t i = 0; i < n;) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      if (c < 0x20 || c == 0x7f)
        esc(c);
      else
        out += char(c);
      ++i;
      continue;
    }
    // A well-formed UTF-8 sequence (no overlongs, no surrogates, ≤ U+10FFFF, not a C1 control) stays.
    size_t len = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 ? 2 : 0;
    uint32_t cp = len == 4 ? c & 7u : len == 3 ? c & 15u : c & 31u;
    bool ok = len > 0 && c <= 0xF4 && i + len <= n;
    for (size_t k = 1; ok && k < len; ++k) {
      const unsigned char d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xC0) != 0x80) ok = false;
      cp = cp << 6 | (d & 0x3Fu);
    }
    if (ok) {
      const uint32_t minimum = len == 2 ? 0x80 : len == 3 ? 0x800 : 0x10000;
      ok = cp >= minimum && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF) && !(cp >= 0x80 && cp < 0xA0);
    }
    if (ok) {
      out.append(s, i, len);
      i += len;
    } else {
      esc(c);
      ++i;
    }
  }
  return out;
}

}  // namespace somm
